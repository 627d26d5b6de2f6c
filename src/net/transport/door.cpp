#include "volcast/net/transport/door.hpp"

#include <poll.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <list>
#include <mutex>
#include <thread>
#include <unordered_map>
#include <vector>

#include "volcast/core/error.hpp"
#include "volcast/net/transport/websocket.hpp"

namespace volcast::detail {
namespace {

using Clock = std::chrono::steady_clock;

// One handshake in progress: TLS (if any), then the 12-byte header and the Hello payload.
struct Pending {
  std::unique_ptr<Connection> connection;
  std::string address;
  Clock::time_point deadline;
  short events = POLLIN;       // what the next step waits for
  std::vector<uint8_t> bytes;  // header, then header + payload
  size_t have = 0;
  bool tls_done = false;
  WebSocketConnection* web = nullptr;  // `connection`, once it spoke HTTP instead of a Hello
  bool web_open = false;               // its WebSocket is open: the Hello comes through it
};

// Writes answered HTTP requests (page assets) on their own threads, so that a peer that reads
// slowly never holds the door; at most kMax at once (more are closed: the browser retries). The
// door's end shuts down and joins the rest.
class Responders {
 public:
  ~Responders() {
    std::vector<std::shared_ptr<Job>> jobs;
    {
      std::lock_guard lock(mutex_);
      jobs.swap(jobs_);
    }
    for (auto& j : jobs) j->connection->shutdown();
    for (auto& j : jobs) j->thread.join();
  }

  void start(std::unique_ptr<Connection> c, std::string bytes) {
    std::lock_guard lock(mutex_);
    std::erase_if(jobs_, [](const std::shared_ptr<Job>& j) {
      if (!j->done) return false;
      j->thread.join();
      return true;
    });
    if (jobs_.size() >= kMax) return;
    auto job = std::make_shared<Job>();
    job->connection = std::move(c);
    job->thread = std::thread([j = job.get(), bytes = std::move(bytes)] {
      try {
        j->connection->write_all(
            std::span(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()), 5000);
      } catch (const Error&) {
      }
      j->connection->shutdown();  // the answer is complete: the peer sees the end now
      j->done = true;
    });
    jobs_.push_back(std::move(job));
  }

 private:
  static constexpr size_t kMax = 16;
  struct Job {
    std::unique_ptr<Connection> connection;
    std::thread thread;
    std::atomic<bool> done{false};
  };
  std::mutex mutex_;
  std::vector<std::shared_ptr<Job>> jobs_;
};

// Wrong-token history of one address.
struct Offences {
  int wrong_tokens = 0;
  Clock::time_point blocked_until{};
  Clock::time_point last{};
};

// Logs the first failure, then at most one line per interval with how many were not logged.
class FailureLog {
 public:
  void add(const std::string& peer, const std::string& why) {
    const auto now = Clock::now();
    if (now - last_ < std::chrono::seconds(10)) {
      ++suppressed_;
      return;
    }
    if (suppressed_ > 0)
      spdlog::warn("handshake from {} failed: {} ({} more failed handshakes not logged since)",
                   peer, why, suppressed_);
    else
      spdlog::warn("handshake from {} failed: {}", peer, why);
    suppressed_ = 0;
    last_ = now;
  }
  void flush() {
    if (suppressed_ > 0) spdlog::warn("{} more failed handshakes not logged", suppressed_);
    suppressed_ = 0;
  }

 private:
  Clock::time_point last_ = Clock::now() - std::chrono::hours(1);
  uint64_t suppressed_ = 0;
};

int ms_until(Clock::time_point t) {
  const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(t - Clock::now());
  return static_cast<int>(std::clamp<int64_t>(left.count(), 0, 100));
}

class Door {
 public:
  Door(TcpListener& listener, const DoorConfig& config, const std::function<void(Admitted&)>& admit,
       DoorCounters& counters)
      : listener_(listener), config_(config), admit_(admit), counters_(counters) {}

  void run(const std::atomic<bool>& stopping) {
    std::vector<pollfd> fds;
    std::vector<std::list<Pending>::iterator> owners;
    while (!stopping) {
      fds.assign(1, pollfd{listener_.fd(), POLLIN, 0});
      owners.clear();
      auto next_deadline = Clock::now() + std::chrono::milliseconds(100);
      for (auto it = pending_.begin(); it != pending_.end(); ++it) {
        fds.push_back({it->connection->fd(), it->events, 0});
        owners.push_back(it);
        next_deadline = std::min(next_deadline, it->deadline);
      }
      if (::poll(fds.data(), fds.size(), ms_until(next_deadline)) < 0 && errno != EINTR) break;
      for (size_t i = 1; i < fds.size(); ++i)
        if (fds[i].revents != 0) step(owners[i - 1]);
      if (fds[0].revents != 0) accept_all();
      expire();
    }
    log_.flush();
  }

