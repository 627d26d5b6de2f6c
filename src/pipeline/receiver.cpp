#include "volcast/pipeline/receiver.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>

#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/core/text.hpp"
#include "volcast/render/headless_target.hpp"

namespace volcast {
namespace {

struct Accumulator {
  uint64_t frames = 0, dropped = 0, depth_bytes = 0, color_bytes = 0;
  std::vector<double> latencies_ms;
};

}  // namespace

// Hands the newest decoded images from the receiving thread to the render thread (the
// presenter), which uploads them and reconstructs the points on the GPU. Frames are shared,
// immutable once handed over: a camera that repeats its frame keeps its frame (and the renderer
// skips its upload).
struct FrameFeed::State {
  std::vector<CameraCalibration> cameras;
  mutable std::mutex mutex;
  std::condition_variable changed;
  std::vector<std::shared_ptr<const CameraFrame>> frames;
  uint64_t version = 0, taken = 0;
  bool done = false;                // the receiving side is finished
  std::atomic<bool> closed{false};  // the presenter asked to end
  LiveStats live;
};

const std::vector<CameraCalibration>& FrameFeed::cameras() const {
  return state_.cameras;
}

bool FrameFeed::next(std::vector<std::shared_ptr<const CameraFrame>>& frames,
                     std::chrono::microseconds wait) {
  std::unique_lock lock(state_.mutex);
  state_.changed.wait_for(lock, wait,
                          [&] { return state_.done || state_.version != state_.taken; });
  if (state_.version == state_.taken) return false;
  state_.taken = state_.version;
  frames = state_.frames;
  return true;
}

bool FrameFeed::finished() const {
  std::lock_guard lock(state_.mutex);
  return (state_.done && state_.version == state_.taken) || state_.closed;
}

void FrameFeed::close() {
  state_.closed = true;
  state_.changed.notify_all();
}

LiveStats FrameFeed::live() const {
  std::lock_guard lock(state_.mutex);
  return state_.live;
}

Presenter headless_presenter(const ViewerOptions& opt) {
  return [opt](FrameFeed& feed, ViewerResult& result) {
    HeadlessTarget target(opt.width, opt.height);  // before the renderer: it owns the context
    CameraRenderer renderer;
    result.renderer = renderer.gl_description();
    // A software rasteriser (no GPU) takes the cores the stream needs: draw it less often.
    const bool software = result.renderer.find("llvmpipe") != std::string::npos ||
                          result.renderer.find("softpipe") != std::string::npos;
    const bool throttle = software && opt.software_render_fps > 0;
    if (throttle)
      spdlog::info("software renderer ({}): drawing at most {} frames per second", result.renderer,
                   opt.software_render_fps);
    const std::vector<CameraCalibration>& calibrations = feed.cameras();
    renderer.set_cameras(calibrations);
    renderer.set_avatar_filter(opt.avatar_filter);
    std::vector<std::shared_ptr<const CameraFrame>> frames, uploaded(calibrations.size());
    std::optional<ViewCamera> view = opt.view;
    auto last_draw = std::chrono::steady_clock::now() - std::chrono::hours(1);
    while (!feed.finished()) {
      if (!feed.next(frames, std::chrono::milliseconds(100))) continue;
      if (throttle) {  // draw the newest frames at most software_render_fps times a second
        const auto due =
            last_draw + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(1.0 / opt.software_render_fps));
        while (std::chrono::steady_clock::now() < due && !feed.finished())
          feed.next(frames, std::chrono::duration_cast<std::chrono::microseconds>(
                                due - std::chrono::steady_clock::now()));
      }
      // A frame this thread still holds cannot have been reused by the receiver: the same
      // pointer is the same images, already on the GPU.
      for (size_t i = 0; i < frames.size(); ++i)
        if (frames[i] && frames[i] != uploaded[i]) {
          renderer.upload(i, *frames[i]);
          uploaded[i] = frames[i];
        }
      if (!view) view = default_view(calibrations, frames);
      renderer.draw_cameras(to_view(*view, target.target().aspect()), target.target(), opt.pass);
      last_draw = std::chrono::steady_clock::now();
      ++result.frames_rendered;
    }
    if (!opt.screenshot.empty() && result.frames_rendered > 0) {
      ColorImage image;  // the only read-back: the last frame, for the screenshot
      target.read_image(image);
      write_color_png(opt.screenshot, image);
      spdlog::info("wrote {}", opt.screenshot.string());
    }
  };
}

