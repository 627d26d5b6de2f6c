#pragma once
// A NATS cluster of Debian's nats-server processes on loopback ports, started and stopped by
// volcast itself: for `volcast bench --nats` and the tests (issue 17). Each node listens for
// clients on 127.0.0.1 and routes to every other node (a full mesh, nats-server's cluster block).
#include <sys/types.h>

#include <filesystem>
#include <string>
#include <vector>

#include "volcast/cluster/nats.hpp"

namespace volcast::cluster {

class LocalNatsCluster {
 public:
  /// Starts `nodes` nats-server processes (1..9), their configuration and logs in `dir`
  /// (node-N.conf, node-N.log); `extra_config` (nats-server's format, e.g. "max_payload:
  /// 65536"; a tls block) goes into each node's configuration. Waits until every node accepts
  /// clients and a message published on the first node reaches a subscriber on the last, both
  /// connected with `client`'s settings but its URLs (e.g. its TLS files). Throws Error if
  /// nats-server is not installed (scripts/install-deps.sh) or a node does not come up within
  /// 20 s (naming its log).
  LocalNatsCluster(const std::filesystem::path& dir, int nodes,
                   const std::string& extra_config = "", const NatsOptions& client = {});
  ~LocalNatsCluster();  ///< stops every node (SIGTERM, then waits)
  LocalNatsCluster(const LocalNatsCluster&) = delete;
  LocalNatsCluster& operator=(const LocalNatsCluster&) = delete;

  int nodes() const { return static_cast<int>(nodes_.size()); }
  /// Node `i`'s client URL, nats://127.0.0.1:PORT.
  std::string url(int i) const;
  /// Every node's URL, starting with node `first` (for NatsOptions::urls with in_order).
  std::vector<std::string> urls(int first = 0) const;
  /// Kills node `i` (SIGKILL: no goodbye to its clients) and waits for it to exit.
  void kill(int i);
  /// Starts node `i` again on its ports (after kill) and waits until it accepts clients.
  void restart(int i);

 private:
  struct Node {
    int client_port = 0, route_port = 0;
    pid_t pid = 0;
    std::filesystem::path config, log;
  };
  void start(Node& n);
  std::vector<Node> nodes_;
};

}  // namespace volcast::cluster
