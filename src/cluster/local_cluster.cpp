#include "volcast/cluster/local_cluster.hpp"

#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <atomic>
#include <chrono>
#include <fstream>
#include <thread>

#include "volcast/cluster/nats.hpp"
#include "volcast/core/error.hpp"

extern char** environ;

namespace volcast::cluster {
namespace {

using Clock = std::chrono::steady_clock;

sockaddr_in loopback(int port) {
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  a.sin_port = htons(static_cast<uint16_t>(port));
  return a;
}

// A loopback TCP port nobody listens on now.
int free_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a = loopback(0);
  socklen_t n = sizeof a;
  if (fd < 0 || bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) != 0 ||
      getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n) != 0) {
    if (fd >= 0) close(fd);
    throw Error("NATS cluster: no free loopback port");
  }
  close(fd);
  return ntohs(a.sin_port);
}

bool accepting(int port) {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  const sockaddr_in a = loopback(port);
  const bool ok = connect(fd, reinterpret_cast<const sockaddr*>(&a), sizeof a) == 0;
  close(fd);
  return ok;
}

std::string nats_server_binary() {
  for (const char* p : {"/usr/sbin/nats-server", "/usr/bin/nats-server"})
    if (std::filesystem::exists(p)) return p;
  throw Error(
      "NATS cluster: nats-server is not installed (scripts/install-deps.sh installs Debian's "
      "nats-server)");
}

}  // namespace

LocalNatsCluster::LocalNatsCluster(const std::filesystem::path& dir, int nodes,
                                   const std::string& extra_config, const NatsOptions& client) {
  if (nodes < 1 || nodes > 9) throw Error("NATS cluster: 1..9 nodes");
  std::filesystem::create_directories(dir);
  nodes_.resize(static_cast<size_t>(nodes));
  for (auto& n : nodes_) n.client_port = free_port(), n.route_port = free_port();
  for (size_t i = 0; i < nodes_.size(); ++i) {
    Node& n = nodes_[i];
    n.config = dir / ("node-" + std::to_string(i) + ".conf");
    n.log = dir / ("node-" + std::to_string(i) + ".log");
    std::ofstream c(n.config);
    c << "server_name: volcast-" << i << "\nlisten: 127.0.0.1:" << n.client_port << "\n"
      << extra_config << "\n";
    if (nodes > 1) {
      c << "cluster {\n  name: volcast\n  listen: 127.0.0.1:" << n.route_port << "\n  routes: [\n";
      for (size_t j = 0; j < nodes_.size(); ++j)
        if (j != i) c << "    nats-route://127.0.0.1:" << nodes_[j].route_port << "\n";
      c << "  ]\n}\n";
    }
    if (!c) throw Error("NATS cluster: cannot write " + n.config.string());
  }
  try {
    for (auto& n : nodes_) start(n);
    if (nodes > 1) {  // routed: the first node's message reaches the last node's subscriber
      NatsOptions first = client, last = client;
      first.urls = {url(0)};
      last.urls = {url(nodes - 1)};
      NatsConnection a(first), b(last);
      std::atomic<bool> arrived{false};
      auto sub =
          b.subscribe("_volcast.cluster.ready", [&](const std::string&, auto) { arrived = true; });
      const auto deadline = Clock::now() + std::chrono::seconds(20);
      while (!arrived) {
        if (Clock::now() > deadline)
          throw Error("NATS cluster: the nodes did not form a cluster within 20 s; see " +
                      nodes_[0].log.string());
        a.publish("_volcast.cluster.ready", {});
        a.flush();
        std::this_thread::sleep_for(std::chrono::milliseconds(50));
      }
    }
  } catch (...) {
    for (int i = 0; i < nodes; ++i) kill(i);
    throw;
  }
}

LocalNatsCluster::~LocalNatsCluster() {
  for (auto& n : nodes_)
    if (n.pid > 0) {
      ::kill(n.pid, SIGTERM);
      int status = 0;
      waitpid(n.pid, &status, 0);
      n.pid = 0;
    }
}

void LocalNatsCluster::start(Node& n) {
  std::vector<std::string> args = {"nats-server", "-c", n.config.string(), "-l", n.log.string()};
  std::vector<char*> argv;
  for (auto& s : args) argv.push_back(s.data());
  argv.push_back(nullptr);
  const std::string binary = nats_server_binary();
  if (posix_spawn(&n.pid, binary.c_str(), nullptr, nullptr, argv.data(), environ) != 0)
    throw Error("NATS cluster: cannot start " + binary);
  const auto deadline = Clock::now() + std::chrono::seconds(20);
  while (!accepting(n.client_port)) {
    int status = 0;
    if (waitpid(n.pid, &status, WNOHANG) == n.pid) {
      n.pid = 0;
      throw Error("NATS cluster: nats-server exited at start; see " + n.log.string());
    }
    if (Clock::now() > deadline)
      throw Error("NATS cluster: nats-server did not accept clients within 20 s; see " +
                  n.log.string());
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
}

std::string LocalNatsCluster::url(int i) const {
  return "nats://127.0.0.1:" + std::to_string(nodes_.at(static_cast<size_t>(i)).client_port);
}

std::vector<std::string> LocalNatsCluster::urls(int first) const {
  std::vector<std::string> out;
  for (int k = 0; k < nodes(); ++k) out.push_back(url((first + k) % nodes()));
  return out;
}

void LocalNatsCluster::kill(int i) {
  Node& n = nodes_.at(static_cast<size_t>(i));
  if (n.pid <= 0) return;
  ::kill(n.pid, SIGKILL);
  int status = 0;
  waitpid(n.pid, &status, 0);
  n.pid = 0;
}

void LocalNatsCluster::restart(int i) {
  Node& n = nodes_.at(static_cast<size_t>(i));
  if (n.pid > 0) return;
  start(n);
}

}  // namespace volcast::cluster
