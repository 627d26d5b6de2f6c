// volcast calibrate: every camera's world_from_camera from depth alone (the lattice target where
// the cameras see it, targetless ICP over their overlap otherwise), the floor for room_from_site,
// a report of the residuals, a site config and a preview picture.
#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include "calibrate_preview.hpp"
#include "commands.hpp"
#include "real_sites.hpp"
#include "volcast/calibrate/floor.hpp"
#include "volcast/calibrate/target.hpp"
#include "volcast/calibrate/targetless.hpp"
#include "volcast/capture/camera_folder.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/io/site_config.hpp"

namespace volcast {
namespace fs = std::filesystem;
namespace {

struct Camera {
  std::string name;
  fs::path source;
  std::optional<Intrinsics> intrinsics;  ///< given to the source (a folder camera has none)
  std::unique_ptr<FrameSource> reader;
  RayTable rays;
  CameraFrame first;                        ///< the frame targetless registration uses
  std::vector<Eigen::Vector3d> cloud;       ///< of `first`, camera frame, metres
  std::vector<TargetObservation> observed;  ///< the target, per capture that found it
  double feature_rms_m = -1;
  std::string method;
};

// The intrinsics a camera folder's PNGs get: --intrinsics-from, else the Azure Kinect recording's
// factory NFOV calibration from the shared data (nominal for these cameras, said so in the report).
Intrinsics folder_intrinsics(const CalibrateArgs& a, const FolderCamera& c, std::string& note) {
  fs::path from = a.intrinsics_from;
  if (from.empty()) {
    const auto data = find_data("");
    if (!data)
      throw Error("camera " + c.serial + ": the folder's PNGs carry no intrinsics; give " +
                  "--intrinsics-from (an Azure Kinect .mkv or an image-sequence folder)");
    from = *data / kKinectSet;
    note = "NOMINAL intrinsics: the Azure Kinect recording's factory NFOV calibration (" +
           from.string() + "), not these cameras' own";
  } else {
    note = "intrinsics from " + from.string();
  }
  return open_source(from)->calibration().depth;
}

std::vector<Camera> open_cameras(const CalibrateArgs& a, std::vector<std::string>& notes) {
  std::vector<Camera> cameras;
  for (const std::string& s : a.sources) {
    const fs::path path(s);
    const auto folder =
        fs::is_directory(path) ? list_folder_cameras(path) : std::vector<FolderCamera>{};
    if (folder.empty()) {
      Camera c;
      c.name = path.filename().string();
      c.source = path;
      cameras.push_back(std::move(c));
      continue;
    }
    for (const FolderCamera& f : folder) {
      std::string note;
      Camera c;
      c.name = f.serial;
      c.source = f.depth.front();
      c.intrinsics = folder_intrinsics(a, f, note);
      if (notes.empty() || notes.back() != note) notes.push_back(note);
      cameras.push_back(std::move(c));
    }
  }
  if (cameras.empty()) throw Error("calibrate: give at least one --source");
  for (Camera& c : cameras) {
    SourceOptions o;
    o.intrinsics = c.intrinsics;
    c.reader = open_source(c.source, o);
    c.rays = make_ray_table(c.reader->calibration().depth);
  }
  return cameras;
}

// Reads up to a.frames frame sets (camera i's frame k = capture k) and looks for the target in
// each; keeps every camera's first frame for the targetless step.
void scan(const CalibrateArgs& a, std::vector<Camera>& cameras) {
  int frames = a.frames;
  for (const Camera& c : cameras) frames = std::min(frames, c.reader->frame_count());
  frames = std::max(frames, 1);
  const TargetModel model = lattice_target();
  CameraFrame frame;
  for (int k = 0; k < frames; ++k) {
    for (size_t i = 0; i < cameras.size(); ++i) {
      Camera& c = cameras[i];
      c.reader->next(frame);
      if (k == 0) c.first = frame;
      if (a.no_target) continue;
      const TargetDetection d = detect_target(frame.depth, c.rays, model);
      if (!d.found) {
        if (k == 0) spdlog::debug("camera {} ({}): {}", i, c.name, d.why_not);
        continue;
      }
      TargetObservation o;
      o.camera = static_cast<int>(i);
      o.capture = k;
      for (const FoundSphere& s : d.spheres)
        if (s.model_index >= 0) o.centres.emplace_back(s.model_index, s.centre_m);
      c.observed.push_back(std::move(o));
    }
    if (frames > 1 && (k + 1) % 10 == 0)
      std::fprintf(stderr, "\rcalibrate: scanned %d of %d frame sets for the target", k + 1,
                   frames);
  }
  if (frames > 1) std::fprintf(stderr, "\n");
  for (Camera& c : cameras) c.cloud = depth_points(c.first.depth, c.rays, 1, 0.25, 6.0);
}

// The source as the site config names it: relative to the config's folder when that stays near
// it (the pair can move together), else absolute.
std::string relative_to(const fs::path& file, const fs::path& dir) {
  std::error_code ec;
  const fs::path absolute = fs::weakly_canonical(fs::absolute(file), ec);
  const fs::path rel = fs::relative(absolute, fs::weakly_canonical(fs::absolute(dir)), ec);
  if (ec || rel.empty() || rel.string().rfind("../..", 0) == 0) return absolute.string();
  return rel.string();
}

}  // namespace

int run_calibrate(const CalibrateArgs& a) {
  std::vector<std::string> notes;
  std::vector<Camera> cameras = open_cameras(a, notes);
  const size_t n = cameras.size();
  if (a.reference < 0 || static_cast<size_t>(a.reference) >= n)
    throw Error("calibrate: --reference " + std::to_string(a.reference) + " is not one of the " +
                std::to_string(n) + " cameras");
  spdlog::info("calibrate: {} cameras", n);
  for (size_t i = 0; i < n; ++i)
    spdlog::info("  camera {} ({}): {}", i, cameras[i].name, cameras[i].reader->description());
  for (const auto& note : notes) spdlog::warn("{}", note);
  scan(a, cameras);

  // 1. The target, where the cameras saw it.
  std::vector<std::optional<RigidTransform>> start(n);
  std::vector<TargetObservation> observations;
  int captures = 0;
  for (const Camera& c : cameras)
    for (const auto& o : c.observed) {
      observations.push_back(o);
      captures = std::max(captures, o.capture + 1);
    }
  if (!observations.empty()) {
    // The world: the reference camera's frame if it saw the target, else the target's first
    // placement.
    const int world_camera =
        a.reference_target || cameras[static_cast<size_t>(a.reference)].observed.empty()
            ? -1
            : a.reference;
    const TargetSolution s =
        solve_target_registration(static_cast<int>(n), captures, observations, world_camera);
    for (size_t i = 0; i < n; ++i)
      if (s.world_from_camera[i]) {
        start[i] = s.world_from_camera[i];
        cameras[i].feature_rms_m = s.rms_m[i];
        cameras[i].method = "target";
        spdlog::info("camera {} ({}): placed by the target, {} sphere centres, RMS {:.2f} mm", i,
                     cameras[i].name, s.features[i], s.rms_m[i] * 1e3);
      }
    for (const auto& p : s.problems) spdlog::warn("target: {}", p);
  } else if (!a.no_target) {
    spdlog::info("calibrate: no camera sees the lattice target; registering without it");
  }
  // A rough start from a site config (e.g. the viewer's sliders) for the cameras the target left.
  if (!a.start.empty()) {
    const auto poses = read_site_poses(a.start);
    for (size_t i = 0; i < n && i < poses.size(); ++i)
      if (!start[i] && poses[i]) {
        start[i] = poses[i];
        cameras[i].method = "start";
      }
  }

  // 2. Targetless: the cameras nothing placed yet (and, with --refine, all of them).
  std::vector<std::vector<Eigen::Vector3d>> clouds;
  for (const Camera& c : cameras) clouds.push_back(c.cloud);
  std::vector<TargetlessCamera> views;
  for (const Camera& c : cameras)
    views.push_back({c.cloud, c.first.depth, c.reader->calibration().depth});
  bool need = a.refine;
  for (size_t i = 0; i < n; ++i) need = need || !start[i] || cameras[i].method == "start";
  std::vector<std::optional<RigidTransform>> pose = start;
  TargetlessResult t;
  if (need && n > 1) {
    TargetlessOptions o;
    o.progress = [](const std::string& line) { spdlog::info("  {}", line); };
    spdlog::info(
        "calibrate: registering over the cameras' overlap: {}, {}...",
        std::all_of(start.begin(), start.end(), [](const auto& p) { return p.has_value(); })
            ? "the start poses and FPFH + RANSAC hypotheses near them"
            : "FPFH + RANSAC hypotheses",
        "checked against free space, then ICP; a minute or two per camera on 2 cores");
    // The anchor keeps its pose: the reference, or (when the target placed others but not it) the
    // first camera the target placed, so both methods share one world.
    int anchor = a.reference;
    if (!start[static_cast<size_t>(anchor)])
      for (size_t i = 0; i < n; ++i)
        if (start[i] && cameras[i].method == "target") {
          anchor = static_cast<int>(i);
          break;
        }
    t = register_targetless(views, start, anchor, o);
    for (size_t i = 0; i < n; ++i) {
      if (cameras[i].method == "target" && !a.refine) continue;  // the target is more accurate
      pose[i] = t.world_from_camera[i];
      cameras[i].method = cameras[i].method.empty()      ? "targetless"
                          : cameras[i].method == "start" ? "start + ICP"
                                                         : cameras[i].method + " + ICP";
    }
  } else if (n == 1) {
    pose[0] = pose[0].value_or(RigidTransform{});
    cameras[0].method = cameras[0].method.empty() ? "single camera" : cameras[0].method;
  }

  // 3. The floor: room_from_site.
  std::vector<RigidTransform> placed;
  std::vector<std::vector<Eigen::Vector3d>> placed_clouds;
  for (size_t i = 0; i < n; ++i)
    if (pose[i]) {
      placed.push_back(*pose[i]);
      placed_clouds.push_back(clouds[i]);
    }
  std::optional<FloorPlane> floor;
  if (!a.no_floor && !placed.empty()) {
    std::string why;
    floor = find_floor(placed_clouds, placed, std::nullopt, why);
    if (floor) {
      const RigidTransform room = room_from_site(*floor, placed);
      for (auto& p : pose)
        if (p) p = room * *p;
      spdlog::info("floor: {} ({:.0f}% of samples, RMS {:.1f} mm); the room frame has it at y = 0",
                   floor->reason, floor->share * 100, floor->rms_m * 1e3);
    } else {
      spdlog::warn("floor: {}; the site keeps camera {}'s frame", why, a.reference);
    }
  }

  // 4. The report.
  const std::vector<CameraOverlap> overlap = measure_overlap(clouds, pose, 0.01, 0.03);
  const size_t placed_count = static_cast<size_t>(
      std::count_if(pose.begin(), pose.end(), [](const auto& p) { return p.has_value(); }));
  std::printf("\n%-3s %-14s %-16s %10s %9s %11s %11s %9s\n", "cam", "name", "method", "target mm",
              "overlap", "RMS before", "RMS mm", "height m");
  for (size_t i = 0; i < n; ++i) {
    const Camera& c = cameras[i];
    const std::string target =
        c.feature_rms_m >= 0 ? fmt::format("{:.2f}", c.feature_rms_m * 1e3) : "-";
    const std::string before = i < t.before.size() && t.before[i].points > 0
                                   ? fmt::format("{:.1f}", t.before[i].rms_m * 1e3)
                                   : "-";
    if (!pose[i]) {
      std::printf("%-3zu %-14s %-16s %10s %9s %11s %11s %9s\n", i, c.name.c_str(), "NOT PLACED",
                  target.c_str(), "-", before.c_str(), "-", "-");
      continue;
    }
    const std::string height = floor ? fmt::format("{:.2f}", pose[i]->translation.y()) : "-";
    std::printf("%-3zu %-14s %-16s %10s %8.1f%% %11s %11.1f %9s\n", i, c.name.c_str(),
                c.method.c_str(), target.c_str(), overlap[i].fraction * 100, before.c_str(),
                overlap[i].rms_m * 1e3, height.c_str());
  }
  std::printf(
      "target mm: RMS of the sphere centres after the solve; overlap: share of the camera's "
      "samples within 30 mm of another camera's surface; RMS: their point-to-plane distance\n\n");
  std::vector<std::string> problems = t.problems;
  for (size_t i = 0; i < n; ++i)
    if (!pose[i] && std::none_of(problems.begin(), problems.end(), [&](const std::string& p) {
          return p.rfind("camera " + std::to_string(i) + ":", 0) == 0;
        }))
      problems.push_back("camera " + std::to_string(i) + ": could not be placed");
  for (const auto& p : problems) spdlog::error("{}", p);

  // 5. The site config and the preview.
  const fs::path out(a.out);
  const fs::path out_dir = out.has_parent_path() ? out.parent_path() : fs::path(".");
  std::vector<SiteCamera> site;
  for (size_t i = 0; i < n; ++i) {
    SiteCamera s;
    s.source = relative_to(cameras[i].source, out_dir);
    s.name = cameras[i].name;
    s.intrinsics = cameras[i].intrinsics;
    s.world_from_camera = pose[i];
    if (pose[i]) {
      SiteRegistration r;
      r.method = cameras[i].method;
      r.feature_rms_mm = cameras[i].feature_rms_m >= 0 ? cameras[i].feature_rms_m * 1e3 : -1;
      r.overlap_rms_mm = overlap[i].points > 0 ? overlap[i].rms_m * 1e3 : -1;
      s.registration = r;
    }
    site.push_back(std::move(s));
  }
  write_site_config(out, site);
  spdlog::info("wrote {} ({} of {} cameras placed)", out.string(), placed_count, n);
  if (!a.preview.empty()) {
    std::vector<CameraCalibration> calibrations;
    std::vector<CameraFrame> frames;
    for (size_t i = 0; i < n; ++i)
      if (pose[i]) {
        CameraCalibration cal = cameras[i].reader->calibration();
        cal.world_from_camera = *pose[i];
        calibrations.push_back(cal);
        frames.push_back(cameras[i].first);
      }
    write_calibration_preview(a.preview, calibrations, frames, floor.has_value());
    spdlog::info("wrote {} (from above, and from the side)", a.preview);
  }
  return problems.empty() ? 0 : 3;
}

}  // namespace volcast
