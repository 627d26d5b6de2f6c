#include "volcast/capture/real_sites.hpp"

#include <spdlog/spdlog.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdlib>

#include "volcast/capture/k4a_recording.hpp"
#include "volcast/capture/still_source.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace fs = std::filesystem;

std::optional<fs::path> find_data(const std::string& flag) {
  std::vector<fs::path> candidates;
  if (!flag.empty()) {  // an explicit folder is the only place to look
    if (fs::exists(fs::path(flag) / kHandsSet) && fs::exists(fs::path(flag) / kKinectSet))
      return fs::weakly_canonical(flag);
    return std::nullopt;
  }
  if (const char* env = std::getenv("VOLCAST_DATA")) candidates.push_back(env);
  std::error_code ec;
  const fs::path exe = fs::read_symlink("/proc/self/exe", ec);
  if (!ec) candidates.push_back(exe.parent_path() / "../../../shared/data");
  candidates.push_back(fs::current_path() / "../shared/data");
  candidates.push_back(fs::current_path() / "shared/data");
  for (const auto& c : candidates)
    if (fs::exists(c / kHandsSet) && fs::exists(c / kKinectSet)) return fs::weakly_canonical(c);
  return std::nullopt;
}

std::vector<std::unique_ptr<FrameSource>> two_camera_site(const fs::path& data) {
  // Camera 0: the hands sequence. Its intrinsics were never published: use the nominal pinhole
  // the data's README suggests (about 70 degrees horizontal field of view), and say so.
  SourceOptions hands_options;
  Intrinsics nominal;
  nominal.fx = nominal.fy = 460;
  nominal.cx = 320;
  nominal.cy = 180;
  hands_options.intrinsics = nominal;
  spdlog::warn(
      "camera 0 ({}) has no published intrinsics; using a NOMINAL pinhole fx=fy=460, cx=320, "
      "cy=180",
      kHandsSet);
  // Camera 1: the genuine Azure Kinect recording, factory calibration; the two scenes are
  // unrelated, so the site places it 1.6 m to the right of camera 0.
  SourceOptions kinect_options;
  RigidTransform beside;
  beside.translation = {1.6, 0, 0};
  kinect_options.world_from_camera = beside;
  std::vector<std::unique_ptr<FrameSource>> sources;
  sources.push_back(open_source(data / kHandsSet, hands_options));
  sources.push_back(open_source(data / kKinectSet, kinect_options));
  return sources;
}

ColorCalibration nominal_kinect_color(const fs::path& data) {
  const K4aRecordingInfo info = probe_k4a_recording(data / kKinectSet);
  if (info.color_intrinsics.width == 0)
    throw Error("the Azure Kinect recording " + (data / kKinectSet).string() + " has no color");
  return {info.color_intrinsics, info.color_from_depth};
}

std::vector<std::unique_ptr<FrameSource>> four_camera_site(const fs::path& data) {
  const fs::path dir = data / kFourKinectSet;
  std::vector<fs::path> depth;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().rfind("depth.", 0) == 0) depth.push_back(e.path());
  std::sort(depth.begin(), depth.end());
  if (depth.size() != 4) throw Error("expected four depth.*.png in " + dir.string());
  // The same camera model (Azure Kinect NFOV unbinned), from the genuine recording's calibration.
  const CameraCalibration model = open_source(data / kKinectSet)->calibration();
  const ColorCalibration color_model = nominal_kinect_color(data);
  std::vector<std::unique_ptr<FrameSource>> sources;
  for (size_t i = 0; i < depth.size(); ++i) {
    CameraCalibration cal = model;
    cal.world_from_camera = RigidTransform{};
    cal.world_from_camera.translation = {1.6 * static_cast<double>(i), 0, 0};
    std::string color = depth[i].filename().string();
    color.replace(0, 5, "rgb");  // depth.<serial>-0001.png -> rgb.<serial>-0001.png
    sources.push_back(open_still_source(depth[i], dir / color, cal, 30, color_model));
  }
  return sources;
}

std::vector<CameraCalibration> turned_to_overlap(std::vector<CameraCalibration> cameras) {
  const Eigen::Vector3d pivot(0, 0, 2.0);
  const double yaw_deg[] = {0, 12, -12, 24};
  for (size_t i = 0; i < cameras.size(); ++i) {
    const Eigen::Matrix3d turn =
        Eigen::AngleAxisd(yaw_deg[i % 4] * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
    cameras[i].world_from_camera.rotation = turn;
    cameras[i].world_from_camera.translation = pivot - turn * pivot;
  }
  return cameras;
}

}  // namespace volcast
