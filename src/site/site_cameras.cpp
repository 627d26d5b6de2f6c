// The site's cameras: a recording replayed, or the site config's and --source's cameras with
// their filters and the capture nodes' cameras on NATS, each logged as viewers will see it.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <Eigen/Geometry>

#include "site_parts.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/io/site_config.hpp"

namespace volcast::detail {
namespace {

FilterConfig filters_of(const SiteServerOptions& a, size_t camera) {
  return a.filters ? a.filters(camera) : FilterConfig{};
}

// Cameras from the site config file (if any), then from --source, each with its filters.
void load_site(const SiteServerOptions& a, std::vector<std::unique_ptr<FrameSource>>& sources,
               std::vector<FilterConfig>& filters, std::vector<std::string>& names) {
  SourceOptions defaults;
  defaults.intrinsics = a.intrinsics;
  if (!a.site_config.empty()) {
    const std::vector<SiteCamera> cameras = read_site_config(a.site_config);
    for (const SiteCamera& cam : cameras) {
      const std::string where =
          "site config '" + a.site_config + "' camera " + std::to_string(sources.size());
      SourceOptions opt = defaults;
      if (cam.intrinsics) opt.intrinsics = *cam.intrinsics;
      if (const auto& pose = cam.world_from_camera) {
        opt.world_from_camera = *pose;
        const Eigen::Vector3d t = pose->translation, r = degrees_from_rotation(pose->rotation);
        spdlog::info(
            "camera {}: placed by the site config at ({:.3f}, {:.3f}, {:.3f}) m, turned "
            "({:.2f}, {:.2f}, {:.2f}) deg",
            sources.size(), t.x(), t.y(), t.z(), r.x(), r.y(), r.z());
      }
      FilterConfig f = filters_of(a, sources.size());
      if (!cam.filters_json.empty()) {
        try {
          apply_filter_json(cam.filters_json, f);
        } catch (const Error& e) {
          throw Error(where + ": " + e.what());
        }
      }
      const std::string name =
          cam.name.empty() ? "camera " + std::to_string(sources.size()) : cam.name;
      sources.push_back(open_source(resolve_site_source(cam.source, a.site_config), opt));
      filters.push_back(f);
      names.push_back(name);
    }
  }
  for (const auto& path : a.sources) {
    filters.push_back(filters_of(a, sources.size()));
    names.push_back("camera " + std::to_string(sources.size()));
    sources.push_back(open_source(path, defaults));
  }
}

// The cameras: a recording replayed, or the site's sources (--config, --source) and the capture
// nodes' cameras (--nats-cameras) in a SitePlayer; logs each.
}  // namespace

void open_cameras(SiteParts& s) {
  const SiteServerOptions& a = s.options;
  std::vector<std::unique_ptr<FrameSource>> sources;
  std::vector<FilterConfig> filters;
  std::vector<std::string> names;
  if ((!a.nats_cameras.empty() || a.camera_only) && !a.nats)
    throw Error("serve: --nats-cameras and --camera-only need --nats");
  if (a.nats) s.nats.emplace(*a.nats);
  if (!a.replay_path.empty()) {
    s.replay.emplace(a.replay_path, a.replay);
    const RecordingInfo& info = s.replay->info();
    spdlog::info(
        "replaying {}: {} frame sets, {:.1f} s, tier {} (passed through as "
        "recorded to viewers of that tier){}",
        a.replay_path, info.frame_sets.size(),
        static_cast<double>(s.replay->timeline().duration_us()) / 1e6, to_string(info.stream.tier),
        info.closed ? "" : "; not closed by its recorder, indexed by scanning");
    for (const VoicePlan::Speaker& v : s.replay->voices().speakers)
      spdlog::info("replaying the voice of '{}': {} packets (as '{} (recorded)' in the sessions)",
                   printable(v.speaker.name), v.packets, printable(v.speaker.name));
    for (const auto& c : s.replay->cameras()) {
      names.push_back(c.description);
      filters.emplace_back();
    }
  } else {
    load_site(a, sources, filters, names);
    for (const std::string& node : a.nats_cameras) {
      cluster::RemoteSiteOptions o;
      o.site = node;
      o.tier = a.nats_camera_tier;
      o.fps = a.fps > 0 ? a.fps : 30;
      s.nodes.push_back(std::make_unique<cluster::RemoteSite>(*s.nats, o));
      auto node_sources = s.nodes.back()->sources();
      for (size_t i = 0; i < node_sources.size(); ++i) {
        names.push_back(node + ": " + s.nodes.back()->cameras()[i].description);
        sources.push_back(std::move(node_sources[i]));
        filters.emplace_back();  // filtered on the node
      }
    }
    if (sources.empty())
      throw Error("serve: give at least one --source, a --config with cameras or --nats-cameras");
  }
  std::vector<std::string> color_notes(names.size());  // per camera: ", no color" etc.
  for (size_t i = 0; i < sources.size(); ++i) {
    const int color = sources[i]->color_frame_count(), frames = sources[i]->frame_count();
    color_notes[i] = color == 0 ? ", NO COLOR (depth only)"
                     : color < frames
                         ? fmt::format(", no color in {} of {} frames", frames - color, frames)
                         : "";
  }
  if (!s.replay) {
    SiteOptions site_options;
    site_options.max_read_failures = a.max_read_failures;
    s.site.emplace(std::move(sources), a.fps, filters, std::move(site_options));
  }
  auto cameras = s.replay ? s.replay->cameras() : s.site->cameras();
  for (size_t i = 0; i < cameras.size(); ++i) {
    const auto& k = cameras[i].calibration.depth;
    spdlog::info("camera {}: {} (sent as {}x{}, fx {:.1f} fy {:.1f} cx {:.1f} cy {:.1f}{}{}{})", i,
                 cameras[i].description, k.width, k.height, k.fx, k.fy, k.cx, k.cy,
                 k.is_pinhole() ? ", pinhole" : ", Brown-Conrady",
                 filters[i].any() ? ", filtered" : "", color_notes[i]);
  }
  s.cameras = cameras;
  for (size_t i = 0; i < cameras.size(); ++i) s.cameras[i].description = names[i];
}

}  // namespace volcast::detail
