#include "volcast/net/stream/server.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <sys/eventfd.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <list>
#include <mutex>
#include <thread>

#include "volcast/net/transport/door.hpp"
#include "tier_encoder.hpp"
#include "volcast/codec/registry.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/worker_pool.hpp"
#include "volcast/net/transport/connection.hpp"
#include "volcast/net/stream/pacing.hpp"
#include "volcast/net/transport/websocket.hpp"

namespace volcast {
namespace {

// CPU time of the calling thread, milliseconds.
double thread_cpu_ms() {
  timespec t{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) / 1e6;
}

int64_t steady_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// An eventfd that wakes one viewer's thread when its tier has a new frame set.
struct WakeFd {
  int fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  ~WakeFd() { ::close(fd); }
  void signal() const {
    const uint64_t one = 1;
    [[maybe_unused]] const auto n = ::write(fd, &one, sizeof one);
  }
  void drain() const {
    uint64_t v;
    [[maybe_unused]] const auto n = ::read(fd, &v, sizeof v);
  }
};

}  // namespace

struct Server::Impl {
  ServerConfig config;
  std::vector<protocol::CameraInfo> cameras;
  std::unique_ptr<TcpListener> listener;
  std::unique_ptr<WorkerPool> pool;
  detail::DoorConfig door;
  detail::DoorCounters door_counters;
  std::function<void(detail::Admitted&)> admit_fn;
  std::thread door_thread;
  std::atomic<bool> stopping{false};

  mutable std::mutex mutex;  // guards everything below and each Tier's shared fields
  std::condition_variable captured_changed;
  std::shared_ptr<const CapturedFrameSet> captured;  // the newest published frame set
  std::deque<int64_t> published_us;  // steady times of the last publish() calls (at most 33)
  double peak_fps = 0;               // see note_published()
  int64_t peak_us = 0;
  double budget_cores = 1;   // ServerConfig::tier_cpu_budget, the default worked out
  uint64_t site_pixels = 0;  // depth pixels of every camera together

  struct Tier {
    Tier(detail::TierKey key, size_t cameras) : encoder(std::move(key), cameras) {}
    detail::TierEncoder encoder;  // used by the tier's thread only
    std::thread thread;
    // Guarded by Impl::mutex:
    std::shared_ptr<const detail::EncodedFrames> latest;
    std::vector<const WakeFd*> subscribers;
    // Consumers that take every frame set (add_tier_tap), each with whether it has begun (at a
    // key frame set).
    struct Tap {
      uint64_t id = 0;
      std::shared_ptr<std::function<void(const TierFrameSet&)>> fn;
      bool begun = false;
    };
    std::vector<Tap> taps;
    bool key_wanted = true;
    bool stop = false;
    TierReport report;
    double encode_ms_total = 0;
    double encode_ns = 0;    // estimated CPU per frame set (detail::tier_encode_ns)
    double cpu_ms_mean = 0;  // measured codec CPU per frame set, moving average
  };
  std::list<std::shared_ptr<Tier>> tiers;
  std::vector<std::thread> retired;  // threads of tiers told to stop, to be joined without mutex

  struct Viewer {
    uint64_t id = 0;
    std::unique_ptr<Connection> connection;
    // Session messages waiting for this viewer's thread (guarded by Impl::mutex): coalesce key
    // (0: none) and the whole message.
    std::deque<std::pair<uint64_t, std::shared_ptr<const std::vector<uint8_t>>>> outbox;
    std::string kicked;  // set: disconnect with this reason
    std::shared_ptr<Tier> tier;
    std::string address;  // the peer's IP address (per-address tier limits)
    std::thread thread;
    WakeFd wake;
    ViewerReport report;
    std::atomic<bool> done{false};
  };
  std::list<Viewer> viewers;
  uint64_t next_viewer_id = 1;
  uint64_t next_tap_id = 1;
  std::deque<ViewerReport> ended;  // reports of viewers that left, newest last (bounded)
  static constexpr size_t kEndedReportsKept = 256;

