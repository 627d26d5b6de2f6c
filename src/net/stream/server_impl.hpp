#pragma once
// Internal to volcast_net_stream: the Server's state and its steps, shared by its three files --
// server.cpp (the public API, and admitting the viewers the door hands on), server_tiers.cpp
// (tiers: their encoding threads, the CPU budget, subscriptions) and server_viewer.cpp (each
// viewer's thread: Welcome, frame sets paced by its Acks, session messages).
#include <sys/epoll.h>
#include <sys/eventfd.h>
#include <sys/timerfd.h>
#include <unistd.h>

#include <array>
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <list>
#include <map>
#include <mutex>
#include <optional>
#include <thread>

#include "tier_encoder.hpp"
#include "volcast/core/worker_pool.hpp"
#include "volcast/net/stream/pacing.hpp"
#include "volcast/net/stream/server.hpp"
#include "volcast/net/transport/connection.hpp"
#include "volcast/net/transport/door.hpp"

namespace volcast {

struct Server::Impl {
  // Wakes one viewer's thread, which polls `fd` (an epoll set of the two below): signal() at
  // once (its tier has a new frame set, a session message is to be sent; an eventfd), at() when
  // its held voice packets fall due (a timerfd: no wake-up before then). Each fd is created
  // here; a failure leaves it -1, and poll(2) then reports the set as never ready.
  struct WakeFd {
    int event = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
    int timer = ::timerfd_create(CLOCK_MONOTONIC, TFD_NONBLOCK | TFD_CLOEXEC);
    int fd = watch(event, timer);
    WakeFd() = default;
    WakeFd(const WakeFd&) = delete;
    WakeFd& operator=(const WakeFd&) = delete;
    ~WakeFd() {
      ::close(fd);
      ::close(timer);
      ::close(event);
    }
    void signal() const {
      const uint64_t one = 1;
      [[maybe_unused]] const auto n = ::write(event, &one, sizeof one);
    }
    // Wakes the thread once steady_us() reaches `due_us` (steady_clock is CLOCK_MONOTONIC);
    // -1 disarms it.
    void at(int64_t due_us) const {
      itimerspec t{};
      if (due_us >= 0) {
        t.it_value.tv_sec = due_us / 1'000'000;
        t.it_value.tv_nsec = due_us % 1'000'000 * 1000 + 1;  // never all zero (that disarms)
      }
      ::timerfd_settime(timer, TFD_TIMER_ABSTIME, &t, nullptr);
    }
    void drain() const {
      uint64_t v;
      [[maybe_unused]] const auto a = ::read(event, &v, sizeof v);
      [[maybe_unused]] const auto b = ::read(timer, &v, sizeof v);
    }
    static int watch(int event, int timer) {
      const int set = ::epoll_create1(EPOLL_CLOEXEC);
      for (const int f : {event, timer}) {
        epoll_event e{};
        e.events = EPOLLIN;
        e.data.fd = f;
        ::epoll_ctl(set, EPOLL_CTL_ADD, f, &e);
      }
      return set;
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
    Tier(volcast::Tier key, size_t cameras) : encoder(std::move(key), cameras) {}
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
    double encode_ns = 0;  // estimated CPU per site frame set (detail::tier_encode_ns / divisor)
    // Body bytes of the frame sets encoded in the last second, with their steady times: the
    // tier's rate for the viewers' rate control.
    std::deque<std::pair<int64_t, size_t>> produced;
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
    bool outbox_woken = false;  // the thread was signalled for what the outbox holds
    // The queued streams (voice: one a talker) lately queued for this viewer, and when
    // (steady_us()) each last was; bit i of outbox_stream_mask: recent_streams[i] has a message in
    // the outbox. Held voice packets go out once every stream heard in the last kActiveStreamUs has
    // one there (streams_complete), or stream_coalesce_us after the oldest (the timer, armed for
    // timer_due_us; -1: not armed).
    struct RecentStream {
      uint64_t key = 0;
      int64_t last_us = INT64_MIN / 2;
    };
    std::array<RecentStream, 8> recent_streams{};
    uint32_t outbox_stream_mask = 0;
    int64_t timer_due_us = -1;
    std::string kicked;          // set: disconnect with this reason
    std::shared_ptr<Tier> tier;  // changed by its own thread only (under mutex)
    // Rate adaptation (server.hpp): the Hello's flags and cap, the best rung it may get, rungs
    // refused by the CPU budget until a steady time, and the tier its Hello named.
    uint8_t adapt = 0;
    uint64_t max_bits_per_s = 0;
    std::vector<std::string> decodes;  // Hello::decodes: empty, any
    size_t top = 0;
    std::vector<int64_t> refused_until;
    volcast::Tier hello_key;
    std::string address;  // the peer's IP address (per-address tier limits)
    std::thread thread;
    WakeFd wake;
    ViewerReport report;
    std::atomic<bool> done{false};
  };
  std::list<Viewer> viewers;
  std::vector<volcast::Tier> ladder;            // config.ladder parsed
  std::optional<volcast::Tier> passed_through;  // config.passed_through_tier parsed: free
  std::vector<double> ladder_sizes;             // its rungs' relative sizes, or empty
  // Each tier's last measured rate (bits/s) by name, kept after it stops: a rung not running now
  // is judged by what it produced last.
  std::map<std::string, double> learned_bits;
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

