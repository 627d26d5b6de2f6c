// volcast bench --drawing: pointing and drawing (session/annotations.hpp) on loopback over TLS --
// a pointer's moves as the others see them (sent -> received, server clock), the bytes a busy
// drawing session sends each receiver, and what the OR display costs a frame against its backdrop
// alone (pipeline/or_display.hpp, on whatever OpenGL the machine has: llvmpipe without a GPU).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "bench_session_site.hpp"
#include "volcast/bench/bench.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/filter/filters.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/or_display.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/pipeline/session_client.hpp"
#include "volcast/render/backdrop_renderer.hpp"
#include "volcast/render/headless_target.hpp"
#include "volcast/render/view.hpp"
#include "volcast/session/hub.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;

struct DrawingRow {
  std::string name;
  int observers = 0;
  uint64_t pointers_received = 0;  ///< by the observers, together
  double pointer_ms_p50 = 0, pointer_ms_p99 = 0;
  double bytes_per_second_per_receiver = 0;
  uint64_t annotations = 0;
};

double median_ms(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// One owner pointing at 60 Hz (and, when `drawing`, drawing a 120-point stroke every 0.5 s and a
// label every 2 s, erasing its oldest beyond 20) and `observers` watching, for `seconds`, the
// real site `sources` streaming at 30 fps or idle.
DrawingRow measure(const std::string& name, std::vector<std::unique_ptr<FrameSource>> sources,
                   int observers, bool drawing, bool stream_site, double seconds) {
  DrawingRow row;
  row.name = name;
  row.observers = observers;
  bench::BenchSite s(std::move(sources), stream_site);
  std::vector<std::unique_ptr<HeadlessParticipant>> people;
  for (int i = 0; i <= observers; ++i) {
    SessionClientOptions o;
    o.participant.session = "bench";
    o.participant.name = i == 0 ? "owner" : "observer " + std::to_string(i);
    o.drive_poses = false;
    people.push_back(bench::join_bench(s.link, std::move(o)));
  }
  std::this_thread::sleep_for(std::chrono::milliseconds(1500));  // joins
  Participant& owner = people[0]->participant();
  const uint64_t bytes0 = s.hub.stats().drawing_bytes_out;
  const auto t0 = Clock::now();
  auto next = t0;
  int frame = 0;
  std::vector<uint32_t> tags;
  while (Clock::now() - t0 < std::chrono::duration<double>(seconds)) {
    const float x = 0.3f * std::sin(float(frame) * 0.05f);
    owner.point(true, {0, 1.4f, 1}, true, {x, 0.9f, 0});
    if (drawing && frame % 30 == 0) {
      session::Annotation a;
      a.kind =
          frame % 120 == 0 ? session::AnnotationKind::kLabel : session::AnnotationKind::kStroke;
      if (a.kind == session::AnnotationKind::kLabel) {
        a.points = {{x, 0.9f, 0}};
        a.text = "cut here";
      } else {
        for (int k = 0; k < 120; ++k)
          a.points.push_back({x + 0.002f * float(k), 0.9f, 0.001f * float(k)});
      }
      owner.annotate(std::move(a));
      const auto mine = owner.snapshot(wall_clock_us()).annotations;
      if (mine.size() > 20) owner.erase(mine.front().id);
    }
    ++frame;
    next += std::chrono::microseconds(16667);
    std::this_thread::sleep_until(next);
  }
  const double wall = std::chrono::duration<double>(Clock::now() - t0).count();
  owner.point(false, {0, 1.4f, 1}, false, {0, 1, 0});
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  const SessionHubStats hs = s.hub.stats();
  row.bytes_per_second_per_receiver =
      double(hs.drawing_bytes_out - bytes0) / wall / std::max(observers, 1);
  row.annotations = hs.annotations;
  std::vector<double> p50, p99;
  for (size_t i = 1; i < people.size(); ++i)
    for (const RemoteStats& o : people[i]->participant().stats().others)
      if (o.name == "owner") {
        row.pointers_received += o.pointers_received;
        p50.push_back(o.pointer_age_ms_p50);
        p99.push_back(o.pointer_age_ms_p99);
      }
  row.pointer_ms_p50 = median_ms(p50);
  row.pointer_ms_p99 = median_ms(p99);
  bench::end_bench(people);
  s.stop();
  return row;
}

struct DisplayRow {
  double backdrop_ms = 0, or_display_ms = 0;
  int frames = 0;
  std::string renderer;
};

// The OR display of the real Kinect recording's camera with 20 strokes and 3 avatars in view,
// against its backdrop alone (undistorted frame, no primitives), median ms a frame (glFinish).
DisplayRow measure_display(const fs::path& kinect, double seconds) {
  auto source = open_source(kinect);
  const CameraCalibration camera = source->calibration();
  const CameraFrame frame = source->next();
  const OrDisplaySize size = or_display_size(camera);
  HeadlessTarget target(size.width, size.height);
  OrDisplay display;
  BackdropRenderer backdrop;
  SessionSnapshot s;
  for (uint32_t i = 0; i < 20; ++i) {
    session::Annotation a;
    a.id = i + 1;
    a.author = 2 + i % 3;
    for (int k = 0; k < 60; ++k)
      a.points.push_back({-0.2f + 0.007f * float(k), -0.1f + 0.01f * float(i), 0.8f});
    s.annotations.push_back(a);
  }
  for (uint32_t i = 0; i < 3; ++i) {
    RemoteParticipant p;
    p.id = 2 + i;
    p.has_pose = true;
    p.pose.head.position = {-0.3f + 0.3f * float(i), -0.2f, 1.5f};
    p.pose.hands_tracked = true;
    p.pose.left_hand.position = p.pose.head.position + Eigen::Vector3f(-0.2f, 0.4f, -0.2f);
    p.pose.right_hand.position = p.pose.head.position + Eigen::Vector3f(0.2f, 0.4f, -0.2f);
    s.others.push_back(p);
    s.pointers.push_back({p.id, p.pose.right_hand.position, true, {0.05f * float(i), 0, 0.8f}, 0});
  }
  const PixelMap map = make_pixel_map(camera.depth, true, std::nullopt);
  CameraFrame undistorted;
  apply_pixel_map(map, frame.depth, undistorted.depth);
  apply_pixel_map(map, frame.color, undistorted.color);
  CameraCalibration pinhole = camera;
  pinhole.depth = map.output;
  const View view = camera_view(pinhole, 0.05f, 20);
  std::vector<double> a, b;
  const auto until = Clock::now() + std::chrono::duration<double>(seconds);
  for (int i = 0; i < 3 || Clock::now() < until; ++i) {  // interleaved: the same load for both
    auto t = Clock::now();
    backdrop.draw(view, target.target(), undistorted);
    target.finish();
    a.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t).count());
    t = Clock::now();
    display.draw(target.target(), camera, frame, s, 0);
    target.finish();
    b.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t).count());
  }
  ColorImage image;
  target.read_image(image);
  return {median_ms(a), median_ms(b), int(b.size()), ""};
}

}  // namespace