ViewCamera default_view(std::span<const CameraCalibration> cameras,
                        std::span<const std::shared_ptr<const CameraFrame>> frames) {
  // The default viewpoint needs the points once: built on the CPU this once.
  std::vector<PointCloud> clouds(frames.size());
  std::vector<const PointCloud*> views;
  for (size_t i = 0; i < frames.size() && i < cameras.size(); ++i) {
    if (frames[i]) CloudBuilder(cameras[i]).build(frames[i]->depth, frames[i]->color, clouds[i]);
    views.push_back(&clouds[i]);
  }
  if (cameras.empty()) return ViewCamera{};
  return orbit_view(cameras.front().world_from_camera, views);
}

namespace {

// Refreshes the live figures from what arrived over the last `interval_us` (then forgotten) and
// the whole session so far.
void update_live(LiveStats& live, const std::vector<Accumulator>& total,
                 std::vector<Accumulator>& recent, const StageRecorder& stages, uint64_t received,
                 int64_t interval_us) {
  const double seconds = static_cast<double>(interval_us) / 1e6;
  for (size_t i = 0; i < recent.size(); ++i) {
    CameraStats& s = live.cameras[i];
    Accumulator& a = recent[i];
    s.frames_received = total[i].frames;
    s.frames_dropped = total[i].dropped;
    s.received_fps = seconds > 0 ? static_cast<double>(a.frames) / seconds : 0;
    s.mbit_per_s =
        seconds > 0 ? static_cast<double>(a.depth_bytes + a.color_bytes) * 8 / seconds / 1e6 : 0;
    if (a.frames > 0) {
      s.mean_depth_bytes = static_cast<double>(a.depth_bytes) / static_cast<double>(a.frames);
      s.mean_color_bytes = static_cast<double>(a.color_bytes) / static_cast<double>(a.frames);
      s.depth_compression_ratio = static_cast<double>(s.width) * s.height * 2 / s.mean_depth_bytes;
    }
    s.latency_ms_p50 = percentile(a.latencies_ms, 0.50);
    s.latency_ms_p99 = percentile(a.latencies_ms, 0.99);
    a = Accumulator{};
  }
  live.stages = stages.summary();
  live.frame_sets_received = received;
}

// What ended a session that threw `error`.
ViewerEnd end_of(const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const ClientError& e) {
    switch (e.kind()) {
      case ClientError::Kind::kTimedOut:
        return ViewerEnd::kTimedOut;
      case ClientError::Kind::kRejected:
        return ViewerEnd::kRejected;
      case ClientError::Kind::kProtocol:
        return ViewerEnd::kProtocolError;
      case ClientError::Kind::kConnectionLost:
        return ViewerEnd::kConnectionLost;
    }
  } catch (...) {
  }
  return ViewerEnd::kError;
}

std::string message_of(const std::exception_ptr& error) {
  try {
    std::rethrow_exception(error);
  } catch (const std::exception& e) {
    return e.what();
  } catch (...) {
    return "unknown error";
  }
}

bool is_error(ViewerEnd end) {
  return end >= ViewerEnd::kTimedOut;
}

// Every end of a session: writes the figures if asked, and throws ViewerError on an error.
ViewerResult finish(const ViewerOptions& opt, ViewerResult result) {
  if (!opt.stats_json.empty()) {
    try {
      write_stats_json(opt.stats_json, result);
    } catch (const std::exception& e) {
      if (!is_error(result.ended)) throw;
      spdlog::error("{}", e.what());  // the session's own error is the one to report
    }
  }
  if (is_error(result.ended)) {
    const std::string message = result.error;
    throw ViewerError(message, std::make_shared<const ViewerResult>(std::move(result)));
  }
  return result;
}

}  // namespace

