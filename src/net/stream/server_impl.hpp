#pragma once
// Internal to volcast_net_stream: the Server's state and its steps, shared by its three files --
// server.cpp (the public API, and admitting the viewers the door hands on), server_tiers.cpp
// (tiers: their encoding threads, the CPU budget, subscriptions) and server_viewer.cpp (each
// viewer's thread: Welcome, frame sets paced by its Acks, session messages).
#include <sys/eventfd.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <list>
#include <mutex>
#include <thread>

#include "tier_encoder.hpp"
#include "volcast/core/worker_pool.hpp"
#include "volcast/net/stream/pacing.hpp"
#include "volcast/net/stream/server.hpp"
#include "volcast/net/transport/connection.hpp"
#include "volcast/net/transport/door.hpp"

namespace volcast {

struct Server::Impl {
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
  // The steady clock, microseconds (pacing, publish times).
  static int64_t steady_us() {
    return std::chrono::duration_cast<std::chrono::microseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }

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
    // The outbox holds only queued-stream messages (kQueuedStreamKey), the oldest queued at
    // outbox_since_us (steady_us()); empty or not, false once another kind is queued.
    bool outbox_streams_only = true;
    int64_t outbox_since_us = 0;
    // The key of the queued stream last queued, and when (steady_us()) one of another key was
    // last queued after one: the outbox waits (stream_coalesce_us) only while several streams
    // come (one talker's packets have nothing to join).
    uint64_t last_stream_key = 0;
    int64_t streams_mixed_us = INT64_MIN / 2;
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

  // --- Admitting viewers (server.cpp) ---

  // Runs on the door's thread for each authenticated viewer: applies the server's policy, then
  // gives the viewer a tier and a thread. Throws Error (the door sends it as a Reject).
  void admit(detail::Admitted& a);

  // Throws Error naming the offered tiers if the viewer's is not one of them.
  void check_offered(const protocol::Hello& hello) const;

  // --- Tiers (server_tiers.cpp) ---

  // The site's frame rate for tier costs; 30 before the first frame sets.
  double site_fps() const { return peak_fps > 0 ? peak_fps : 30; }

  // Called by publish() with mutex held: notes the time and updates peak_fps, the highest rate
  // (from the median gap between the last 33 publish() calls) seen in the last 30 s, so that a
  // publisher slowed for a while by a busy machine does not make the tiers look cheap.
  void note_published();

  // Whether the viewers of `address` are all that watch `tier` (no other address, no tap).
  bool held_alone_by(const Tier& tier, const std::string& address) const;

  // Throws Error if a new tier `key` costing `encode_ns` per frame set would take the tiers past
  // the CPU budget, or the tiers `address` holds alone past its share (the count, half the
  // budget). The costliest tiers are the first not to fit. Caller holds mutex.
  void check_tier_budget(const detail::TierKey& key, double encode_ns,
                         const std::string& address) const;

  // Joins the threads of viewers that have ended (keeping their reports) and of tiers nobody
  // watches any more. Caller holds mutex (a finished viewer thread no longer takes it; a tier
  // thread told to stop leaves without taking it).
  void reap_finished();

  // Joins the threads of stopped tiers. Caller must not hold mutex.
  void join_retired();

  // The tier's thread: encodes the newest frame set whenever there is one it has not encoded.
  void run_tier(std::shared_ptr<Tier> tier);

  // Finds or makes the tier and subscribes `wake` (if not null) to it. A new tier for a viewer
  // from `address` must fit the CPU budget (check_tier_budget); one for a tap (`address` null)
  // is made regardless. Caller holds mutex. Throws Error.
  std::shared_ptr<Tier> subscribe(const detail::TierKey& key, const WakeFd* wake,
                                  const std::string* address);

  // Unsubscribes `wake` from `tier` (takes mutex).
  void unsubscribe(Tier& tier, const WakeFd& wake);

  // --- Each viewer's thread (server_viewer.cpp) ---

  // Applies `f` to `v`'s report under mutex.
  void update(Viewer& v, const std::function<void(ViewerReport&)>& f);

  // The viewer's thread: sends Welcome, streams (stream()) until the viewer ends or the server
  // stops, then reports why and tells the session service it left.
  void serve_viewer(Viewer& v);

  // Queues a session message for `v` (mutex held), waking its thread when it must; false if `v`
  // is gone or being dropped.
  bool queue_session(Viewer& v, std::shared_ptr<const std::vector<uint8_t>> message,
                     uint64_t coalesce_key);

  // Writes the session messages queued for `v` (in order), small ones joined into one write in
  // `joined` (reused between calls); throws Error if it was kicked. `batch` is scratch. Queued
  // stream messages alone wait until the oldest is config.stream_coalesce_us old: returns when
  // (steady_us()) they are due then, else -1.
  int64_t flush_session(Viewer& v, std::vector<std::shared_ptr<const std::vector<uint8_t>>>& batch,
                        std::vector<uint8_t>& joined);

  // Reads one message from the viewer: an Ack, a KeyFrameRequest, or a session message (for the
  // session service, else skipped). Anything else ends the connection.
  void read_control(Viewer& v, Tier& tier, Pacer& pacer, std::vector<uint8_t>& payload);

  // Sends `tier`'s newest frame sets to `v` as its pacer allows (sealed when the tier sealed them
  // and the connection carries raw bytes), skipping stale ones and deltas it cannot decode, with
  // its session messages ahead of them; reads its Acks, key frame requests and session messages.
  // Throws Error when the viewer stalls, misbehaves or the connection fails.
  void stream(Viewer& v, Tier& tier);
};

}  // namespace volcast
