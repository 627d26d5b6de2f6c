// The viewer, run_viewer: the steps below, in the order a depth frame takes them from the socket
// to the renderer, each saying which thread runs it.
//   1. connect, join          calling thread: TCP/TLS and the handshake (the Welcome names the
//                             cameras); a participant joins its session (on_connected)
//   2. open_feed              the hand-over point between the receiving and the render thread
//   3. RenderThread           render thread: the Presenter takes the newest frames from the feed,
//                             uploads them and reconstructs the points on the GPU (CameraRenderer;
//                             the headless presenter is in frame_feed.cpp)
//   4. Watchdog               its own thread: closes the connection at the time limit, on Ctrl-C or
//                             once the presenter closed, so that a blocked receive returns
//   5. receive_frame_sets     calling thread, per frame set: receive and decode (Client::receive,
//                             the cameras in parallel), keep_decoded, count, hand_to_renderer,
//                             save_frames
//   5b. receive_reconnecting calling thread: after a cut (the connection broke or fell silent),
//                             connect again, rejoin (on_reconnected), resume with a key frame set
//   6. wind down              stop the watchdog, close the connection, let the render thread draw
//                             what is pending (RenderThread::finish)
//   7. the figures            set_end, camera_figures, on_finished, finish (the JSON, and
//                             ViewerError on an error; how a session ends: viewer_end.cpp)
#include "volcast/pipeline/receiver.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <mutex>
#include <thread>

#include "frame_feed_state.hpp"
#include "viewer_end.hpp"
#include "volcast/codec/tier.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/core/text.hpp"

namespace volcast {
namespace {

using viewer_end::fail;
using viewer_end::finish;
using viewer_end::is_cut;
using viewer_end::message_of;
using viewer_end::set_end;

using Frames = std::vector<std::shared_ptr<const CameraFrame>>;

// Per camera: what arrived, over the whole run or since the last live refresh.
struct Accumulator {
  uint64_t frames = 0, dropped = 0, depth_bytes = 0, color_bytes = 0;
  std::vector<double> latencies_ms;
};

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

// 1. Connect (calling thread): TCP/TLS, the server's certificate, the handshake (Client). Null on
// a failure, with result saying why.
std::unique_ptr<Client> connect_to_server(const ViewerOptions& opt, ViewerResult& result) {
  try {
    return std::make_unique<Client>(opt.client);
  } catch (...) {
    fail(result, std::current_exception());
    return nullptr;
  }
}

// 1. Join (calling thread): options.on_connected, where a participant joins its session. False
// on a failure, with result saying why.
bool join(const ViewerOptions& opt, Client& client, ViewerResult& result) {
  if (!opt.on_connected) return true;
  try {
    opt.on_connected(client);
    return true;
  } catch (...) {
    fail(result, std::current_exception());
    return false;
  }
}

// 2. The feed's state for the Welcome's cameras: their calibrations, and what the live figures
// say from the start (descriptions, sizes, codecs).
void open_feed(FrameFeed::State& box, const protocol::Welcome& welcome, const ViewerOptions& opt) {
  const auto& cams = welcome.cameras;
  for (const auto& c : cams) box.cameras.push_back(c.calibration);
  box.live.tier = opt.client.tier;
  box.live.adaptive = opt.client.adapt;
  box.live.cameras.resize(cams.size());
  for (size_t i = 0; i < cams.size(); ++i) {
    box.live.cameras[i].description = printable(cams[i].description);
    box.live.cameras[i].width = cams[i].calibration.depth.width;
    box.live.cameras[i].height = cams[i].calibration.depth.height;
  }
}

// 3. The render thread (only with options.render): runs the presenter (options.presenter, else
// the headless one) on the feed, writing result.renderer and result.frames_rendered, then closes
// the feed. It owns the GL context and everything drawn with it.
class RenderThread {
 public:
  RenderThread(const ViewerOptions& opt, FrameFeed& feed, ViewerResult& result) {
    if (opt.render)
      thread_ = std::thread([this, &opt, &feed, &result] {
        try {
          (opt.presenter ? opt.presenter : headless_presenter(opt))(feed, result);
        } catch (...) {
          error_ = std::current_exception();
        }
        feed.close();  // the presenter is gone: nothing draws what arrives from now on
      });
  }