int run_drawing_bench(const BenchArgs& a) {
  const auto data = find_data(a.data);
  if (!data) throw Error("bench --drawing: the real recordings were not found (--data DIR)");
  if (!(a.server_seconds > 0)) throw Error("--server-seconds must be positive");
  spdlog::set_level(spdlog::level::warn);
  struct Config {
    const char* name;
    int observers;
    bool drawing, stream_site;
  };
  const Config configs[] = {{"pointer, 1 observer, site idle", 1, false, false},
                            {"pointer, 3 observers + OR's 2 cameras", 3, false, true},
                            {"busy drawing, 3 observers + OR's 2 cameras", 3, true, true}};
  std::printf("%-44s %9s %9s %9s %14s\n", "configuration", "received", "ptr p50", "ptr p99",
              "B/s per rcvr");
  nlohmann::json rows = nlohmann::json::array();
  for (const Config& c : configs) {
    const DrawingRow r = measure(c.name, two_camera_site(*data), c.observers, c.drawing,
                                 c.stream_site, a.server_seconds);
    std::printf("%-44s %9llu %7.2fms %7.2fms %14.0f\n", r.name.c_str(),
                static_cast<unsigned long long>(r.pointers_received), r.pointer_ms_p50,
                r.pointer_ms_p99, r.bytes_per_second_per_receiver);
    rows.push_back({{"configuration", r.name},
                    {"observers", r.observers},
                    {"pointers_received", r.pointers_received},
                    {"pointer_ms_p50", r.pointer_ms_p50},
                    {"pointer_ms_p99", r.pointer_ms_p99},
                    {"bytes_per_second_per_receiver", r.bytes_per_second_per_receiver},
                    {"annotations", r.annotations}});
  }
  const DisplayRow d = measure_display(*data / kKinectSet, std::max(1.0, a.render_seconds));
  std::printf(
      "\nOR display (Kinect camera 640x576, 20 strokes, 3 avatars, 3 pointers): %.2f ms a frame, "
      "its backdrop alone %.2f ms (x%.2f), median of %d frames each, glFinish after each\n",
      d.or_display_ms, d.backdrop_ms, d.or_display_ms / std::max(d.backdrop_ms, 1e-6), d.frames);
  std::printf(
      "pointer: sent -> received by each observer (server clock), median over observers; bytes: "
      "pointer, annotation and erase messages the hub sent, per receiver\n");
  if (!a.json.empty()) {
    nlohmann::json j;
    j["drawing"] = rows;
    j["or_display"] = {{"or_display_ms", d.or_display_ms},
                       {"backdrop_ms", d.backdrop_ms},
                       {"ratio", d.or_display_ms / std::max(d.backdrop_ms, 1e-6)},
                       {"frames", d.frames}};
    std::ofstream(a.json) << j.dump(2) << "\n";
  }
  return 0;
}

}  // namespace volcast