  // Runs on the door's thread for each authenticated viewer: applies the server's policy, then
  // gives the viewer a tier and a thread. Throws Error (the door sends it as a Reject).
  void admit(detail::Admitted& a) {
    join_retired();
    std::lock_guard lock(mutex);
    reap_finished();
    const protocol::Hello& hello = a.hello;
    try {
      int active = 0;
      for (const auto& v : viewers) active += !v.done;
      if (active >= config.max_viewers)
        throw Error("server full (" + std::to_string(config.max_viewers) + " viewers)");
      check_offered(hello);
      Viewer& v = viewers.emplace_back();
      v.id = next_viewer_id++;
      v.report.id = v.id;
      v.address = a.address;
      try {
        v.tier = subscribe({hello.depth_codec, hello.color_codec, hello.color_quality}, &v.wake,
                           &v.address);
      } catch (...) {
        viewers.pop_back();
        throw;
      }
      v.connection = std::move(a.connection);
      v.report.peer = v.connection->peer();
      v.report.connected = true;
      v.report.depth_codec = hello.depth_codec;  // known codec names: subscribe checked them
      v.report.color_codec = hello.color_codec;
      v.report.color_quality = hello.color_quality;
      v.thread = std::thread([this, &v] { serve_viewer(v); });
    } catch (const Error& e) {
      ViewerReport r;
      r.peer = a.connection->peer();
      r.error = e.what();
      ended.push_back(std::move(r));
      if (ended.size() > kEndedReportsKept) ended.pop_front();
      throw;
    }
  }

  // Throws Error naming the offered tiers if the viewer's is not one of them.
  void check_offered(const protocol::Hello& hello) const {
    if (config.offered_tiers.empty()) return;
    std::string list;
    for (const auto& t : config.offered_tiers) {
      const size_t a = t.find('/'), b = t.find('/', a + 1);
      const bool quality_given = b != std::string::npos;
      if (t.substr(0, a) == hello.depth_codec &&
          t.substr(a + 1, quality_given ? b - a - 1 : std::string::npos) == hello.color_codec &&
          (!quality_given || std::stoi(t.substr(b + 1)) == hello.color_quality))
        return;
      list += (list.empty() ? "" : ", ") + t;
    }
    throw Error("this server does not offer that tier; it offers " + list);
  }

  // The site's frame rate for tier costs; 30 before the first frame sets.
  double site_fps() const { return peak_fps > 0 ? peak_fps : 30; }

  // Called by publish() with mutex held: notes the time and updates peak_fps, the highest rate
  // (from the median gap between the last 33 publish() calls) seen in the last 30 s, so that a
  // publisher slowed for a while by a busy machine does not make the tiers look cheap.
  void note_published() {
    const int64_t now = steady_us();
    published_us.push_back(now);
    if (published_us.size() > 33) published_us.pop_front();
    if (published_us.size() < 3) return;
    std::array<int64_t, 32> gaps;
    const size_t n = published_us.size() - 1;
    for (size_t i = 0; i < n; ++i) gaps[i] = published_us[i + 1] - published_us[i];
    std::nth_element(gaps.begin(), gaps.begin() + n / 2, gaps.begin() + n);
    const double fps = std::clamp(1e6 / double(std::max<int64_t>(gaps[n / 2], 1)), 1.0, 1000.0);
    if (fps >= peak_fps || now - peak_us > 30'000'000) {
      peak_fps = fps;
      peak_us = now;
    }
  }

  // Whether the viewers of `address` are all that watch `tier` (no other address, no tap).
  bool held_alone_by(const Tier& tier, const std::string& address) const {
    if (!tier.taps.empty()) return false;
    bool any = false;
    for (const auto& v : viewers) {
      if (v.done || v.tier.get() != &tier) continue;
      if (v.address != address) return false;
      any = true;
    }
    return any;
  }

  // Throws Error if a new tier `key` costing `encode_ns` per frame set would take the tiers past
  // the CPU budget, or the tiers `address` holds alone past its share (the count, half the
  // budget). The costliest tiers are the first not to fit. Caller holds mutex.
  void check_tier_budget(const detail::TierKey& key, double encode_ns,
                         const std::string& address) const {
    const double fps = site_fps();
    const double cost = encode_ns * fps / 1e9;
    double total = 0, alone = 0;
    int alone_count = 0;
    for (const auto& t : tiers) {
      if (t->stop) continue;
      const double c = t->encode_ns * fps / 1e9;
      total += c;
      if (held_alone_by(*t, address)) {
        alone += c;
        ++alone_count;
      }
    }
    const std::string name = key.depth_codec + "/" + key.color_codec +
                             (key.color_quality > 0 ? "/" + std::to_string(key.color_quality) : "");
    // Each reason fits the 200 characters a viewer shows of a Reject.
    if (total + cost > budget_cores)
      throw Error(fmt::format(
          "tier {} would cost about {:.2f} CPU cores; the tiers' budget is {:.2f} cores "
          "(--tier-cpu-budget), {:.2f} in use: choose cheaper codecs or a tier already watched",
          name, cost, budget_cores, total));
    if (alone_count >= config.max_tiers_per_address)
      throw Error(
          fmt::format("your address holds {} tiers nobody else watches, the most per address "
                      "(--max-tiers-per-address): choose the codecs of a viewer already watching",
                      alone_count));
    if (alone + cost > budget_cores / 2)
      throw Error(fmt::format(
          "tier {} would cost about {:.2f} CPU cores; your address's own tiers use {:.2f} of its "
          "share, {:.2f} cores (half the --tier-cpu-budget): choose cheaper codecs",
          name, cost, alone, budget_cores / 2));
  }