 private:
  void accept_all() {
    for (int k = 0; k < 64; ++k) {  // a bounded batch; the rest next round
      AcceptedSocket s = listener_.accept_nonblocking();
      if (s.fd < 0) return;
      if (count_from(s.address) >= config_.max_pending_per_address) {
        ::close(s.fd);
        ++counters_.over_limit;
        log_.add(s.peer, "too many pending handshakes from this address");
        continue;
      }
      if (static_cast<int>(pending_.size()) >= config_.max_pending) {
        // Drop the oldest: a real viewer finishes its handshake in a round trip or two.
        ++counters_.over_limit;
        log_.add(pending_.front().connection->peer(),
                 "dropped for a newer handshake (server busy)");
        pending_.pop_front();
      }
      Pending p;
      try {
        p.connection =
            config_.tls ? accept_tls(s.fd, s.peer, config_.tls) : make_tcp_connection(s.fd, s.peer);
      } catch (const Error& e) {
        ++counters_.failed;
        log_.add(s.peer, e.what());
        continue;
      }
      p.address = s.address;
      p.deadline = Clock::now() + std::chrono::milliseconds(config_.handshake_timeout_ms);
      p.tls_done = !config_.tls;
      p.bytes.resize(protocol::kHeaderBytes);
      pending_.push_back(std::move(p));
      step(std::prev(pending_.end()));  // the peer may have spoken already
    }
  }

  int count_from(const std::string& address) const {
    int n = 0;
    for (const auto& p : pending_) n += p.address == address;
    return n;
  }

  // Advances one handshake as far as it can go without blocking.
  void step(std::list<Pending>::iterator it) {
    Pending& p = *it;
    try {
      if (!p.tls_done) {
        const int want = p.connection->handshake_step();
        if (want != 0) {
          p.events = static_cast<short>(want);
          return;
        }
        p.tls_done = true;
        p.events = POLLIN;
      }
      if (p.web && !p.web_open) {
        if (p.web->handshake_step() != 0) return;
        if (p.web->http() == WebSocketConnection::Http::kAnswered) {
          ++counters_.web_files;
          std::string response = p.web->take_response();
          responders_.start(p.web->release_inner(), std::move(response));
          pending_.erase(it);
          return;
        }
        p.web_open = true;  // the Hello follows inside the WebSocket
        p.have = 0;
        p.bytes.assign(protocol::kHeaderBytes, 0);
      }
      while (true) {
        const size_t n = p.connection->read_available(std::span(p.bytes).subspan(p.have));
        p.have += n;
        if (config_.web && !p.web && p.have >= 4 && !protocol::starts_with_magic(p.bytes)) {
          // Not a Volcast viewer: a browser's HTTP request (for the page, or the WebSocket).
          auto web = std::make_unique<WebSocketConnection>(
              std::move(p.connection), std::span(p.bytes).first(p.have), config_.web,
              protocol::kHeaderBytes + protocol::kMaxHelloBytes, kPendingWebBytes);
          p.web = web.get();
          p.connection = std::move(web);
          p.have = 0;
          step(it);
          return;
        }
        if (p.have == protocol::kHeaderBytes && p.bytes.size() == protocol::kHeaderBytes) {
          const protocol::Header h = protocol::parse_header(p.bytes, protocol::kMaxHelloBytes);
          if (h.type != protocol::MessageType::kHello)
            throw Error("expected Hello as first message");
          if (h.payload_bytes < protocol::kTokenBytes) throw Error("malformed hello: truncated");
          p.bytes.resize(protocol::kHeaderBytes + h.payload_bytes);
        }
        if (p.have == p.bytes.size() && p.bytes.size() > protocol::kHeaderBytes) break;
        if (n == 0) return;  // wait for more
      }
    } catch (const Error& e) {
      ++counters_.failed;
      log_.add(p.connection->peer(), e.what());
      if (p.tls_done) send_reject(*p.connection, std::string("handshake failed: ") + e.what());
      pending_.erase(it);
      return;
    }
    finish(it);
  }