const char* to_string(ViewerEnd end) {
  switch (end) {
    case ViewerEnd::kFramesReached:
      return "frames_reached";
    case ViewerEnd::kSecondsReached:
      return "seconds_reached";
    case ViewerEnd::kInterrupted:
      return "interrupted";
    case ViewerEnd::kClosed:
      return "closed";
    case ViewerEnd::kServerClosed:
      return "server_closed";
    case ViewerEnd::kTimedOut:
      return "timed_out";
    case ViewerEnd::kRejected:
      return "rejected";
    case ViewerEnd::kProtocolError:
      return "protocol_error";
    case ViewerEnd::kConnectionLost:
      return "connection_lost";
    case ViewerEnd::kError:
      return "error";
  }
  return "error";
}

ViewerResult run_viewer(const ViewerOptions& opt) {
  ViewerResult result;
  result.depth_codec = opt.client.depth_codec;
  result.color_codec = opt.client.color_codec;
  std::unique_ptr<Client> connected;
  try {
    connected = std::make_unique<Client>(opt.client);
  } catch (...) {
    const std::exception_ptr error = std::current_exception();
    result.ended = end_of(error);
    result.error = message_of(error);
    return finish(opt, std::move(result));
  }
  Client& client = *connected;
  const auto& cams = client.welcome().cameras;
  if (opt.on_connected) {
    try {
      opt.on_connected(client);
    } catch (...) {
      const std::exception_ptr error = std::current_exception();
      result.ended = end_of(error);
      result.error = message_of(error);
      return finish(opt, std::move(result));
    }
  }

  FrameFeed::State box;
  for (const auto& c : cams) box.cameras.push_back(c.calibration);
  box.live.depth_codec = opt.client.depth_codec;
  box.live.color_codec = opt.client.color_codec;
  box.live.cameras.resize(cams.size());
  for (size_t i = 0; i < cams.size(); ++i) {
    box.live.cameras[i].description = printable(cams[i].description);
    box.live.cameras[i].width = cams[i].calibration.depth.width;
    box.live.cameras[i].height = cams[i].calibration.depth.height;
  }
  FrameFeed feed(box);
  std::exception_ptr render_error;
  std::thread render_thread;
  if (opt.render)
    render_thread = std::thread([&] {
      try {
        (opt.presenter ? opt.presenter : headless_presenter(opt))(feed, result);
      } catch (...) {
        render_error = std::current_exception();
      }
      feed.close();  // the presenter is gone: nothing draws what arrives from now on
    });

  std::vector<Accumulator> acc(cams.size());
  // Each camera's newest decoded frame, and per camera the frames images are moved into (one no
  // longer held by the renderer is reused; a repeated frame keeps its frame).
  std::vector<std::shared_ptr<const CameraFrame>> frames(cams.size());
  std::vector<std::vector<std::shared_ptr<CameraFrame>>> buffers(cams.size());
  ReceivedFrameSet rx;
  StageRecorder stages;
  std::vector<Accumulator> live_acc(cams.size());  // since the last live refresh
  int64_t live_from_us = wall_clock_us();
  const auto start = std::chrono::steady_clock::now();
  int64_t first_rx_us = 0, last_rx_us = 0;
  uint64_t last_sequence = 0, received = 0;
  std::exception_ptr receive_error;
  // A watchdog closes the connection at the time limit so a blocked receive() returns, and says
  // why.
  std::mutex watchdog_mutex;
  std::condition_variable watchdog_cv;
  bool finished = false;
  std::atomic<ViewerEnd> stopped_by{ViewerEnd::kServerClosed};
  std::thread watchdog([&] {
    std::unique_lock lock(watchdog_mutex);
    while (!finished) {
      watchdog_cv.wait_for(lock, std::chrono::milliseconds(50));
      const bool timeout = opt.seconds > 0 && std::chrono::steady_clock::now() - start >
                                                  std::chrono::duration<double>(opt.seconds);
      if (timeout || (opt.stop && *opt.stop) || box.closed) {
        stopped_by = timeout                 ? ViewerEnd::kSecondsReached
                     : opt.stop && *opt.stop ? ViewerEnd::kInterrupted
                                             : ViewerEnd::kClosed;
        client.close();
        return;
      }
    }
  });
  try {
    if (!opt.save_frames_dir.empty()) std::filesystem::create_directories(opt.save_frames_dir);
    while ((opt.frames <= 0 || received < static_cast<uint64_t>(opt.frames)) &&
           client.receive(rx)) {
      // The decoded images move (swap, no copy) into a frame the renderer may hold; the client
      // decodes into the swapped-in buffers next time (decoders keep their own references).
      for (size_t i = 0; i < cams.size(); ++i) {
        if (rx.repeated[i] && frames[i]) continue;
        std::shared_ptr<CameraFrame> frame;
        for (auto& b : buffers[i])
          if (b.use_count() == 1) frame = b;
        if (!frame) {
          frame = std::make_shared<CameraFrame>();
          if (buffers[i].size() < 4) buffers[i].push_back(frame);
        }
        CameraFrame& decoded = rx.frames.cameras[i];
        std::swap(frame->depth, decoded.depth);
        std::swap(frame->color, decoded.color);
        frame->device_timestamp_us = decoded.device_timestamp_us;
        frames[i] = std::move(frame);
      }
      const int64_t now = wall_clock_us();
      stages.add(rx.times, now);
      const double latency_ms = static_cast<double>(now - rx.frames.capture_time_us) / 1000.0;
      const uint64_t gap = received > 0 && rx.frames.sequence > last_sequence + 1
                               ? rx.frames.sequence - last_sequence - 1
                               : 0;
      for (size_t i = 0; i < cams.size(); ++i)
        for (Accumulator* a : {&acc[i], &live_acc[i]}) {
          ++a->frames;
          a->dropped += gap;
          a->depth_bytes += rx.depth_bytes[i];
          a->color_bytes += rx.color_bytes[i];
          a->latencies_ms.push_back(latency_ms);
        }
      if (received == 0) first_rx_us = now;
      last_rx_us = now;
      last_sequence = rx.frames.sequence;
      ++received;
      if (opt.render) {
        std::lock_guard lock(box.mutex);
        box.frames = frames;
        ++box.version;
        box.changed.notify_one();
        if (now - live_from_us >= 500'000) {  // the panel's figures, twice a second
          update_live(box.live, acc, live_acc, stages, received, now - live_from_us);
          live_from_us = now;
        }
      }
      if (box.closed) break;  // the presenter ended the session, or failed
      if (!opt.save_frames_dir.empty()) {
        for (size_t i = 0; i < cams.size(); ++i) {
          const CameraFrame& f = *frames[i];
          const std::string stem = fmt::format("cam{}_{:08d}", i, rx.frames.sequence);
          write_depth_png(opt.save_frames_dir / (stem + "_depth.png"), f.depth);
          if (!f.color.empty())
            write_color_png(opt.save_frames_dir / (stem + "_color.png"), f.color);
        }
      }
    }
  } catch (...) {
    receive_error = std::current_exception();
  }
  {
    std::lock_guard lock(watchdog_mutex);
    finished = true;
  }
  watchdog_cv.notify_all();
  watchdog.join();
  client.close();
  if (opt.render) {
    {
      std::lock_guard lock(box.mutex);
      box.done = true;
    }
    box.changed.notify_all();
    render_thread.join();  // renders whatever is still pending
  }
  result.last_frames = frames;
  result.frame_sets_received = received;
  if (render_error) {  // first: a failed presenter closes the session, which may break a receive
    result.ended = ViewerEnd::kError;
    result.error = "renderer: " + message_of(render_error);
  } else if (receive_error) {
    result.ended = end_of(receive_error);
    result.error = message_of(receive_error);
  } else if (opt.frames > 0 && received >= static_cast<uint64_t>(opt.frames)) {
    result.ended = ViewerEnd::kFramesReached;
  } else if (box.closed && stopped_by == ViewerEnd::kServerClosed) {
    result.ended = ViewerEnd::kClosed;  // the presenter ended it before the watchdog saw it
  } else {
    result.ended = stopped_by;  // seconds reached, interrupted, closed, or else the server closed
  }
  result.frames_undecodable = client.frames_undecodable();
  result.stages = stages.summary();

  const double seconds = static_cast<double>(last_rx_us - first_rx_us) / 1e6;
  for (size_t i = 0; i < cams.size(); ++i) {
    const Accumulator& a = acc[i];
    CameraStats s;
    s.description = printable(cams[i].description);
    s.width = cams[i].calibration.depth.width;
    s.height = cams[i].calibration.depth.height;
    s.frames_received = a.frames;
    s.frames_dropped = a.dropped;
    if (a.frames > 0) {
      s.mean_depth_bytes = static_cast<double>(a.depth_bytes) / static_cast<double>(a.frames);
      s.mean_color_bytes = static_cast<double>(a.color_bytes) / static_cast<double>(a.frames);
      s.depth_compression_ratio = static_cast<double>(s.width) * s.height * 2 / s.mean_depth_bytes;
    }
    if (seconds > 0 && a.frames > 1) {
      s.received_fps = static_cast<double>(a.frames - 1) / seconds;
      s.mbit_per_s = (s.mean_depth_bytes + s.mean_color_bytes) * 8 * s.received_fps / 1e6;
    }
    s.latency_ms_p50 = percentile(a.latencies_ms, 0.50);
    s.latency_ms_p99 = percentile(a.latencies_ms, 0.99);
    result.cameras.push_back(s);
  }
  if (opt.on_finished) {
    try {
      opt.on_finished(result);
    } catch (const std::exception& e) {
      spdlog::error("viewer: {}", e.what());
    }
  }
  return finish(opt, std::move(result));
}