  // Joins the threads of viewers that have ended (keeping their reports) and of tiers nobody
  // watches any more. Caller holds mutex (a finished viewer thread no longer takes it; a tier
  // thread told to stop leaves without taking it).
  void reap_finished() {
    for (auto it = viewers.begin(); it != viewers.end();) {
      if (!it->done) {
        ++it;
        continue;
      }
      if (it->thread.joinable()) it->thread.join();
      ended.push_back(it->report);
      if (ended.size() > kEndedReportsKept) ended.pop_front();
      it = viewers.erase(it);
    }
    for (auto it = tiers.begin(); it != tiers.end();) {
      if (!(*it)->subscribers.empty() || !(*it)->taps.empty()) {
        ++it;
        continue;
      }
      (*it)->stop = true;
      retired.push_back(std::move((*it)->thread));
      it = tiers.erase(it);
    }
    captured_changed.notify_all();
  }

  // Joins the threads of stopped tiers. Caller must not hold mutex.
  void join_retired() {
    std::vector<std::thread> threads;
    {
      std::lock_guard lock(mutex);
      threads.swap(retired);
    }
    for (auto& t : threads) t.join();
  }

  void update(Viewer& v, const std::function<void(ViewerReport&)>& f) {
    std::lock_guard lock(mutex);
    f(v.report);
  }

  // The tier's thread: encodes the newest frame set whenever there is one it has not encoded.
  void run_tier(std::shared_ptr<Tier> tier) {
    uint64_t last_sequence = 0, since_key = 0;
    auto last_key = std::chrono::steady_clock::now() - std::chrono::hours(1);
    while (true) {
      std::shared_ptr<const CapturedFrameSet> frames;
      bool key = false, seal = false;
      {
        std::unique_lock lock(mutex);
        captured_changed.wait(lock, [&] {
          return stopping || tier->stop || (captured && captured->sequence > last_sequence);
        });
        if (stopping || tier->stop) break;
        if (tier->subscribers.empty() &&
            tier->taps.empty()) {  // nobody: encode nothing until reaped or rejoined
          last_sequence = captured->sequence;
          continue;
        }
        frames = captured;
        // Over TLS and for enough viewers, sealed once here rather than encrypted once per viewer.
        seal = !config.insecure &&
               static_cast<int>(tier->subscribers.size()) >= config.seal_from_viewers;
        const auto now = std::chrono::steady_clock::now();
        // A replayed frame set recorded on this tier brings its own key frame sets: passing its
        // deltas through beats making keys on schedule.
        const EncodedFrameSetBody* pre = frames->encoded.get();
        const detail::TierKey& tk = tier->encoder.key();
        const bool recorded_tier = pre && pre->depth_codec == tk.depth_codec &&
                                   pre->color_codec == tk.color_codec &&
                                   pre->color_quality == tk.color_quality;
        key =
            tier->report.frames_encoded == 0 ||
            (!recorded_tier && since_key + 1 >= static_cast<uint64_t>(config.key_frame_interval)) ||
            (tier->key_wanted &&
             now - last_key >= std::chrono::milliseconds(config.min_key_interval_ms));
      }
      last_sequence = frames->sequence;
      const auto start = std::chrono::steady_clock::now();
      std::shared_ptr<const detail::EncodedFrames> encoded;
      try {
        encoded = tier->encoder.encode(*frames, key, *pool, seal);
      } catch (const std::exception& e) {
        spdlog::error("tier {}/{}: frame set {} not encoded: {}", tier->report.depth_codec,
                      tier->report.color_codec, frames->sequence, e.what());
        continue;
      }
      const auto end = std::chrono::steady_clock::now();
      std::unique_lock lock(mutex);
      if (encoded->key) {
        since_key = 0;
        last_key = end;
        tier->key_wanted = false;
        ++tier->report.key_frames;
      } else {
        ++since_key;
      }
      ++tier->report.frames_encoded;
      tier->encode_ms_total += std::chrono::duration<double, std::milli>(end - start).count();
      const double weight = 1.0 / double(std::min<uint64_t>(tier->report.frames_encoded, 30));
      tier->cpu_ms_mean += (tier->encoder.last_cpu_ms() - tier->cpu_ms_mean) * weight;
      tier->latest = encoded;
      for (const WakeFd* w : tier->subscribers) w->signal();
      if (tier->taps.empty()) continue;
      std::vector<std::shared_ptr<std::function<void(const TierFrameSet&)>>> taps;
      for (auto& tap : tier->taps) {
        tap.begun = tap.begun || encoded->key;
        if (tap.begun) taps.push_back(tap.fn);
      }
      lock.unlock();
      const TierFrameSet f{encoded->sequence, encoded->key, encoded->capture_us,
                           encoded->body,     encoded,      encoded->index};
      for (const auto& tap : taps) (*tap)(f);
    }
  }

