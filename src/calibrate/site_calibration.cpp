// Calibrating a site (volcast calibrate): every camera's world_from_camera from depth alone (the
// lattice target where the cameras see it, targetless ICP over their overlap otherwise), the floor
// for room_from_site, the residuals and the site config.
#include "volcast/calibrate/site_calibration.hpp"

#include <spdlog/fmt/fmt.h>
#include <spdlog/spdlog.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <memory>

#include "volcast/calibrate/preview.hpp"
#include "volcast/calibrate/target.hpp"
#include "volcast/capture/camera_folder.hpp"
#include "volcast/capture/real_sites.hpp"
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
Intrinsics folder_intrinsics(const CalibrationOptions& a, const FolderCamera& c,
                             std::string& note) {
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

std::vector<Camera> open_cameras(const CalibrationOptions& a, std::vector<std::string>& notes) {
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
void scan(const CalibrationOptions& a, std::vector<Camera>& cameras) {
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

// 1. The target, where the cameras saw it: the start poses of the cameras it placed.
std::vector<std::optional<RigidTransform>> place_by_target(const CalibrationOptions& a,
                                                           std::vector<Camera>& cameras) {
  const size_t n = cameras.size();
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
  return start;
}

// 2. Targetless: the cameras nothing placed yet (and, with --refine, all of them). Returns the
// poses; `t` gets what the registration measured.
std::vector<std::optional<RigidTransform>> place_by_overlap(
    const CalibrationOptions& a, std::vector<Camera>& cameras,
    const std::vector<std::optional<RigidTransform>>& start, TargetlessResult& t) {
  const size_t n = cameras.size();
  std::vector<TargetlessCamera> views;
  for (const Camera& c : cameras)
    views.push_back({c.cloud, c.first.depth, c.reader->calibration().depth});
  bool need = a.refine;
  for (size_t i = 0; i < n; ++i) need = need || !start[i] || cameras[i].method == "start";
  std::vector<std::optional<RigidTransform>> pose = start;
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
  return pose;
}

// 3. The floor: room_from_site, applied to every pose.
std::optional<FloorPlane> align_floor(const CalibrationOptions& a,
                                      const std::vector<Camera>& cameras,
                                      std::vector<std::optional<RigidTransform>>& pose) {
  std::vector<RigidTransform> placed;
  std::vector<std::vector<Eigen::Vector3d>> placed_clouds;
  for (size_t i = 0; i < cameras.size(); ++i)
    if (pose[i]) {
      placed.push_back(*pose[i]);
      placed_clouds.push_back(cameras[i].cloud);
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
  return floor;
}

// 4. The result: the residuals at the final poses, and a problem for every camera left unplaced.
SiteCalibration summarise(std::vector<Camera>& cameras,
                          const std::vector<std::optional<RigidTransform>>& pose,
                          std::optional<FloorPlane> floor, const TargetlessResult& t) {
  const size_t n = cameras.size();
  std::vector<std::vector<Eigen::Vector3d>> clouds;
  for (const Camera& c : cameras) clouds.push_back(c.cloud);
  const std::vector<CameraOverlap> overlap = measure_overlap(clouds, pose, 0.01, 0.03);
  SiteCalibration site;
  site.floor = std::move(floor);
  for (size_t i = 0; i < n; ++i) {
    Camera& c = cameras[i];
    CalibratedCamera r;
    r.name = c.name;
    r.source = c.source;
    r.intrinsics = c.intrinsics;
    r.calibration = c.reader->calibration();
    r.world_from_camera = pose[i];
    if (pose[i]) r.calibration.world_from_camera = *pose[i];
    r.method = c.method;
    r.target_rms_m = c.feature_rms_m;
    if (i < t.before.size() && t.before[i].points > 0) r.before_rms_m = t.before[i].rms_m;
    r.overlap = overlap[i];
    r.first = std::move(c.first);
    site.cameras.push_back(std::move(r));
  }
  site.problems = t.problems;
  for (size_t i = 0; i < n; ++i)
    if (!pose[i] &&
        std::none_of(site.problems.begin(), site.problems.end(), [&](const std::string& p) {
          return p.rfind("camera " + std::to_string(i) + ":", 0) == 0;
        }))
      site.problems.push_back("camera " + std::to_string(i) + ": could not be placed");
  return site;
}

}  // namespace

size_t SiteCalibration::placed() const {
  return static_cast<size_t>(std::count_if(cameras.begin(), cameras.end(), [](const auto& c) {
    return c.world_from_camera.has_value();
  }));
}

SiteCalibration calibrate_site(const CalibrationOptions& a) {
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
  const std::vector<std::optional<RigidTransform>> start = place_by_target(a, cameras);
  TargetlessResult t;
  std::vector<std::optional<RigidTransform>> pose = place_by_overlap(a, cameras, start, t);
  std::optional<FloorPlane> floor = align_floor(a, cameras, pose);
  return summarise(cameras, pose, std::move(floor), t);
}

std::string calibration_table(const SiteCalibration& site) {
  std::string out =
      fmt::format("\n{:<3} {:<14} {:<16} {:>10} {:>9} {:>11} {:>11} {:>9}\n", "cam", "name",
                  "method", "target mm", "overlap", "RMS before", "RMS mm", "height m");
  for (size_t i = 0; i < site.cameras.size(); ++i) {
    const CalibratedCamera& c = site.cameras[i];
    const std::string target =
        c.target_rms_m >= 0 ? fmt::format("{:.2f}", c.target_rms_m * 1e3) : "-";
    const std::string before =
        c.before_rms_m >= 0 ? fmt::format("{:.1f}", c.before_rms_m * 1e3) : "-";
    if (!c.world_from_camera) {
      out += fmt::format("{:<3} {:<14} {:<16} {:>10} {:>9} {:>11} {:>11} {:>9}\n", i, c.name,
                         "NOT PLACED", target, "-", before, "-", "-");
      continue;
    }
    const std::string height =
        site.floor ? fmt::format("{:.2f}", c.world_from_camera->translation.y()) : "-";
    out += fmt::format("{:<3} {:<14} {:<16} {:>10} {:>8.1f}% {:>11} {:>11.1f} {:>9}\n", i, c.name,
                       c.method, target, c.overlap.fraction * 100, before, c.overlap.rms_m * 1e3,
                       height);
  }
  out +=
      "target mm: RMS of the sphere centres after the solve; overlap: share of the camera's "
      "samples within 30 mm of another camera's surface; RMS: their point-to-plane distance\n\n";
  return out;
}

void write_calibrated_site(const SiteCalibration& calibration, const fs::path& out) {
  const fs::path out_dir = out.has_parent_path() ? out.parent_path() : fs::path(".");
  std::vector<SiteCamera> site;
  for (const CalibratedCamera& c : calibration.cameras) {
    SiteCamera s;
    s.source = relative_to(c.source, out_dir);
    s.name = c.name;
    s.intrinsics = c.intrinsics;
    s.world_from_camera = c.world_from_camera;
    if (c.world_from_camera) {
      SiteRegistration r;
      r.method = c.method;
      r.feature_rms_mm = c.target_rms_m >= 0 ? c.target_rms_m * 1e3 : -1;
      r.overlap_rms_mm = c.overlap.points > 0 ? c.overlap.rms_m * 1e3 : -1;
      s.registration = r;
    }
    site.push_back(std::move(s));
  }
  write_site_config(out, site);
}

int report_calibration(const SiteCalibration& site, const fs::path& out,
                       const std::string& preview) {
  std::printf("%s", calibration_table(site).c_str());
  for (const auto& p : site.problems) spdlog::error("{}", p);
  write_calibrated_site(site, out);
  spdlog::info("wrote {} ({} of {} cameras placed)", out.string(), site.placed(),
               site.cameras.size());
  if (!preview.empty()) {
    std::vector<CameraCalibration> calibrations;
    std::vector<CameraFrame> frames;
    for (const CalibratedCamera& c : site.cameras)
      if (c.world_from_camera) {
        calibrations.push_back(c.calibration);
        frames.push_back(c.first);
      }
    write_calibration_preview(preview, calibrations, frames, site.floor.has_value());
    spdlog::info("wrote {} (from above, and from the side)", preview);
  }
  return site.problems.empty() ? 0 : 3;
}

}  // namespace volcast