  // The whole Hello is here: token first, then the rest. A right token is always accepted; the
  // back-off after wrong ones applies to wrong ones only.
  void finish(std::list<Pending>::iterator it) {
    Pending p = std::move(*it);
    pending_.erase(it);
    const auto payload = std::span<const uint8_t>(p.bytes).subspan(protocol::kHeaderBytes);
    if (!tokens_equal(protocol::hello_token(payload), config_.token)) {
      refuse_wrong_token(p);
      return;
    }
    Admitted a;
    try {
      a.hello = protocol::parse_hello(payload);
    } catch (const Error& e) {
      ++counters_.failed;
      log_.add(p.connection->peer(), e.what());
      send_reject(*p.connection, std::string("handshake failed: ") + e.what());
      return;
    }
    ++counters_.admitted;
    if (p.web) {
      // Authenticated: its messages may now be as long as a session's avatar frames.
      p.web->authenticated(kMaxWebMessageBytes);
      ++counters_.web_viewers;
    }
    a.connection = std::move(p.connection);
    a.address = p.address;
    try {
      admit_(a);
    } catch (const Error& e) {
      if (a.connection) send_reject(*a.connection, e.what());
    }
  }

  // Refuses a wrong token and backs its address off: after free_wrong_tokens of them (forgotten
  // after 10 quiet minutes), each further one is refused for 1 s, doubling up to 60 s from it.
  void refuse_wrong_token(Pending& p) {
    const auto now = Clock::now();
    Offences& o = offences_[p.address];
    if (now - o.last > kForgetAfter) o = Offences{};
    o.last = now;
    const bool backed_off = now < o.blocked_until;
    if (++o.wrong_tokens >= config_.free_wrong_tokens) {
      const int doublings = std::min(o.wrong_tokens - config_.free_wrong_tokens, 6);
      o.blocked_until =
          now + std::min(std::chrono::seconds(1 << doublings), std::chrono::seconds(60));
    }
    if (backed_off) {
      ++counters_.backed_off;
      const auto wait_s =
          std::chrono::duration_cast<std::chrono::seconds>(o.blocked_until - now).count() + 1;
      log_.add(p.connection->peer(), "wrong join token during this address's back-off");
      send_reject(*p.connection, "too many wrong join tokens from your address: try again in " +
                                     std::to_string(wait_s) + " s");
    } else {
      ++counters_.wrong_token;
      log_.add(p.connection->peer(), "wrong join token");
      send_reject(*p.connection, "wrong join token: use the link the server printed at start");
    }
    prune();
  }

  void expire() {
    const auto now = Clock::now();
    for (auto it = pending_.begin(); it != pending_.end();) {
      if (now < it->deadline) {
        ++it;
        continue;
      }
      ++counters_.failed;
      log_.add(it->connection->peer(),
               "no Hello within " + std::to_string(config_.handshake_timeout_ms) + " ms");
      it = pending_.erase(it);
    }
  }

  // Keeps the offence table bounded: forgets addresses quiet for 10 minutes, then the oldest.
  void prune() {
    constexpr size_t kMaxAddresses = 4096;
    if (offences_.size() <= kMaxAddresses) return;
    const auto now = Clock::now();
    std::erase_if(offences_, [&](const auto& kv) {
      return now > kv.second.blocked_until && now - kv.second.last > kForgetAfter;
    });
    while (offences_.size() > kMaxAddresses) {
      auto oldest = offences_.begin();
      for (auto i = offences_.begin(); i != offences_.end(); ++i)
        if (i->second.last < oldest->second.last) oldest = i;
      offences_.erase(oldest);
    }
  }

  static constexpr auto kForgetAfter = std::chrono::minutes(10);

  TcpListener& listener_;
  const DoorConfig& config_;
  const std::function<void(Admitted&)>& admit_;
  DoorCounters& counters_;
  std::list<Pending> pending_;
  std::unordered_map<std::string, Offences> offences_;
  FailureLog log_;
  Responders responders_;
};

}  // namespace

void run_door(TcpListener& listener, const DoorConfig& config, const std::atomic<bool>& stopping,
              const std::function<void(Admitted&)>& admit, DoorCounters& counters) {
  Door(listener, config, admit, counters).run(stopping);
}

void send_reject(Connection& c, const std::string& reason) {
  const auto msg =
      protocol::message(protocol::MessageType::kReject, protocol::serialize_reject(reason));
  try {
    c.write_all(msg, 200);  // best effort: tell a confused peer why before closing
  } catch (const Error&) {
  }
}

}  // namespace volcast::detail