  // Finds or makes the tier and subscribes `wake` (if not null) to it. A new tier for a viewer
  // from `address` must fit the CPU budget (check_tier_budget); one for a tap (`address` null)
  // is made regardless. Caller holds mutex. Throws Error.
  std::shared_ptr<Tier> subscribe(const detail::TierKey& key, const WakeFd* wake,
                                  const std::string* address) {
    std::shared_ptr<Tier> tier;
    for (const auto& t : tiers)
      if (t->encoder.key() == key && !t->stop) tier = t;
    if (!tier) {
      if (static_cast<int>(tiers.size()) >= config.max_tiers)
        throw Error("server has " + std::to_string(config.max_tiers) +
                    " tiers already; choose the codecs of a viewer already watching");
      const double encode_ns = detail::tier_encode_ns(key, site_pixels);  // unknown codecs throw
      if (address) check_tier_budget(key, encode_ns, *address);
      tier = std::make_shared<Tier>(key, cameras.size());
      tier->encode_ns = encode_ns;
      tier->report.depth_codec = key.depth_codec;
      tier->report.color_codec = key.color_codec;
      tier->report.color_quality = key.color_quality;
      tiers.push_back(tier);
      tier->thread = std::thread([this, tier] { run_tier(tier); });
    }
    if (wake) tier->subscribers.push_back(wake);
    tier->key_wanted = true;  // the newcomer needs a key frame (a no-op for non-temporal tiers)
    return tier;
  }

  void unsubscribe(Tier& tier, const WakeFd& wake) {
    std::lock_guard lock(mutex);
    std::erase(tier.subscribers, &wake);
  }

  void serve_viewer(Viewer& v) {
    Connection& c = *v.connection;
    try {
      protocol::Welcome welcome{cameras, wall_clock_us()};
      c.write_all(protocol::message(protocol::MessageType::kWelcome, protocol::serialize(welcome)),
                  config.stall_timeout_ms);
      spdlog::info("viewer {} connected (depth {}, color {})", v.report.peer, v.report.depth_codec,
                   v.report.color_codec);
      stream(v, *v.tier);
    } catch (const std::exception& e) {
      if (!stopping) spdlog::info("viewer {} ended: {}", v.report.peer, e.what());
      update(v, [&](ViewerReport& r) { r.error = e.what(); });
    }
    unsubscribe(*v.tier, v.wake);
    c.shutdown();
    std::string why;
    update(v, [&](ViewerReport& r) {
      r.connected = false;
      why = r.error.empty() ? "server stopping" : r.error;
      v.outbox.clear();
    });
    if (config.session) {
      try {
        config.session->on_viewer_left(v.id, why);
      } catch (const std::exception& e) {
        spdlog::error("session: viewer {} left: {}", v.id, e.what());
      }
    }
    v.done = true;
  }

  // Writes the session messages queued for `v` (in order); throws Error if it was kicked.
  void flush_session(Viewer& v, std::vector<std::shared_ptr<const std::vector<uint8_t>>>& batch) {
    batch.clear();
    {
      std::lock_guard lock(mutex);
      if (!v.kicked.empty()) throw Error(v.kicked);
      for (auto& m : v.outbox) batch.push_back(std::move(m.second));
      v.outbox.clear();
    }
    for (const auto& m : batch) v.connection->write_all(*m, config.stall_timeout_ms);
  }

