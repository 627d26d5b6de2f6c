// The quality table (quality_report.hpp): settings, site loading, scoring, pictures, JSON.
#include "volcast/quality/quality_report.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <fstream>
#include <nlohmann/json.hpp>

#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/io/site_config.hpp"

namespace volcast {
namespace fs = std::filesystem;
namespace {

std::string slug(const std::string& name) {
  std::string s;
  for (char c : name) {
    if (std::isalnum(static_cast<unsigned char>(c)))
      s += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
    else if (!s.empty() && s.back() != '-')
      s += '-';
  }
  while (!s.empty() && s.back() == '-') s.pop_back();
  return s;
}

ViewScore mean_of(const std::vector<ViewScore>& scores) {
  ViewScore m;
  for (const ViewScore& s : scores) {
    m.psnr_db += s.psnr_db;
    m.ssim += s.ssim;
    m.depth_mean_mm += s.depth_mean_mm;
    m.depth_p95_mm += s.depth_p95_mm;
    m.coverage += s.coverage;
    m.seam_energy += s.seam_energy;
    m.seam_error_energy += s.seam_error_energy;
    m.valid += s.valid;
    m.compared += s.compared;
    m.seam_pixels += s.seam_pixels;
  }
  const double n = scores.empty() ? 1.0 : double(scores.size());
  m.psnr_db /= n, m.ssim /= n, m.depth_mean_mm /= n, m.depth_p95_mm /= n, m.coverage /= n,
      m.seam_energy /= n, m.seam_error_energy /= n;
  return m;
}

size_t worst_camera(const std::vector<ViewScore>& scores) {
  size_t worst = 0;
  for (size_t k = 1; k < scores.size(); ++k) {
    const bool colour = scores[k].psnr_db > 0;
    if (colour ? scores[k].psnr_db < scores[worst].psnr_db
               : scores[k].depth_mean_mm > scores[worst].depth_mean_mm)
      worst = k;
  }
  return worst;
}

ColorImage stacked(const ColorImage& top, const ColorImage& bottom) {
  ColorImage out(top.width, top.height + bottom.height);
  std::copy(top.bgra.begin(), top.bgra.end(), out.bgra.begin());
  std::copy(bottom.bgra.begin(), bottom.bgra.end(),
            out.bgra.begin() + static_cast<std::ptrdiff_t>(top.bgra.size()));
  return out;
}

}  // namespace

std::vector<QualitySetting> quality_settings() {
  std::vector<QualitySetting> s;
  CameraPassOptions before;  // the renderer's default before issue 38
  before.surface = Surface::kSplats;
  before.splat_size = SplatSize::kAdaptive;
  before.blend = true;
  before.blend_weights = BlendWeights::kAngleDistance;
  before.balance_colour = false;
  s.push_back({"splats adaptive, blend v1 (before)", before});
  CameraPassOptions o = before;
  o.blend = false;
  s.push_back({"splats adaptive, no blend", o});
  o.splat_size = SplatSize::kFootprint;
  s.push_back({"splats footprint, no blend", o});
  o.splat_size = SplatSize::kFixedPixels;
  o.fixed_point_px = 2;
  s.push_back({"splats 2 px, no blend", o});
  o = before;
  o.surface = Surface::kMesh;
  o.blend = false;
  s.push_back({"mesh, no blend", o});
  o.blend = true;
  s.push_back({"mesh, blend v1", o});
  o = before;
  o.blend_weights = BlendWeights::kReliability;
  s.push_back({"splats adaptive, reliability blend", o});
  o.balance_colour = true;
  s.push_back({"splats adaptive, reliability blend + colour balance", o});
  o = before;
  o.surface = Surface::kMesh;
  o.blend_weights = BlendWeights::kReliability;
  s.push_back({"mesh, reliability blend", o});
  o.balance_colour = true;
  s.push_back({"mesh, reliability blend + colour balance", o});
  // The default as it is now, whichever row it equals.
  const CameraPassOptions now{};
  for (QualitySetting& q : s)
    if (q.options.surface == now.surface && q.options.splat_size == now.splat_size &&
        q.options.blend == now.blend && q.options.blend_weights == now.blend_weights &&
        q.options.balance_colour == now.balance_colour &&
        q.name.find("(before)") == std::string::npos)
      q.name += " (default)";
  return s;
}

QualitySite load_quality_site(const fs::path& site_config,
                              const std::optional<ColorCalibration>& nominal_color) {
  QualitySite site;
  const std::vector<SiteCamera> cameras = read_site_config(site_config);
  for (size_t i = 0; i < cameras.size(); ++i) {
    const SiteCamera& cam = cameras[i];
    if (!cam.world_from_camera)
      throw Error(
          fmt::format("{}: camera {} has no world_from_camera (register the site first: "
                      "volcast calibrate)",
                      site_config.string(), i));
    SourceOptions o;
    if (cam.intrinsics) o.intrinsics = *cam.intrinsics;
    o.world_from_camera = cam.world_from_camera;
    o.nominal_color = nominal_color;
    auto source = open_source(resolve_site_source(cam.source, site_config), o);
    site.cameras.push_back(source->calibration());
    site.frames.push_back(source->next());
    site.names.push_back(cam.name.empty() ? fmt::format("camera {}", i) : cam.name);
  }
  return site;
}

std::vector<QualityRow> score_settings(const QualitySite& site,
                                       const std::vector<QualitySetting>& settings,
                                       const fs::path& pictures) {
  LeaveOneOut loo(site.cameras, site.frames);
  std::vector<QualityRow> rows;
  std::vector<ColorImage> worst_pictures;
  size_t worst = 0;
  size_t default_row = 0;
  for (size_t r = 0; r < settings.size(); ++r) {
    spdlog::info("quality: {}/{} {} ({} cameras held out in turn)", r + 1, settings.size(),
                 settings[r].name, site.cameras.size());
    LeaveOneOut::Result result = loo.run(settings[r].options);
    QualityRow row{settings[r].name, mean_of(result.scores), result.scores, result.ms_per_frame};
    if (r == 0) worst = worst_camera(result.scores);
    if (settings[r].name.find("(default)") != std::string::npos) default_row = r;
    worst_pictures.push_back(side_by_side(result.views[worst]));
    rows.push_back(std::move(row));
  }
  if (!pictures.empty()) {
    fs::create_directories(pictures);
    for (size_t r = 0; r < settings.size(); ++r)
      write_color_png(pictures / ("quality-" + slug(settings[r].name) + ".png"), worst_pictures[r]);
    write_color_png(pictures / "quality.png",
                    stacked(worst_pictures[0], worst_pictures[default_row]));
    spdlog::info(
        "quality: pictures of {} (the worst camera) in {}: rendered | real | colour error "
        "| depth error; quality.png is before (top) and the default (bottom)",
        site.names[worst], pictures.string());
  }
  return rows;
}

std::string quality_table(const std::vector<QualityRow>& rows) {
  std::string t =
      "| setting | PSNR dB | SSIM | depth mean mm | depth p95 mm | coverage | seam energy | seam "
      "error energy | ms per view |\n| --- | --- | --- | --- | --- | --- | --- | --- | --- |\n";
  const QualityRow* base = rows.empty() ? nullptr : &rows[0];
  for (const QualityRow& r : rows) {
    const ViewScore& m = r.mean;
    const auto ratio = [](double a, double b) { return b > 0 ? a / b : 0.0; };
    t += fmt::format(
        "| {} | {:.2f} ({:+.2f}) | {:.3f} | {:.1f} | {:.1f} | {:.1f} % | {:.0f} ({:.2f}x) "
        "| {:.0f} ({:.2f}x) | {:.1f} ({:.2f}x) |\n",
        r.setting, m.psnr_db, m.psnr_db - base->mean.psnr_db, m.ssim, m.depth_mean_mm,
        m.depth_p95_mm, 100.0 * m.coverage, m.seam_energy,
        ratio(m.seam_energy, base->mean.seam_energy), m.seam_error_energy,
        ratio(m.seam_error_energy, base->mean.seam_error_energy), r.ms_per_frame,
        ratio(r.ms_per_frame, base->ms_per_frame));
  }
  return t;
}

void write_quality_json(const std::vector<QualityRow>& rows, const fs::path& file) {
  const auto figures = [](const ViewScore& s) {
    return nlohmann::json{{"psnr_db", s.psnr_db},
                          {"ssim", s.ssim},
                          {"depth_mean_mm", s.depth_mean_mm},
                          {"depth_p95_mm", s.depth_p95_mm},
                          {"coverage", s.coverage},
                          {"seam_energy", s.seam_energy},
                          {"seam_error_energy", s.seam_error_energy},
                          {"compared_pixels", s.compared},
                          {"seam_pixels", s.seam_pixels}};
  };
  nlohmann::json list = nlohmann::json::array();
  for (const QualityRow& r : rows) {
    nlohmann::json j = figures(r.mean);
    j["setting"] = r.setting;
    j["ms_per_frame"] = r.ms_per_frame;
    j["cameras"] = nlohmann::json::array();
    for (const ViewScore& s : r.cameras) j["cameras"].push_back(figures(s));
    list.push_back(j);
  }
  std::ofstream out(file);
  out << nlohmann::json{{"quality", list}}.dump(2) << "\n";
  if (!out) throw Error("cannot write " + file.string());
}

}  // namespace volcast