  // 6. Once receiving has ended (calling thread): marks the feed done and waits until the
  // presenter has drawn whatever is still pending and returned.
  void finish(const ViewerOptions& opt, FrameFeed::State& box) {
    if (!opt.render) return;
    {
      std::lock_guard lock(box.mutex);
      box.done = true;
    }
    box.changed.notify_all();
    thread_.join();  // renders whatever is still pending
  }

  // What the presenter threw, if it did (read after finish()).
  const std::exception_ptr& error() const { return error_; }

 private:
  std::exception_ptr error_;
  std::thread thread_;
};

// 4. The connection now, for the watchdog to close from its thread: a reconnect (5b) swaps it.
// Once closed, a client set later is closed at once and reconnecting stops.
class ClientSlot {
 public:
  void set(Client* client) {
    std::lock_guard lock(mutex_);
    client_ = client;
    if (closed_ && client_) client_->close();
  }
  void close() {
    std::lock_guard lock(mutex_);
    closed_ = true;
    if (client_) client_->close();
  }
  bool closed() const {
    std::lock_guard lock(mutex_);
    return closed_;
  }

 private:
  mutable std::mutex mutex_;
  Client* client_ = nullptr;
  bool closed_ = false;
};

// 4. The watchdog, on a thread of its own from construction to stop(): every 50 ms it checks the
// time limit (options.seconds, counted from its construction), the external stop flag and
// whether the presenter closed the feed; on any, it records which (stopped_by) and closes the
// connection so that a blocked receive() returns.
class Watchdog {
 public:
  Watchdog(const ViewerOptions& opt, ClientSlot& client, const FrameFeed::State& box) {
    const auto start = std::chrono::steady_clock::now();
    thread_ = std::thread([this, &opt, &client, &box, start] {
      std::unique_lock lock(mutex_);
      while (!finished_) {
        cv_.wait_for(lock, std::chrono::milliseconds(50));
        const bool timeout = opt.seconds > 0 && std::chrono::steady_clock::now() - start >
                                                    std::chrono::duration<double>(opt.seconds);
        if (timeout || (opt.stop && *opt.stop) || box.closed) {
          stopped_by_ = timeout                 ? ViewerEnd::kSecondsReached
                        : opt.stop && *opt.stop ? ViewerEnd::kInterrupted
                                                : ViewerEnd::kClosed;
          client.close();
          return;
        }
      }
    });
  }

  // 6. Ends the watchdog thread (calling thread) and waits for it.
  void stop() {
    {
      std::lock_guard lock(mutex_);
      finished_ = true;
    }
    cv_.notify_all();
    thread_.join();
  }

  // What the watchdog stopped the session for; kServerClosed if it did not.
  ViewerEnd stopped_by() const { return stopped_by_; }

 private:
  std::mutex mutex_;
  std::condition_variable cv_;
  bool finished_ = false;
  std::atomic<ViewerEnd> stopped_by_{ViewerEnd::kServerClosed};
  std::thread thread_;
};

// 5. What the receiving (calling) thread keeps while it receives.
struct Reception {
  explicit Reception(size_t cameras)
      : frames(cameras), buffers(cameras), total(cameras), recent(cameras) {}