  // Reads one message from the viewer: an Ack, a KeyFrameRequest, or a session message (for the
  // session service, else skipped). Anything else ends the connection.
  void read_control(Viewer& v, Tier& tier, Pacer& pacer, std::vector<uint8_t>& payload) {
    Connection& c = *v.connection;
    uint8_t header_bytes[protocol::kHeaderBytes];
    c.read_exact(header_bytes, config.handshake_timeout_ms);
    const protocol::Header h = protocol::parse_header(header_bytes);
    const uint8_t session_type = static_cast<uint8_t>(static_cast<uint16_t>(h.type) & 0xff);
    const bool session = h.channel == protocol::Channel::kSession;
    const uint32_t limit = session && config.session ? config.session->max_payload(session_type)
                                                     : protocol::kMaxControlBytes;
    if (limit == 0)
      throw Error("viewer sent an unknown session message type " + std::to_string(session_type));
    if (h.payload_bytes > limit)
      throw Error("viewer sent a message of " + std::to_string(h.payload_bytes) +
                  " bytes, over the limit of " + std::to_string(limit));
    payload.resize(h.payload_bytes);
    c.read_exact(payload, config.handshake_timeout_ms);
    if (session && config.session) {
      config.session->on_message(v.id, session_type, payload);
      return;
    }
    if (h.type == protocol::MessageType::kAck) {
      if (!pacer.on_ack(protocol::parse_ack(payload), steady_us()))
        throw Error("viewer acknowledged a frame set it was not sent");
    } else if (h.type == protocol::MessageType::kKeyFrameRequest) {
      std::lock_guard lock(mutex);
      tier.key_wanted = true;
      ++v.report.key_requests;
    } else if (h.channel != protocol::Channel::kSession) {
      throw Error("viewer sent an unexpected message");
    }
  }

