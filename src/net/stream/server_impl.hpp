#pragma once
// Internal to volcast_net_stream: the Server as the router of one site's selective forwarding unit.
// Its parts, each a plain type in its own header: the producers (tier_producer.hpp: one encoding
// per tier), the consumers (viewer_consumer.hpp: one thread per viewer, its session outbox in
// session_outbox.hpp), the door (net/transport's run_door, and admit() here), the rate
// controller (rate_control.hpp, one per viewer) over the ladder (ladder.hpp), and the tiers' CPU
// budget (tier_budget.hpp). Its steps are in server.cpp (the public API, admitting the viewers the
// door hands on), server_tiers.cpp (running the producers, subscriptions), server_viewer.cpp (each
// viewer's thread: Welcome, frame sets paced by its Acks, session messages) and server_adapt.cpp
// (moving adaptive viewers along the ladder).
#include <atomic>
#include <chrono>
#include <condition_variable>
#include <deque>
#include <functional>
#include <list>
#include <memory>
#include <mutex>
#include <thread>

#include "ladder.hpp"
#include "tier_budget.hpp"
#include "tier_producer.hpp"
#include "viewer_consumer.hpp"
#include "volcast/core/worker_pool.hpp"
#include "volcast/net/stream/pacing.hpp"
#include "volcast/net/stream/rate_control.hpp"
#include "volcast/net/stream/server.hpp"
#include "volcast/net/transport/connection.hpp"
#include "volcast/net/transport/door.hpp"

namespace volcast {

struct Server::Impl {
  using Producer = detail::TierProducer;
  using Viewer = detail::ViewerConsumer;

  // The steady clock, microseconds (pacing, publish times).
  static int64_t steady_us() {
    return std::chrono::duration_cast<std::chrono::microseconds>(
               std::chrono::steady_clock::now().time_since_epoch())
        .count();
  }

  ServerConfig config;
  std::vector<protocol::CameraInfo> cameras;
  std::vector<detail::TierOffer> offers;  // config.offered_tiers parsed
  std::unique_ptr<TcpListener> listener;
  std::unique_ptr<WorkerPool> pool;
  detail::DoorConfig door;
  detail::DoorCounters door_counters;
  std::function<void(detail::Admitted&)> admit_fn;
  std::thread door_thread;
  std::atomic<bool> stopping{false};

  mutable std::mutex mutex;  // guards everything below and the parts' shared fields
  std::condition_variable captured_changed;
  std::shared_ptr<const CapturedFrameSet> captured;  // the newest published frame set
  detail::TierBudget budget;
  detail::Ladder ladder;
  std::list<std::shared_ptr<Producer>> tiers;
  std::vector<std::thread> retired;  // threads of tiers told to stop, to be joined without mutex
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

  // Whether the viewers of `address` are all that watch `tier` (no other address, no tap).
  bool held_alone_by(const Producer& tier, const std::string& address) const;

  // Throws Error if a new tier `key` costing `encode_ns` per frame set would take the tiers past
  // the CPU budget, or the tiers `address` holds alone past its share (the count, half the
  // budget). The costliest tiers are the first not to fit. Caller holds mutex.
  // `share` false: the total alone (a ladder rung: the operator's own list, one tier a viewer).
  void check_tier_budget(const Tier& key, double encode_ns, const std::string& address,
                         bool share = true) const;

  // Joins the threads of viewers that have ended (keeping their reports) and of tiers nobody
  // watches any more. Caller holds mutex (a finished viewer thread no longer takes it; a tier
  // thread told to stop leaves without taking it).
  void reap_finished();

  // Joins the threads of stopped tiers. Caller must not hold mutex.
  void join_retired();

  // The tier's thread: encodes the newest frame set whenever there is one it has not encoded.
  void run_tier(std::shared_ptr<Producer> tier);

  // Finds or makes the tier and subscribes `wake` (if not null) to it. A new tier for a viewer
  // from `address` must fit the CPU budget (check_tier_budget); one for a tap (`address` null)
  // is made regardless. Caller holds mutex. Throws Error.
  std::shared_ptr<Producer> subscribe(const Tier& key, const detail::WakeFd* wake,
                                      const std::string* address, bool share = true);

  // Unsubscribes `wake` from `tier` (takes mutex).
  void unsubscribe(Producer& tier, const detail::WakeFd& wake);

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
  // stream messages alone wait until each active stream has one queued or the oldest is
  // config.stream_coalesce_us old (session_outbox.hpp): returns when (steady_us()) they are due
  // then, else -1.
  int64_t flush_session(Viewer& v, std::vector<std::shared_ptr<const std::vector<uint8_t>>>& batch,
                        std::vector<uint8_t>& joined);

  // Reads one message from the viewer: an Ack, a KeyFrameRequest, or a session message (for the
  // session service, else skipped). Anything else ends the connection.
  // Each Ack also goes to `rc` (the viewer's rate control).
  void read_control(Viewer& v, Pacer& pacer, RateController& rc, std::vector<uint8_t>& payload);

  // Sends `tier`'s newest frame sets to `v` as its pacer allows (sealed when the tier sealed them
  // and the connection carries raw bytes), skipping stale ones and deltas it cannot decode, with
  // its session messages ahead of them; reads its Acks, key frame requests and session messages.
  // Throws Error when the viewer stalls, misbehaves or the connection fails.
  void stream(Viewer& v);

  // --- Rate adaptation (server_adapt.cpp) ---

  // Whether `v` adapts along the ladder (Hello kAdapt, a ladder).
  bool adaptive(const Viewer& v) const {
    return (v.floor.adapt & protocol::Hello::kAdapt) && !ladder.rungs.empty();
  }
  // The rate (bits/s) of `key`'s tier: measured while it runs, else learned, else 0. Mutex held.
  double tier_bits(const Tier& key) const;
  // Each rung's tier_bits into `bits` (capacity reused). Mutex held.
  void ladder_bits(std::vector<double>& bits) const;
  // The rung of `v`'s tier, or -1.
  int rung_of(const Viewer& v) const;
  // Puts `v` on its first rung at admission (the best allowed that the budget takes). Mutex held;
  // throws the budget's Error when none does.
  std::shared_ptr<Producer> subscribe_adaptive(Viewer& v);
  // Moves `v` to rung `rung` (or, for a notice, keeps it) and tells it with a TierChange. False
  // if the budget refused that rung's tier (then left out for 10 s).
  bool switch_tier(Viewer& v, const RateDecision& d, double goodput_bits);
  // Writes a TierChange for `v`'s tier now with `reason`.
  void send_tier_change(Viewer& v, const std::string& reason, double goodput_bits);
};

}  // namespace volcast
