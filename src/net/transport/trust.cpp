#include "volcast/net/transport/trust.hpp"

#include <fcntl.h>
#include <sys/file.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <fstream>
#include <sstream>
#include <vector>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

struct Pin {
  std::string server, fingerprint;
  int line = 0;
};

std::vector<Pin> read_pins(const std::filesystem::path& file) {
  std::vector<Pin> pins;
  std::ifstream in(file);
  std::string text;
  for (int line = 1; std::getline(in, text); ++line) {
    if (text.empty() || text[0] == '#') continue;
    std::istringstream fields(text);
    Pin p;
    p.line = line;
    if (fields >> p.server >> p.fingerprint) pins.push_back(std::move(p));
  }
  return pins;
}

void write_pins(const std::filesystem::path& file, const std::vector<Pin>& pins) {
  std::error_code ec;
  std::filesystem::create_directories(file.parent_path(), ec);
  if (ec) throw Error("cannot create '" + file.parent_path().string() + "': " + ec.message());
  // A temporary file of this process's own: two viewers of one user may store at the same moment.
  const auto temp = std::filesystem::path(file.string() + ".tmp." + std::to_string(::getpid()));
  {
    std::ofstream out(temp, std::ios::trunc);
    out << "# Volcast servers this user trusts: HOST:PORT SHA-256 of the server's certificate\n";
    for (const auto& p : pins) out << p.server << ' ' << p.fingerprint << '\n';
    if (!out.flush()) throw Error("cannot write '" + temp.string() + "'");
  }
  ::chmod(temp.c_str(), 0600);
  std::filesystem::rename(temp, file, ec);
  if (ec) throw Error("cannot write '" + file.string() + "': " + ec.message());
}

// Holds an exclusive flock(2) on `file`.lock while alive, so that the read-modify-write of the
// pins by viewers started at once (one user, several viewers) loses no pin. Throws Error naming
// the lock file if it cannot be created.
class PinLock {
 public:
  explicit PinLock(const std::filesystem::path& file) {
    std::error_code ec;
    std::filesystem::create_directories(file.parent_path(), ec);
    if (ec) throw Error("cannot create '" + file.parent_path().string() + "': " + ec.message());
    const auto path = file.string() + ".lock";
    fd_ = ::open(path.c_str(), O_RDWR | O_CREAT | O_CLOEXEC, 0600);
    if (fd_ < 0) throw Error("cannot open '" + path + "'");
    while (::flock(fd_, LOCK_EX) != 0)
      if (errno != EINTR) break;  // no locking on this file system: go on unlocked
  }
  ~PinLock() { ::close(fd_); }
  PinLock(const PinLock&) = delete;
  PinLock& operator=(const PinLock&) = delete;

 private:
  int fd_ = -1;
};

void store(const std::filesystem::path& file, const std::string& server, const std::string& fp) {
  if (file.empty()) return;
  const PinLock lock(file);
  std::vector<Pin> pins;
  for (auto& p : read_pins(file))
    if (p.server != server) pins.push_back(std::move(p));
  pins.push_back({server, fp, 0});
  write_pins(file, pins);
}

}  // namespace

TrustDecision check_server_fingerprint(const std::filesystem::path& known_servers,
                                       const std::string& host_port, const std::string& actual,
                                       const std::string& expected) {
  if (!expected.empty()) {
    if (expected != actual)
      throw Error("server " + host_port + " presented a certificate with SHA-256 fingerprint " +
                  actual + ", but the join link says " + expected +
                  ": check that the link is the one the server printed at start; if it is, "
                  "someone may be intercepting the connection");
    store(known_servers, host_port, actual);
    return TrustDecision::kFromLink;
  }
  if (known_servers.empty())
    throw Error("no certificate fingerprint to check server " + host_port +
                " against: join with the server's link");
  for (const auto& p : read_pins(known_servers)) {
    if (p.server != host_port) continue;
    if (p.fingerprint == actual) return TrustDecision::kPinned;
    throw Error("server " + host_port + " presented a certificate with SHA-256 fingerprint " +
                actual + ", not the one pinned on first use (" + p.fingerprint + ", " +
                known_servers.string() + " line " + std::to_string(p.line) +
                "): compare with the fingerprint the server printed at start; if its certificate "
                "was replaced on purpose, delete that line or join with the server's new link; "
                "otherwise someone may be intercepting the connection");
  }
  store(known_servers, host_port, actual);
  return TrustDecision::kFirstUse;
}

}  // namespace volcast
