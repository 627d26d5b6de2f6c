#include "volcast/pipeline/export.hpp"

#include <fmt/format.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/io/PointCloudIO.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <climits>
#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>

#include "k4a_mkv_writer.hpp"
#include "volcast/capture/k4a_calibration.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/core/jpeg.hpp"
#include "volcast/core/private_file.hpp"
#include "volcast/reconstruct/point_cloud.hpp"
#include "volcast/record/decode.hpp"
#include "volcast/record/recording.hpp"

namespace volcast {
namespace fs = std::filesystem;
namespace {

// intrinsics.json as an image-sequence folder reads it (volcast/capture/image_sequence.hpp).
void write_intrinsics_json(const fs::path& file, const CameraCalibration& c, double fps) {
  const Intrinsics& k = c.depth;
  nlohmann::json j = {{"fx", k.fx}, {"fy", k.fy}, {"cx", k.cx}, {"cy", k.cy}, {"k1", k.k1},
                      {"k2", k.k2}, {"k3", k.k3}, {"k4", k.k4}, {"k5", k.k5}, {"k6", k.k6},
                      {"p1", k.p1}, {"p2", k.p2}, {"fps", fps}};
  std::vector<double> r(9), t(3);
  for (int i = 0; i < 9; ++i) r[i] = c.world_from_camera.rotation(i / 3, i % 3);
  for (int i = 0; i < 3; ++i) t[i] = c.world_from_camera.translation(i);
  j["world_from_camera"] = {{"rotation", r}, {"translation", t}};
  write_private_file(file, j.dump(2) + "\n");
}

void write_ply(const fs::path& file, const PointCloud& cloud, open3d::geometry::PointCloud& o3d) {
  o3d.points_.resize(cloud.points.size());
  o3d.colors_.resize(cloud.points.size());
  for (size_t i = 0; i < cloud.points.size(); ++i) {
    const SplatPoint& p = cloud.points[i];
    o3d.points_[i] = Eigen::Vector3d(p.position[0], p.position[1], p.position[2]);
    o3d.colors_[i] = Eigen::Vector3d((p.rgba & 0xff) / 255.0, ((p.rgba >> 8) & 0xff) / 255.0,
                                     ((p.rgba >> 16) & 0xff) / 255.0);
  }
  open3d::io::WritePointCloudOption opt;
  opt.write_ascii = open3d::io::WritePointCloudOption::IsAscii::Binary;
  if (!open3d::io::WritePointCloudToPLY(file.string(), o3d, opt))
    throw Error("export: cannot write " + file.string());
  restrict_to_owner(file);
}

// The frame sets in the range o.from_s .. o.to_s of the playback timeline, selected and paced
// as `replay` does (absurd gaps clamped); and their rate (30 for a single frame set).
std::vector<size_t> pick_frame_sets(const std::vector<RecordedFrameSet>& sets,
                                    const ExportOptions& o, double& fps) {
  const PlaybackTimeline timeline = playback_timeline(sets);
  std::vector<size_t> picked;
  for (size_t k = 0; k < sets.size(); ++k) {
    const double t = static_cast<double>(timeline.offset_us[k]) / 1e6;
    if (t >= o.from_s - 1e-6 && (o.to_s < 0 || t <= o.to_s + 1e-6)) picked.push_back(k);
  }
  if (picked.empty()) throw Error("export: no frame sets in the range given");
  const int64_t span = timeline.offset_us[picked.back()] - timeline.offset_us[picked[0]];
  fps = picked.size() > 1 && span > 0
            ? static_cast<double>(picked.size() - 1) * 1e6 / static_cast<double>(span)
            : 30.0;
  return picked;
}

// The PLY and PNG folders; per camera its PNG folder with depth/, color/ and intrinsics.json.
void make_folders(const ExportOptions& o, const std::vector<protocol::CameraInfo>& cams, double fps,
                  ExportReport& report) {
  std::error_code ec;
  for (const fs::path& dir : {o.ply_dir, o.png_dir})
    if (!dir.empty() && (fs::create_directories(dir, ec), ec))
      throw Error("export: cannot make " + dir.string() + ": " + ec.message());
  if (!o.png_dir.empty())
    for (size_t c = 0; c < cams.size(); ++c) {
      const fs::path cam = o.png_dir / fmt::format("camera-{}", c);
      fs::create_directories(cam / "depth", ec);
      fs::create_directories(cam / "color", ec);
      if (ec) throw Error("export: cannot make " + cam.string() + ": " + ec.message());
      write_intrinsics_json(cam / "intrinsics.json", cams[c].calibration, fps);
      ++report.files;
    }
}

// What an MKV track needs to know before its first frame, per camera.
struct TrackTiming {
  std::vector<int64_t> frame_duration_us;
  std::vector<char> has_color;  // any color in the range: a COLOR_ON_DEPTH track
};

// Each camera's own frame interval (a camera slower than the site repeats its frames): the
// median step between its distinct device times, read from the frame sets' heads; `fps` where
// it has none.
TrackTiming track_timing(RecordingReader& reader, const std::vector<size_t>& picked, size_t cameras,
                         double fps) {
  TrackTiming timing{std::vector<int64_t>(cameras, static_cast<int64_t>(1e6 / fps)),
                     std::vector<char>(cameras, 0)};
  std::vector<std::vector<int64_t>> steps(cameras);
  std::vector<int64_t> last(cameras, INT64_MIN);
  std::vector<uint8_t> message;
  protocol::FrameSetView view;
  for (size_t k : picked) {
    try {
      reader.read(k, message, 8);  // room for the send time parse_frame_set expects
      protocol::parse_frame_set(message, view);
    } catch (const Error&) {
      continue;  // the decode below names it
    }
    for (size_t c = 0; c < cameras && c < view.cameras.size(); ++c) {
      const int64_t t = view.cameras[c].device_timestamp_us;
      if (last[c] != INT64_MIN && t > last[c]) steps[c].push_back(t - last[c]);
      if (t != last[c]) last[c] = t;
      timing.has_color[c] = timing.has_color[c] || !view.cameras[c].color.empty();
    }
  }
  for (size_t c = 0; c < cameras; ++c)
    if (!steps[c].empty()) {
      std::nth_element(steps[c].begin(), steps[c].begin() + steps[c].size() / 2, steps[c].end());
      timing.frame_duration_us[c] = steps[c][steps[c].size() / 2];
    }
  return timing;
}

// One MKV writer per camera: o.mkv, or with several cameras FILE-camera-C.mkv beside it.
std::vector<std::unique_ptr<K4aMkvWriter>> open_mkv_writers(
    const ExportOptions& o, const std::vector<protocol::CameraInfo>& cams,
    const TrackTiming& timing, ExportReport& report) {
  std::vector<std::unique_ptr<K4aMkvWriter>> mkvs;
  for (size_t c = 0; c < cams.size(); ++c) {
    const Intrinsics& k = cams[c].calibration.depth;
    const auto mode = k4a_depth_mode_of_size(k.width, k.height);
    if (!mode)
      throw Error(fmt::format(
          "export: camera {} ({}) is {}x{}, not an Azure Kinect depth mode (640x576, 320x288, "
          "512x512, 1024x1024): --mkv cannot describe it; use --png",
          c, cams[c].description, k.width, k.height));
    const fs::path file =
        cams.size() == 1
            ? o.mkv
            : o.mkv.parent_path() / fmt::format("{}-camera-{}.mkv", o.mkv.stem().string(), c);
    mkvs.push_back(std::make_unique<K4aMkvWriter>(file, k, *mode, timing.frame_duration_us[c],
                                                  timing.has_color[c] != 0));
    ++report.files;
  }
  return mkvs;
}

// Camera c's depth and color PNGs of exported frame set n.
void write_pngs(const fs::path& png_dir, size_t c, size_t n, const CameraFrame& f,
                ExportReport& report) {
  const fs::path cam = png_dir / fmt::format("camera-{}", c);
  const fs::path depth = cam / "depth" / fmt::format("{:06d}.png", n);
  write_depth_png(depth, f.depth);
  restrict_to_owner(depth);
  ++report.files;
  if (!f.color.empty()) {
    const fs::path color = cam / "color" / fmt::format("{:06d}.png", n);
    write_color_png(color, f.color);
    restrict_to_owner(color);
    ++report.files;
  }
}

}  // namespace

ExportReport export_recording(const fs::path& path, const ExportOptions& o) {
  if (o.ply_dir.empty() && o.png_dir.empty() && o.mkv.empty())
    throw Error("export: say what to write (--ply DIR, --png DIR, --mkv FILE)");
  RecordingReader reader(path);
  RecordingDecoder decoder(reader);
  const auto& sets = reader.info().frame_sets;
  const auto& cams = reader.info().stream.welcome.cameras;
  if (sets.empty()) throw Error("export: " + path.string() + " holds no frame sets");
  double fps = 0;
  const std::vector<size_t> picked = pick_frame_sets(sets, o, fps);
  std::vector<CloudBuilder> builders;
  for (const auto& c : cams) builders.emplace_back(c.calibration);
  ExportReport report;
  make_folders(o, cams, fps, report);
  std::vector<std::unique_ptr<K4aMkvWriter>> mkvs;
  if (!o.mkv.empty())
    mkvs = open_mkv_writers(o, cams, track_timing(reader, picked, cams.size(), fps), report);
  FrameSet frames;
  PointCloud cloud;
  open3d::geometry::PointCloud o3d;
  for (size_t n = 0; n < picked.size(); ++n) {
    try {
      decoder.decode(picked[n], frames);
    } catch (const Error& e) {
      spdlog::warn("export: frame set {} skipped: {}", picked[n], e.what());
      ++report.skipped;
      continue;
    }
    for (size_t c = 0; c < cams.size(); ++c) {
      const CameraFrame& f = frames.cameras[c];
      for (uint16_t d : f.depth.pixels) report.valid_pixels += d != 0;
      if (!o.ply_dir.empty()) {
        builders[c].build(f.depth, f.color, cloud);
        write_ply(o.ply_dir / fmt::format("frame-{:06d}-camera-{}.ply", n, c), cloud, o3d);
        report.points += cloud.points.size();
        ++report.files;
      }
      if (!mkvs.empty()) mkvs[c]->write(f);
      if (!o.png_dir.empty()) write_pngs(o.png_dir, c, n, f, report);
    }
    ++report.frame_sets;
    if (o.progress) o.progress(n + 1, picked.size());
  }
  for (auto& m : mkvs) m->close();
  return report;
}

}  // namespace volcast