void write_stats_json(const std::filesystem::path& path, const ViewerResult& r) {
  nlohmann::json j;
  j["ended"] = to_string(r.ended);
  j["error"] = r.error.empty() ? nlohmann::json(nullptr) : nlohmann::json(r.error);
  j["frame_sets_received"] = r.frame_sets_received;
  j["depth_codec"] = r.depth_codec;
  j["color_codec"] = r.color_codec;
  j["frames_rendered"] = r.frames_rendered;
  j["renderer"] = r.renderer;
  j["frames_undecodable"] = r.frames_undecodable;
  j["stages"] = nlohmann::json::array();
  for (const StageLatency& l : r.stages)
    j["stages"].push_back(
        {{"stage", l.stage}, {"p50_ms", l.p50_ms}, {"p99_ms", l.p99_ms}, {"mean_ms", l.mean_ms}});
  j["cameras"] = nlohmann::json::array();
  for (size_t i = 0; i < r.cameras.size(); ++i) {
    const CameraStats& s = r.cameras[i];
    j["cameras"].push_back({{"camera", i},
                            {"description", s.description},
                            {"width", s.width},
                            {"height", s.height},
                            {"frames_received", s.frames_received},
                            {"frames_dropped", s.frames_dropped},
                            {"mean_depth_bytes", s.mean_depth_bytes},
                            {"mean_color_bytes", s.mean_color_bytes},
                            {"depth_compression_ratio", s.depth_compression_ratio},
                            {"received_fps", s.received_fps},
                            {"mbit_per_s", s.mbit_per_s},
                            {"latency_ms_p50", s.latency_ms_p50},
                            {"latency_ms_p99", s.latency_ms_p99}});
  }
  if (r.session) {
    const ParticipantStats& p = *r.session;
    j["session"] = r.session_name;
    j["session_round_trip_ms_p50"] = p.round_trip_ms_p50;
    j["session_round_trip_ms_p99"] = p.round_trip_ms_p99;
    j["round_trip_samples"] = p.round_trip_samples;
    j["poses_sent"] = p.poses_sent;
    j["avatar_frames_sent"] = p.avatar_frames_sent;
    j["participants"] = nlohmann::json::array();
    j["others"] = nlohmann::json::array();
    for (const RemoteStats& o : p.others) {
      j["participants"].push_back(o.name);
      j["others"].push_back({{"id", o.id},
                             {"name", o.name},
                             {"poses_received", o.poses_received},
                             {"pose_rate_hz", o.pose_rate_hz},
                             {"pose_age_ms_p50", o.pose_age_ms_p50},
                             {"pose_age_ms_p99", o.pose_age_ms_p99},
                             {"avatar_frames_received", o.avatar_frames_received},
                             {"avatar_fps", o.avatar_fps},
                             {"avatar_latency_ms_p50", o.avatar_latency_ms_p50},
                             {"avatar_latency_ms_p99", o.avatar_latency_ms_p99}});
    }
  }
  if (path.has_parent_path()) std::filesystem::create_directories(path.parent_path());
  std::ofstream out(path);
  out << j.dump(2, ' ', false, nlohmann::json::error_handler_t::replace) << "\n";
  if (!out) throw Error("cannot write '" + path.string() + "'");
}