  void stream(Viewer& v, Tier& tier) {
    Connection& c = *v.connection;
    Pacer pacer(config.max_window);
    std::vector<uint8_t> payload;
    uint64_t last_sequence = 0;  // the site sequence last sent (or skipped)
    uint64_t last_index = 0;     // the tier index last sent; a delta needs index == last + 1
    bool synced = false;
    auto last_progress = std::chrono::steady_clock::now();
    const double cpu_start_ms = thread_cpu_ms();
    std::vector<std::shared_ptr<const std::vector<uint8_t>>> batch;
    while (!stopping) {
      const Connection::Ready ready = c.wait(v.wake.fd, 100);
      if (ready.woken) v.wake.drain();
      if (ready.readable) {
        read_control(v, tier, pacer, payload);
        last_progress = std::chrono::steady_clock::now();
      }
      flush_session(v, batch);  // session messages go ahead of frame sets
      if (!batch.empty())
        update(v, [&](ViewerReport& r) { r.send_cpu_ms = thread_cpu_ms() - cpu_start_ms; });
      if (pacer.frames_in_flight() > 0 && std::chrono::steady_clock::now() - last_progress >
                                              std::chrono::milliseconds(config.stall_timeout_ms))
        throw Error("viewer stalled: acknowledged nothing for " +
                    std::to_string(config.stall_timeout_ms) + " ms");
      std::shared_ptr<const detail::EncodedFrames> frames;
      {
        std::lock_guard lock(mutex);
        frames = tier.latest;
      }
      if (!frames || frames->sequence <= last_sequence) continue;
      if (!pacer.can_send(frames->body.size() + protocol::kFrameSetPrefixBytes)) continue;
      const int64_t now_wall = wall_clock_us();
      const bool decodable = frames->key || (synced && frames->index == last_index + 1);
      const bool stale = now_wall - frames->capture_us > int64_t{config.latency_budget_ms} * 1000;
      if (!decodable || stale) {
        // Skip it: too old, or a delta whose reference this viewer lacks (it waits for a key).
        std::lock_guard lock(mutex);
        ++v.report.frames_dropped;
        v.report.frames_stale += stale;
        if (!decodable) tier.key_wanted = true;
        synced = false;
        last_sequence = frames->sequence;
        continue;
      }
      size_t bytes = 0;
      if (c.encrypted() && c.carries_raw() && !frames->sealed.empty()) {
        // Key, tags and digests inside this viewer's TLS session; the sealed body after them,
        // outside TLS: the same bytes for every viewer of the tier (protocol.hpp, 1.2).
        const auto prefix = protocol::sealed_frame_set_prefix(frames->seal_rest.size(), now_wall);
        const std::span<const uint8_t> parts[2] = {prefix, frames->seal_rest};
        c.write_with_raw(parts, frames->sealed, config.stall_timeout_ms);
        bytes = prefix.size() + frames->seal_rest.size() + frames->sealed.size();
      } else {
        const auto prefix = protocol::frame_set_prefix(frames->body.size(), now_wall);
        const std::span<const uint8_t> parts[2] = {prefix, frames->body};
        c.write_all(parts, config.stall_timeout_ms);
        bytes = prefix.size() + frames->body.size();
      }
      if (pacer.frames_in_flight() == 0) last_progress = std::chrono::steady_clock::now();
      pacer.on_send(frames->sequence, bytes, steady_us());
      std::lock_guard lock(mutex);
      if (last_sequence > 0 && frames->sequence > last_sequence + 1)
        v.report.frames_dropped += frames->sequence - last_sequence - 1;
      last_sequence = frames->sequence;
      last_index = frames->index;
      synced = true;
      ++v.report.frames_sent;
      v.report.bytes_sent += bytes;
      v.report.min_rtt_ms = pacer.min_rtt_us() / 1000;
      v.report.bottleneck_mbit_s = pacer.bottleneck_bytes_per_us() * 8;
      v.report.window = pacer.window_frames();
      v.report.send_cpu_ms = thread_cpu_ms() - cpu_start_ms;
    }
  }
};

Server::Server(std::vector<protocol::CameraInfo> cameras, ServerConfig config)
    : impl_(std::make_unique<Impl>()) {
  if (config.max_window < 1) throw Error("server: --max-window must be at least 1");
  if (config.latency_budget_ms < 1) throw Error("server: --latency-budget must be at least 1 ms");
  if (config.max_viewers < 1) throw Error("server: --max-viewers must be at least 1");
  if (config.seal_from_viewers < 1) throw Error("server: seal_from_viewers must be at least 1");
  if (config.key_frame_interval < 1) throw Error("server: --key-frame-interval must be at least 1");
  if (!(config.tier_cpu_budget >= 0) || config.tier_cpu_budget > 1e6)
    throw Error("server: --tier-cpu-budget must be a number of cores, 0 for the default");
  if (config.max_tiers_per_address < 1)
    throw Error("server: --max-tiers-per-address must be at least 1");
  if (cameras.empty() || static_cast<int>(cameras.size()) > protocol::kMaxCameras)
    throw Error("server: a site needs 1 to " + std::to_string(protocol::kMaxCameras) + " cameras");
  // What every viewer would refuse (protocol.hpp's limits) is refused here, at start.
  uint64_t pixels = 0;
  for (const auto& cam : cameras) {
    const Intrinsics& k = cam.calibration.depth;
    if (k.width < 1 || k.height < 1 || k.width > protocol::kMaxCameraSide ||
        k.height > protocol::kMaxCameraSide)
      throw Error("server: camera '" + cam.description + "' is " + std::to_string(k.width) + "x" +
                  std::to_string(k.height) + "; viewers accept 1 to " +
                  std::to_string(protocol::kMaxCameraSide) + " pixels per side");
    pixels += uint64_t(k.width) * uint64_t(k.height);
  }
  if (pixels > protocol::kMaxSitePixels)
    throw Error("server: the site's cameras have " + std::to_string(pixels) +
                " pixels together; viewers accept at most " +
                std::to_string(protocol::kMaxSitePixels));
  if (protocol::serialize(protocol::Welcome{cameras, 0}).size() > protocol::kMaxWelcomeBytes)
    throw Error("server: the Welcome would exceed the viewers' limit (camera names too long?)");
  if (config.handshake_timeout_ms < 1 || config.max_pending < 1 ||
      config.max_pending_per_address < 1)
    throw Error("server: handshake timeout and pending-handshake limits must be at least 1");
  for (const auto& t : config.offered_tiers) {
    const size_t a = t.find('/'), b = a == std::string::npos ? a : t.find('/', a + 1);
    const std::string depth = t.substr(0, a);
    const std::string color =
        a == std::string::npos ? "" : t.substr(a + 1, b == std::string::npos ? b : b - a - 1);
    int quality = 0;
    if (b != std::string::npos) {
      const std::string q = t.substr(b + 1);
      const bool digits =
          !q.empty() && q.size() <= 3 && q.find_first_not_of("0123456789") == std::string::npos;
      quality = digits ? std::stoi(q) : -1;
    }
    if (!find_depth_codec(depth) || !find_color_codec(color) || quality < 0 || quality > 100)
      throw Error("server: offered tier '" + t +
                  "' must be DEPTH/COLOR or DEPTH/COLOR/QUALITY with codecs this build has "
                  "(volcast view --help lists them) and a quality 1..100");
  }
  const std::string bind = resolve_bind_address(config.bind_address);
  if (config.insecure && !is_loopback_address(bind))
    throw Error(
        "server: --insecure (plain TCP, no encryption) is allowed only on a loopback "
        "address, not " +
        config.bind_address + ": the stream shows an operating room; drop --insecure to use TLS");
  impl_->door.token = config.token ? *config.token : random_join_token();
  if (!config.insecure)
    impl_->door.tls = TlsContext::server(config.identity.certificate_pem.empty()
                                             ? make_self_signed_identity("volcast server")
                                             : config.identity);
  if (!config.web_root.empty())
    impl_->door.web =
        std::make_shared<const detail::WebAssets>(detail::load_web_assets(config.web_root));
  impl_->door.handshake_timeout_ms = config.handshake_timeout_ms;
  impl_->door.max_pending = config.max_pending;
  impl_->door.max_pending_per_address = config.max_pending_per_address;
  impl_->door.free_wrong_tokens = kFreeWrongTokens;
  impl_->budget_cores = config.tier_cpu_budget > 0
                            ? config.tier_cpu_budget
                            : std::max(1.0, double(std::thread::hardware_concurrency()) / 2);
  impl_->site_pixels = pixels;
  impl_->config = std::move(config);
  impl_->cameras = std::move(cameras);
  impl_->pool = std::make_unique<WorkerPool>(impl_->config.encode_threads);
  impl_->listener = std::make_unique<TcpListener>(bind, impl_->config.port);
  impl_->admit_fn = [this](detail::Admitted& a) { impl_->admit(a); };
  impl_->door_thread = std::thread([this] {
    detail::run_door(*impl_->listener, impl_->door, impl_->stopping, impl_->admit_fn,
                     impl_->door_counters);
  });
}

uint64_t Server::add_tier_tap(const std::string& depth_codec, const std::string& color_codec,
                              int color_quality, std::function<void(const TierFrameSet&)> tap) {
  std::lock_guard lock(impl_->mutex);
  if (impl_->stopping) throw Error("server: stopped");
  auto tier = impl_->subscribe({depth_codec, color_codec, color_quality}, nullptr, nullptr);
  double total = 0;
  for (const auto& t : impl_->tiers) total += t->encode_ns;
  total *= impl_->site_fps() / 1e9;
  if (total > impl_->budget_cores)
    spdlog::warn(
        "server: with the tap on tier {}/{}, the tiers cost about {:.2f} CPU cores, over the "
        "budget of {:.2f} (--tier-cpu-budget): viewers asking for a new tier are refused",
        depth_codec, color_codec, total, impl_->budget_cores);
  const uint64_t id = impl_->next_tap_id++;
  tier->taps.push_back(
      {id, std::make_shared<std::function<void(const TierFrameSet&)>>(std::move(tap)), false});
  return id;
}

void Server::remove_tier_tap(uint64_t id) {
  {
    std::lock_guard lock(impl_->mutex);
    for (const auto& tier : impl_->tiers)
      std::erase_if(tier->taps, [id](const Impl::Tier::Tap& t) { return t.id == id; });
    impl_->reap_finished();  // a tier nobody watches or taps any more stops encoding
  }
  impl_->join_retired();
}

void Server::request_key_frame(const std::string& depth_codec, const std::string& color_codec,
                               int color_quality) {
  std::lock_guard lock(impl_->mutex);
  const detail::TierKey key{depth_codec, color_codec, color_quality};
  for (const auto& tier : impl_->tiers)
    if (tier->encoder.key() == key && !tier->stop) tier->key_wanted = true;
}

Server::~Server() {
  stop();
}

uint16_t Server::port() const {
  return impl_->listener->port();
}

const JoinToken& Server::token() const {
  return impl_->door.token;
}

std::string Server::fingerprint() const {
  return impl_->door.tls ? impl_->door.tls->fingerprint() : std::string();
}

std::string Server::join_link(const std::string& host) const {
  JoinLink link;
  link.host = host;
  link.port = port();
  link.token = token();
  link.fingerprint = fingerprint();
  link.insecure = !impl_->door.tls;
  return format_join_link(link);
}

std::string Server::web_link(const std::string& host) const {
  if (!impl_->door.web) return {};
  const bool v6 = host.find(':') != std::string::npos;
  return std::string(impl_->door.tls ? "https://" : "http://") + (v6 ? "[" : "") + host +
         (v6 ? "]" : "") + ":" + std::to_string(port()) + "/#token=" + to_hex(token());
}

double Server::tier_cpu_budget() const {
  return impl_->budget_cores;
}

DoorReport Server::door() const {
  const auto& c = impl_->door_counters;
  return {c.admitted,   c.wrong_token, c.backed_off, c.failed,
          c.over_limit, c.web_files,   c.web_viewers};
}

void Server::publish(std::shared_ptr<const CapturedFrameSet> frames) {
  if (!frames || frames->cameras.size() != impl_->cameras.size())
    throw Error("server: frame set has the wrong number of cameras");
  for (const auto& f : frames->cameras)
    if (!f) throw Error("server: frame set has a missing camera frame");
  {
    std::lock_guard lock(impl_->mutex);
    impl_->captured = std::move(frames);
    impl_->note_published();
  }
  impl_->captured_changed.notify_all();
  // The tiers' threads wake to encode it on the pool: wake its workers now too, not after them.
  impl_->pool->prewake(std::chrono::milliseconds(2));
}

bool Server::send_session(uint64_t viewer, std::shared_ptr<const std::vector<uint8_t>> message,
                          uint64_t coalesce_key) {
  std::lock_guard lock(impl_->mutex);
  for (auto& v : impl_->viewers) {
    if (v.id != viewer) continue;
    if (v.done || !v.kicked.empty()) return false;
    bool replaced = false;
    if (coalesce_key != 0)
      for (auto& m : v.outbox)
        if (m.first == coalesce_key) {
          m.second = std::move(message);
          replaced = true;
          break;
        }
    if (!replaced) {
      if (v.outbox.size() >= 4096) {
        v.kicked = "session messages piled up (4096 unsent): the viewer does not read";
      } else {
        v.outbox.emplace_back(coalesce_key, std::move(message));
      }
    }
    v.wake.signal();
    return true;
  }
  return false;
}

void Server::disconnect(uint64_t viewer, const std::string& why) {
  std::lock_guard lock(impl_->mutex);
  for (auto& v : impl_->viewers)
    if (v.id == viewer && !v.done) {
      if (v.kicked.empty()) v.kicked = why;
      v.wake.signal();
    }
}

std::vector<ViewerReport> Server::viewers() const {
  std::lock_guard lock(impl_->mutex);
  std::vector<ViewerReport> out(impl_->ended.begin(), impl_->ended.end());
  for (const auto& v : impl_->viewers) out.push_back(v.report);
  return out;
}

std::vector<TierReport> Server::tiers() const {
  std::lock_guard lock(impl_->mutex);
  std::vector<TierReport> out;
  const double fps = impl_->site_fps();
  for (const auto& t : impl_->tiers) {
    TierReport r = t->report;
    r.viewers = static_cast<int>(t->subscribers.size());
    if (r.frames_encoded > 0) r.encode_ms_mean = t->encode_ms_total / double(r.frames_encoded);
    r.cpu_ms_mean = t->cpu_ms_mean;
    r.cost_cores = t->encode_ns * fps / 1e9;
    out.push_back(r);
  }
  return out;
}

void Server::stop() {
  if (impl_->stopping.exchange(true)) return;
  impl_->listener->close();
  if (impl_->door_thread.joinable()) impl_->door_thread.join();
  {
    std::lock_guard lock(impl_->mutex);
    for (auto& v : impl_->viewers) v.connection->shutdown();
  }
  impl_->captured_changed.notify_all();
  // The door's thread has ended, so the viewer list no longer changes; viewer threads notice
  // `stopping` within 100 ms and must be joined without holding the mutex they report through.
  for (auto& v : impl_->viewers)
    if (v.thread.joinable()) v.thread.join();
  {
    std::lock_guard lock(impl_->mutex);
    for (auto& t : impl_->tiers) impl_->retired.push_back(std::move(t->thread));
  }
  impl_->captured_changed.notify_all();
  impl_->join_retired();
}

}  // namespace volcast
