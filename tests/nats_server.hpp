#pragma once
// Debian's nats-server (installed by scripts/install-deps.sh), started and stopped by a test: one
// node on a free loopback port, with an optional configuration file.
#include <netinet/in.h>
#include <signal.h>
#include <spawn.h>
#include <sys/socket.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

extern char** environ;

namespace volcast::test {

/// A loopback TCP port nobody listens on now.
inline int free_tcp_port() {
  const int fd = socket(AF_INET, SOCK_STREAM, 0);
  sockaddr_in a{};
  a.sin_family = AF_INET;
  a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
  socklen_t n = sizeof a;
  bind(fd, reinterpret_cast<sockaddr*>(&a), sizeof a);
  getsockname(fd, reinterpret_cast<sockaddr*>(&a), &n);
  close(fd);
  return ntohs(a.sin_port);
}

class NatsServer {
 public:
  /// Starts nats-server on 127.0.0.1 and `port` (0: a free one); `config` (nats-server's
  /// configuration format) is written to DIR/nats.conf and given with -c. Waits until it accepts
  /// connections.
  explicit NatsServer(const std::filesystem::path& dir, const std::string& config = "",
                      int port = 0)
      : port_(port ? port : free_tcp_port()) {
    std::vector<std::string> args = {"nats-server",
                                     "-a",
                                     "127.0.0.1",
                                     "-p",
                                     std::to_string(port_),
                                     "-l",
                                     (dir / "nats.log").string()};
    if (!config.empty()) {
      std::ofstream(dir / "nats.conf") << config;
      args.push_back("-c");
      args.push_back((dir / "nats.conf").string());
    }
    std::vector<char*> argv;
    for (auto& s : args) argv.push_back(s.data());
    argv.push_back(nullptr);
    const char* binary = std::filesystem::exists("/usr/sbin/nats-server") ? "/usr/sbin/nats-server"
                                                                          : "/usr/bin/nats-server";
    if (posix_spawn(&pid_, binary, nullptr, nullptr, argv.data(), environ) != 0)
      throw std::runtime_error("cannot start nats-server (scripts/install-deps.sh installs it)");
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
    while (!accepting()) {
      if (std::chrono::steady_clock::now() > deadline)
        throw std::runtime_error("nats-server did not start; see " + (dir / "nats.log").string());
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
    }
  }
  ~NatsServer() {
    kill(pid_, SIGTERM);
    int status = 0;
    waitpid(pid_, &status, 0);
  }
  NatsServer(const NatsServer&) = delete;
  NatsServer& operator=(const NatsServer&) = delete;

  std::string url() const { return "nats://127.0.0.1:" + std::to_string(port_); }
  int port() const { return port_; }

 private:
  bool accepting() const {
    const int fd = socket(AF_INET, SOCK_STREAM, 0);
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    a.sin_port = htons(static_cast<uint16_t>(port_));
    const bool ok = connect(fd, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
    close(fd);
    return ok;
  }
  int port_;
  pid_t pid_ = 0;
};

}  // namespace volcast::test
