#pragma once
// Internal to volcast_net_stream: a viewer as a consumer of a selective forwarding unit -- its
// connection, the tier it takes, its session messages waiting and its own thread
// (server_viewer.cpp runs it; server_adapt.cpp moves it along the ladder).
#include <atomic>
#include <memory>
#include <string>
#include <thread>

#include "ladder.hpp"
#include "session_outbox.hpp"
#include "tier_producer.hpp"
#include "volcast/net/stream/server.hpp"
#include "volcast/net/transport/connection.hpp"
#include "wake_fd.hpp"

namespace volcast::detail {

struct ViewerConsumer {
  uint64_t id = 0;
  std::string address;  // the peer's IP address (per-address tier limits)
  std::unique_ptr<Connection> connection;
  ViewerFloor floor;  // what its Hello asked for (fixed once admitted, but for refusals)
  std::thread thread;
  WakeFd wake;
  std::atomic<bool> done{false};
  // Guarded by the server's mutex:
  std::shared_ptr<TierProducer> tier;  // changed by its own thread only
  SessionOutbox outbox;
  std::string kicked;  // set: disconnect with this reason
  ViewerReport report;
};

}  // namespace volcast::detail