std::string format_stats_table(const ViewerResult& r) {
  std::string s = fmt::format("depth codec {}, color codec {}, {} frames rendered{}\n",
                              r.depth_codec, r.color_codec, r.frames_rendered,
                              r.renderer.empty() ? "" : " (" + r.renderer + ")");
  s += fmt::format("{:<4} {:>9} {:>8} {:>7} {:>12} {:>12} {:>7} {:>7} {:>8} {:>8}  {}\n", "cam",
                   "size", "frames", "dropped", "depth B/fr", "color B/fr", "ratio", "fps",
                   "Mbit/s", "lat p50", "lat p99 / source");
  for (size_t i = 0; i < r.cameras.size(); ++i) {
    const CameraStats& c = r.cameras[i];
    s += fmt::format(
        "{:<4} {:>9} {:>8} {:>7} {:>12.0f} {:>12.0f} {:>6.2f}x {:>7.1f} {:>8.2f} {:>6.1f}ms  "
        "{:.1f}ms  {}\n",
        i, fmt::format("{}x{}", c.width, c.height), c.frames_received, c.frames_dropped,
        c.mean_depth_bytes, c.mean_color_bytes, c.depth_compression_ratio, c.received_fps,
        c.mbit_per_s, c.latency_ms_p50, c.latency_ms_p99, c.description);
  }
  if (!r.stages.empty()) {
    s += "latency by stage (ms)  ";
    for (const StageLatency& l : r.stages) s += fmt::format("{:>9}", l.stage);
    s += "\n                  p50  ";
    for (const StageLatency& l : r.stages) s += fmt::format("{:>9.2f}", l.p50_ms);
    s += "\n                  p99  ";
    for (const StageLatency& l : r.stages) s += fmt::format("{:>9.2f}", l.p99_ms);
    s += "\n";
  }
  if (r.session) {
    const ParticipantStats& p = *r.session;
    s += fmt::format(
        "session '{}': round trip p50 {:.2f} ms, p99 {:.2f} ms ({} samples); {} poses "
        "sent, {} avatar frames sent\n",
        printable(r.session_name), p.round_trip_ms_p50, p.round_trip_ms_p99, p.round_trip_samples,
        p.poses_sent, p.avatar_frames_sent);
    for (const RemoteStats& o : p.others)
      s += fmt::format(
          "  {:<20} poses {:>6} at {:>6.1f} Hz, age p50 {:>6.2f} ms p99 {:>6.2f} ms; "
          "avatar frames {:>5} at {:>5.1f} fps, latency p50 {:>6.1f} ms\n",
          printable(o.name, 20), o.poses_received, o.pose_rate_hz, o.pose_age_ms_p50,
          o.pose_age_ms_p99, o.avatar_frames_received, o.avatar_fps, o.avatar_latency_ms_p50);
  }
  s += fmt::format("ended: {} after {} frame sets{}\n", to_string(r.ended), r.frame_sets_received,
                   r.error.empty() ? "" : ": " + r.error);
  return s;
}

}  // namespace volcast