  ReceivedFrameSet rx;  // the frame set the Client receives and decodes into
  // Each camera's newest decoded frame, and per camera the frames images are moved into (one no
  // longer held by the renderer is reused; a repeated frame keeps its frame).
  Frames frames;
  std::vector<std::vector<std::shared_ptr<CameraFrame>>> buffers;
  StageRecorder stages;
  std::vector<Accumulator> total;   // the whole run
  std::vector<Accumulator> recent;  // since the last live refresh
  int64_t live_from_us = wall_clock_us();
  int64_t first_rx_us = 0, last_rx_us = 0;
  uint64_t last_sequence = 0, received = 0;
  uint64_t tier_messages = 0;          // the client's TierState::messages taken
  std::vector<TierEvent> tier_events;  // the first 256
  uint64_t stale = 0;                  // decoded, not drawn (ViewerOptions::stale_ms)
  uint64_t undecodable = 0;            // of the clients before the one now (reconnects)
  std::vector<ViewerResult::Outage> outages;
};

// 5. What the server said of the tier since the last frame set (a change, a notice): kept for
// the figures and shown on the panel at once.
void note_tier(const Client& client, FrameFeed::State& box, Reception& r) {
  const TierState& t = client.tier();
  if (t.messages == r.tier_messages) return;
  const bool notice = t.messages == r.tier_messages + 1 && !r.tier_events.empty() &&
                      r.tier_events.back().tier == t.tier;
  r.tier_messages = t.messages;
  const TierEvent e{wall_clock_us(), t.tier, t.lossless_depth, notice, t.path_mbit_s, t.reason};
  if (r.tier_events.size() < 256) r.tier_events.push_back(e);
  std::lock_guard lock(box.mutex);
  box.live.tier = e.tier;
  box.live.lossless_depth = t.lossless_depth;
  box.live.path_mbit_s = t.path_mbit_s;
  box.live.tier_events.push_back(e);
  if (box.live.tier_events.size() > 8) box.live.tier_events.erase(box.live.tier_events.begin());
}

// 5. Keeps what was just decoded: the decoded images move (swap, no copy) into a frame the
// renderer may hold; the client decodes into the swapped-in buffers next time (decoders keep
// their own references). A camera that repeated its frame keeps its frame.
void keep_decoded(Reception& r) {
  for (size_t i = 0; i < r.frames.size(); ++i) {
    if (r.rx.repeated[i] && r.frames[i]) continue;
    std::shared_ptr<CameraFrame> frame;
    for (auto& b : r.buffers[i])
      if (b.use_count() == 1) frame = b;
    if (!frame) {
      frame = std::make_shared<CameraFrame>();
      if (r.buffers[i].size() < 4) r.buffers[i].push_back(frame);
    }
    CameraFrame& decoded = r.rx.frames.cameras[i];
    std::swap(frame->depth, decoded.depth);
    std::swap(frame->color, decoded.color);
    frame->device_timestamp_us = decoded.device_timestamp_us;
    r.frames[i] = std::move(frame);
  }
}

// 5. Counts the frame set, ready at `now_us`: stage times, bytes, latency, frame sets the server
// skipped (a gap in the sequence).
void count(Reception& r, int64_t now_us) {
  r.stages.add(r.rx.times, now_us);
  const double latency_ms = static_cast<double>(now_us - r.rx.frames.capture_time_us) / 1000.0;
  const uint64_t gap = r.received > 0 && r.rx.frames.sequence > r.last_sequence + 1
                           ? r.rx.frames.sequence - r.last_sequence - 1
                           : 0;
  for (size_t i = 0; i < r.frames.size(); ++i)
    for (Accumulator* a : {&r.total[i], &r.recent[i]}) {
      ++a->frames;
      a->dropped += gap;
      a->depth_bytes += r.rx.depth_bytes[i];
      a->color_bytes += r.rx.color_bytes[i];
      a->latencies_ms.push_back(latency_ms);
    }
  if (r.received == 0) r.first_rx_us = now_us;
  r.last_rx_us = now_us;
  r.last_sequence = r.rx.frames.sequence;
  ++r.received;
}

// 5. Hands the newest frames to the render thread (the presenter wakes up in FrameFeed::next) and,
// twice a second, refreshes the panel's live figures.
void hand_to_renderer(FrameFeed::State& box, Reception& r, int64_t now_us) {
  std::lock_guard lock(box.mutex);
  box.frames = r.frames;
  box.live.newest_capture_us = r.rx.frames.capture_time_us;
  box.handed_capture_us = r.rx.frames.capture_time_us;
  box.handed_ready_us = now_us;
  for (const auto& [presented, photon] : box.presented_ms)
    r.stages.add_presented(presented, photon);
  box.presented_ms.clear();
  ++box.version;
  box.changed.notify_one();
  if (now_us - r.live_from_us >= 500'000) {  // the panel's figures, twice a second
    update_live(box.live, r.total, r.recent, r.stages, r.received, now_us - r.live_from_us);
    r.live_from_us = now_us;
  }
}

// 5. options.save_frames_dir: each camera's decoded depth (and color) as PNG.
void save_frames(const std::filesystem::path& dir, const Frames& frames, uint64_t sequence) {
  for (size_t i = 0; i < frames.size(); ++i) {
    const CameraFrame& f = *frames[i];
    const std::string stem = fmt::format("cam{}_{:08d}", i, sequence);
    write_depth_png(dir / (stem + "_depth.png"), f.depth);
    if (!f.color.empty()) write_color_png(dir / (stem + "_color.png"), f.color);
  }
}

// 5. The receive loop (calling thread): until the frame limit, the server's end, the watchdog's
// close or the presenter's, each frame set is received and decoded, kept, counted, handed to the
// render thread and saved if asked. Returns what broke it off, or null.
std::exception_ptr receive_frame_sets(const ViewerOptions& opt, Client& client,
                                      FrameFeed::State& box, Reception& r) {
  try {
    if (!opt.save_frames_dir.empty()) std::filesystem::create_directories(opt.save_frames_dir);
    while ((opt.frames <= 0 || r.received < static_cast<uint64_t>(opt.frames)) &&
           client.receive(r.rx)) {
      note_tier(client, box, r);
      keep_decoded(r);
      const int64_t now = wall_clock_us();
      count(r, now);
      if (!r.outages.empty() && r.outages.back().back_us == 0) {
        r.outages.back().back_us = now;
        std::lock_guard lock(box.mutex);
        box.live.connection.clear();
      }
      const bool stale =
          opt.stale_ms > 0 && now - r.rx.frames.capture_time_us > int64_t{opt.stale_ms} * 1000;
      r.stale += stale;
      if (opt.render && !stale) hand_to_renderer(box, r, now);
      if (box.closed) break;  // the presenter ended the session, or failed
      if (!opt.save_frames_dir.empty())
        save_frames(opt.save_frames_dir, r.frames, r.rx.frames.sequence);
    }
  } catch (...) {
    return std::current_exception();
  }
  return nullptr;
}

// 5b. Sets what the panel says of the connection.
void show_connection(FrameFeed::State& box, const std::string& text, bool reconnected) {
  std::lock_guard lock(box.mutex);
  box.live.connection = text;
  box.live.reconnects += reconnected;
}

// 5b. After a cut (calling thread): connects again, the same config, until it works (a client
// whose site has the same cameras), the slot is closed (the watchdog: time, stop, presenter), the
// server refuses (thrown) or reconnect_give_up_s passed (null). Each try is bounded to 2 s.
std::unique_ptr<Client> connect_again(const ViewerOptions& opt, ClientSlot& slot,
                                      FrameFeed::State& box, const protocol::Welcome& site,
                                      const std::string& why) {
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  ClientConfig config = opt.client;
  config.connect_timeout_ms = std::min(config.connect_timeout_ms, 2000);
  if (config.handshake_timeout_ms <= 0 || config.handshake_timeout_ms > 2000)
    config.handshake_timeout_ms = 2000;
  auto wait = std::chrono::milliseconds(250);
  for (int attempt = 1; !slot.closed(); ++attempt) {
    show_connection(box, fmt::format("reconnecting (try {}): {}", attempt, why), false);
    std::unique_ptr<Client> client;
    try {
      client = std::make_unique<Client>(config);
    } catch (const ClientError& e) {
      if (e.kind() == ClientError::Kind::kRejected) throw;
      spdlog::info("viewer: reconnect try {}: {}", attempt, e.what());
    } catch (const Error& e) {
      spdlog::info("viewer: reconnect try {}: {}", attempt, e.what());
    }
    if (client) {
      const auto& cams = client->welcome().cameras;
      bool same = cams.size() == site.cameras.size();
      for (size_t i = 0; same && i < cams.size(); ++i)
        same = cams[i].calibration.depth.width == site.cameras[i].calibration.depth.width &&
               cams[i].calibration.depth.height == site.cameras[i].calibration.depth.height;
      if (!same)
        throw Error(fmt::format("the site came back with other cameras ({} camera(s), was {})",
                                cams.size(), site.cameras.size()));
      return client;
    }
    if (std::chrono::duration<double>(clock::now() - start).count() > opt.reconnect_give_up_s)
      return nullptr;
    for (auto t = clock::now() + wait; clock::now() < t && !slot.closed();)
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    wait = std::min(wait * 2, std::chrono::milliseconds(2000));
  }
  return nullptr;
}

// 5b. Receives over `client`, and with options.reconnect, over a new connection after each cut
// (on_reconnected joins the session again). Returns what ended it, or null; `client` is the last
// connection.
std::exception_ptr receive_reconnecting(const ViewerOptions& opt, std::unique_ptr<Client>& client,
                                        ClientSlot& slot, FrameFeed::State& box,
                                        const protocol::Welcome& site, Reception& r) {
  for (;;) {
    std::exception_ptr error = receive_frame_sets(opt, *client, box, r);
    if (!error || !opt.reconnect || slot.closed() || box.closed || !is_cut(error)) return error;
    const std::string why = message_of(error);
    spdlog::warn("viewer: {} -- reconnecting", why);
    if (r.outages.size() < 256) r.outages.push_back({wall_clock_us(), 0, why});
    client->close();  // what is still queued on the old path is stale: never read
    std::unique_ptr<Client> next;
    try {
      next = connect_again(opt, slot, box, site, why);
      if (next && opt.on_reconnected) opt.on_reconnected(*next);
    } catch (...) {
      return std::current_exception();
    }
    if (!next) return slot.closed() ? nullptr : error;  // stopped meanwhile, or given up
    spdlog::info("viewer: reconnected");
    r.undecodable += client->frames_undecodable();
    r.tier_messages = 0;
    slot.set(next.get());
    client = std::move(next);  // the old one goes after the participant moved off it
    show_connection(box, "reconnected: waiting for the key frame set", true);
  }
}

// 7. Each camera's figures over the whole run (rates over first to last frame set received).
std::vector<CameraStats> camera_figures(const protocol::Welcome& welcome, const Reception& r) {
  const auto& cams = welcome.cameras;
  std::vector<CameraStats> out;
  const double seconds = static_cast<double>(r.last_rx_us - r.first_rx_us) / 1e6;
  for (size_t i = 0; i < cams.size(); ++i) {
    const Accumulator& a = r.total[i];
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
    out.push_back(s);
  }
  return out;
}

}  // namespace

ViewerResult run_viewer(const ViewerOptions& opt) {
  ViewerResult result;
  result.tier = opt.client.tier;
  // 1. Connect and join; the client lives until the figures are written.
  std::unique_ptr<Client> connected = connect_to_server(opt, result);
  if (!connected || !join(opt, *connected, result)) return finish(opt, std::move(result));
  const protocol::Welcome welcome = connected->welcome();  // the site (a reconnect keeps it)

  // 2.-4. The feed, the render thread, the receiving state and the watchdog, in this order.
  FrameFeed::State box;
  open_feed(box, welcome, opt);
  FrameFeed feed(box);
  RenderThread render(opt, feed, result);
  Reception reception(welcome.cameras.size());
  ClientSlot slot;
  slot.set(connected.get());
  Watchdog watchdog(opt, slot, box);

  // 5. Receive until a limit, the server or an error ends it (5b: reconnecting after cuts).
  const std::exception_ptr receive_error =
      receive_reconnecting(opt, connected, slot, box, welcome, reception);

  // 6. Wind down: the watchdog, the connection, then the render thread draws what is pending.
  watchdog.stop();
  slot.close();
  render.finish(opt, box);
  Client& client = *connected;

  // 7. The figures.
  result.last_frames = reception.frames;
  result.frame_sets_received = reception.received;
  set_end(result, opt, render.error(), receive_error, reception.received, box.closed,
          watchdog.stopped_by());
  result.frames_undecodable = reception.undecodable + client.frames_undecodable();
  result.frames_stale = reception.stale;
  result.outages = std::move(reception.outages);
  result.tier = client.tier().tier;
  result.adaptive = opt.client.adapt;
  result.tier_events = std::move(reception.tier_events);
  {
    std::lock_guard lock(box.mutex);  // the last pictures' presented stages
    for (const auto& [presented, photon] : box.presented_ms)
      reception.stages.add_presented(presented, photon);
  }
  result.stages = reception.stages.summary();
  result.cameras = camera_figures(welcome, reception);
  if (opt.on_finished) {
    try {
      opt.on_finished(result);
    } catch (const std::exception& e) {
      spdlog::error("viewer: {}", e.what());
    }
  }
  return finish(opt, std::move(result));
}

}  // namespace volcast