  // The site's frame rate for tier costs; 30 before its first second of frame sets.
  double site_fps() const { return peak_fps > 0 ? peak_fps : 30; }

  // Called by publish() with mutex held: notes the time and updates peak_fps, the highest rate
  // (the mean over the last 33 publish() calls) seen in the last 30 s, so that a publisher slowed
  // for a while by a busy machine does not make the tiers look cheap.
  void note_published();

  // Whether the viewers of `address` are all that watch `tier` (no other address, no tap).
  bool held_alone_by(const Tier& tier, const std::string& address) const;

  // Throws Error if a new tier `key` costing `encode_ns` per frame set would take the tiers past
  // the CPU budget, or the tiers `address` holds alone past its share (the count, half the
  // budget). The costliest tiers are the first not to fit. Caller holds mutex.
  // `share` false: the total alone (a ladder rung: the operator's own list, one tier a viewer).
  void check_tier_budget(const volcast::Tier& key, double encode_ns, const std::string& address,
                         bool share = true) const;

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
  std::shared_ptr<Tier> subscribe(const volcast::Tier& key, const WakeFd* wake,
                                  const std::string* address, bool share = true);

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
  // A queued stream is active while its messages come less than this far apart (µs): a talker
  // sends one every 20 ms.
  static constexpr int64_t kActiveStreamUs = 30'000;
  // Notes that a message of stream `key` was queued for `v` at `now` (mutex held).
  static void note_stream(Viewer& v, uint64_t key, int64_t now);
  // Whether every stream active at `now` has a message in v's outbox (mutex held): then held
  // voice packets have nothing more to wait for.
  static bool streams_complete(const Viewer& v, int64_t now);

  // Writes the session messages queued for `v` (in order), small ones joined into one write in
  // `joined` (reused between calls); throws Error if it was kicked. `batch` is scratch. Queued
  // stream messages alone wait until each active stream has one queued (streams_complete) or the
  // oldest is config.stream_coalesce_us old: returns when (steady_us()) they are due then, else
  // -1.
  int64_t flush_session(Viewer& v, std::vector<std::shared_ptr<const std::vector<uint8_t>>>& batch,
                        std::vector<uint8_t>& joined);

  // Reads one message from the viewer: an Ack, a KeyFrameRequest, or a session message (for the
  // session service, else skipped). Anything else ends the connection.
  // Each Ack also goes to `rc` (the viewer's rate control).
  void read_control(Viewer& v, Pacer& pacer, RateController& rc, std::vector<uint8_t>& payload);

  // --- Rate adaptation (server_adapt.cpp) ---

  // Whether `v` adapts along the ladder (Hello kAdapt, a ladder).
  bool adaptive(const Viewer& v) const {
    return (v.adapt & protocol::Hello::kAdapt) && !ladder.empty();
  }
  // The rate (bits/s) of `key`'s tier: measured while it runs, else learned, else 0. Mutex held.
  double tier_bits(const volcast::Tier& key) const;
  // Per rung into `ok` (capacity reused), whether `v` may be put on it now (floors, its cap if
  // `cap`, its best rung, budget refusals). Mutex held.
  void allowed_rungs(const Viewer& v, int64_t now, std::vector<char>& ok, bool cap = true) const;
  // The rung of `v`'s tier, or -1.
  int rung_of(const Viewer& v) const;
  // Puts `v` on its first rung at admission (the best allowed that the budget takes). Mutex held;
  // throws the budget's Error when none does.
  std::shared_ptr<Tier> subscribe_adaptive(Viewer& v);
  // Moves `v` to rung `rung` (or, for a notice, keeps it) and tells it with a TierChange. False
  // if the budget refused that rung's tier (then left out for 10 s).
  bool switch_tier(Viewer& v, const RateDecision& d, double goodput_bits);
  // Writes a TierChange for `v`'s tier now with `reason`.
  void send_tier_change(Viewer& v, const std::string& reason, double goodput_bits);

  // Sends `tier`'s newest frame sets to `v` as its pacer allows (sealed when the tier sealed them
  // and the connection carries raw bytes), skipping stale ones and deltas it cannot decode, with
  // its session messages ahead of them; reads its Acks, key frame requests and session messages.
  // Throws Error when the viewer stalls, misbehaves or the connection fails.
  void stream(Viewer& v);
};

}  // namespace volcast
