#include "volcast/cluster/session_link.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>

#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/session/hub.hpp"
#include "volcast/session/message_table.hpp"
#include "volcast/session/messages.hpp"
#include "volcast/session/objects.hpp"

namespace volcast::cluster {
namespace {

// A down message is a whole channel-2 message: the largest payload (a case) and its header.
constexpr uint32_t kMaxDownBytes = session::kMaxCaseBytes + 64;

std::string hex(uint8_t v) {
  char s[4];
  std::snprintf(s, sizeof s, "%02x", v);
  return s;
}

int64_t steady_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

std::string random_token() {
  std::random_device rd;
  const uint64_t v = (static_cast<uint64_t>(rd()) << 32) ^ rd();
  char s[24];
  std::snprintf(s, sizeof s, "relay-%012llx",
                static_cast<unsigned long long>(v & 0xffffffffffffull));
  return s;
}

}  // namespace

std::string session_up_subject(const std::string& site, const std::string& relay) {
  check_subject_token(site, "site name");
  check_subject_token(relay, "relay name");
  return "volcast." + site + ".session.up." + relay;
}

std::string session_down_subject(const std::string& site, const std::string& relay) {
  check_subject_token(site, "site name");
  check_subject_token(relay, "relay name");
  return "volcast." + site + ".session.down." + relay;
}

SessionPiece parse_session_piece(std::span<const uint8_t> data) {
  if (data.size() < kSessionPieceHeader)
    throw Error("session piece: " + std::to_string(data.size()) + " bytes, shorter than its " +
                std::to_string(kSessionPieceHeader) + "-byte header");
  SessionPiece p;
  const uint8_t kind = data[0];
  if (kind != 1 && kind != 2) throw Error("session piece: unknown kind " + std::to_string(kind));
  p.kind = static_cast<PieceKind>(kind);
  p.type = data[2];
  p.viewer = wire::load<uint64_t>(&data[4]);
  p.coalesce_key = wire::load<uint64_t>(&data[12]);
  p.total = wire::load<uint32_t>(&data[20]);
  p.offset = wire::load<uint32_t>(&data[24]);
  p.bytes = data.subspan(kSessionPieceHeader);
  if (p.offset > p.total || p.bytes.size() > p.total - p.offset)
    throw Error("session piece: bytes " + std::to_string(p.offset) + ".." +
                std::to_string(p.offset + p.bytes.size()) + " past the message's " +
                std::to_string(p.total));
  if (p.kind == PieceKind::kLeft &&
      (p.total > kMaxSessionReason || p.offset != 0 || p.bytes.size() != p.total))
    throw Error("session piece: a reason of " + std::to_string(p.total) +
                " bytes in pieces or over " + std::to_string(kMaxSessionReason));
  return p;
}

std::optional<std::vector<uint8_t>> PieceAssembler::add(const std::string& stream,
                                                        const SessionPiece& p, uint32_t limit) {
  auto it = partial_.find(stream);
  if (p.offset == 0) {
    if (it != partial_.end()) {  // the one before never finished
      partial_.erase(it);
      ++dropped_;
    }
    if (p.total > limit)
      throw Error("a session message of " + std::to_string(p.total) + " bytes (type 0x" +
                  hex(p.type) + ", at most " + std::to_string(limit) + ")");
    if (p.bytes.size() == p.total) return std::vector<uint8_t>(p.bytes.begin(), p.bytes.end());
    if (partial_.size() >= max_streams_) {
      auto oldest = std::min_element(partial_.begin(), partial_.end(), [](auto& a, auto& b) {
        return a.second.order < b.second.order;
      });
      partial_.erase(oldest);
      ++dropped_;
    }
    Partial& n = partial_[stream];
    n.head = p;
    n.head.bytes = {};
    n.bytes.reserve(p.total);
    n.bytes.assign(p.bytes.begin(), p.bytes.end());
    n.order = ++order_;
    return std::nullopt;
  }
  if (it == partial_.end() || it->second.head.viewer != p.viewer ||
      it->second.head.type != p.type || it->second.head.total != p.total ||
      it->second.head.coalesce_key != p.coalesce_key || it->second.bytes.size() != p.offset) {
    if (it != partial_.end()) partial_.erase(it);
    ++dropped_;
    throw Error("a session message piece at " + std::to_string(p.offset) + " of " +
                std::to_string(p.total) + " bytes that does not follow on");
  }
  it->second.bytes.insert(it->second.bytes.end(), p.bytes.begin(), p.bytes.end());
  if (it->second.bytes.size() < p.total) return std::nullopt;
  std::vector<uint8_t> whole = std::move(it->second.bytes);
  partial_.erase(it);
  return whole;
}

void publish_session_message(NatsConnection& nats, const std::string& subject, PieceKind kind,
                             uint8_t type, uint64_t viewer, uint64_t coalesce_key,
                             std::span<const uint8_t> message) {
  const size_t max = nats.max_payload();
  if (max <= kSessionPieceHeader) throw Error("NATS max_payload too small for a session piece");
  const size_t per = max - kSessionPieceHeader;
  std::vector<uint8_t> piece;
  size_t offset = 0;
  do {
    const size_t n = std::min(per, message.size() - offset);
    piece.assign(kSessionPieceHeader + n, 0);
    piece[0] = static_cast<uint8_t>(kind);
    piece[2] = type;
    wire::store<uint64_t>(&piece[4], viewer);
    wire::store<uint64_t>(&piece[12], coalesce_key);
    wire::store<uint32_t>(&piece[20], static_cast<uint32_t>(message.size()));
    wire::store<uint32_t>(&piece[24], static_cast<uint32_t>(offset));
    std::copy_n(message.data() + offset, n, piece.data() + kSessionPieceHeader);
    nats.publish(subject, piece);
    offset += n;
  } while (offset < message.size());
}

// ---- SessionBridge (the site's end) ----

SessionBridge::SessionBridge(NatsConnection& nats, std::string site, SessionPort& hub,
                             size_t max_viewers)
    : nats_(nats), site_(std::move(site)), hub_(hub), max_viewers_(max_viewers) {
  check_subject_token(site_, "site name");
  sub_ = nats_.subscribe("volcast." + site_ + ".session.up.*",
                         [this](const std::string& subject, std::span<const uint8_t> data) {
                           on_piece(subject, data);
                         });
}

SessionBridge::~SessionBridge() {
  sub_.reset();
}

SessionLinkStats SessionBridge::stats() const {
  std::lock_guard lock(mutex_);
  SessionLinkStats s = stats_;
  s.viewers = remotes_.size();
  return s;
}

uint64_t SessionBridge::id_of(const std::string& relay, uint64_t viewer,
                              std::vector<uint64_t>& pushed_out) {
  const auto key = std::make_pair(relay, viewer);
  if (auto it = ids_.find(key); it != ids_.end()) return it->second;
  if (remotes_.size() >= max_viewers_) {
    auto oldest = std::min_element(remotes_.begin(), remotes_.end(), [](auto& a, auto& b) {
      return a.second.last_seen < b.second.last_seen;
    });
    pushed_out.push_back(oldest->first);
    ids_.erase({oldest->second.relay, oldest->second.viewer});
    remotes_.erase(oldest);
  }
  const uint64_t id = SessionHub::kRemoteViewer | next_id_++;
  remotes_[id] = Remote{relay, viewer, std::chrono::steady_clock::now()};
  ids_[key] = id;
  return id;
}

void SessionBridge::on_piece(const std::string& subject, std::span<const uint8_t> data) {
  const std::string prefix = "volcast." + site_ + ".session.up.";
  if (subject.size() <= prefix.size()) return;
  const std::string relay = subject.substr(prefix.size());
  SessionPiece p;
  try {
    p = parse_session_piece(data);
  } catch (const Error& e) {
    std::lock_guard lock(mutex_);
    ++stats_.malformed;
    stats_.last_error = "from relay " + relay + ": " + e.what();
    return;
  }
  std::vector<uint64_t> pushed_out;
  uint64_t id = 0;
  {
    std::lock_guard lock(mutex_);
    if (p.kind == PieceKind::kLeft) {
      auto it = ids_.find({relay, p.viewer});
      if (it == ids_.end()) return;  // never sent anything, or already forgotten
      id = it->second;
      ids_.erase(it);
      remotes_.erase(id);
    } else {
      id = id_of(relay, p.viewer, pushed_out);
      remotes_[id].last_seen = std::chrono::steady_clock::now();
    }
  }
  for (uint64_t gone : pushed_out) {
    hub_.on_viewer_left(
        gone, "pushed out: more than " + std::to_string(max_viewers_) + " viewers on relays");
    std::lock_guard lock(mutex_);
    ++stats_.refused;
  }
  if (p.kind == PieceKind::kLeft) {
    hub_.on_viewer_left(
        id, "relay " + relay + ": " + printable(std::string(p.bytes.begin(), p.bytes.end())));
    return;
  }
  std::optional<std::vector<uint8_t>> whole;
  try {
    const uint32_t limit = hub_.max_payload(p.type);
    if (limit == 0) throw Error("an unknown session message type 0x" + hex(p.type));
    whole = assembler_.add(relay, p, limit);
  } catch (const Error& e) {
    drop(id, e.what());
    return;
  }
  if (!whole) return;
  {
    std::lock_guard lock(mutex_);
    ++stats_.messages_in;
  }
  try {
    hub_.on_message(id, p.type, *whole);
  } catch (const Error& e) {
    drop(id, e.what());
  }
}

void SessionBridge::drop(uint64_t id, const std::string& why) {
  Remote r;
  {
    std::lock_guard lock(mutex_);
    auto it = remotes_.find(id);
    if (it == remotes_.end()) return;
    r = it->second;
    ids_.erase({r.relay, r.viewer});
    remotes_.erase(it);
    ++stats_.refused;
    stats_.last_error = why;
  }
  spdlog::warn("session: a viewer of relay {} dropped: {}", r.relay, why);
  const std::string reason = why.substr(0, kMaxSessionReason);
  publish(r.relay, PieceKind::kLeft, r.viewer, 0,
          {reinterpret_cast<const uint8_t*>(reason.data()), reason.size()});
  hub_.on_viewer_left(id, why);
}

void SessionBridge::publish(const std::string& relay, PieceKind kind, uint64_t viewer, uint64_t key,
                            std::span<const uint8_t> bytes) {
  try {
    std::lock_guard lock(publish_mutex_);
    publish_session_message(nats_, session_down_subject(site_, relay), kind, 0, viewer, key, bytes);
  } catch (const Error& e) {
    std::lock_guard lock(mutex_);
    ++stats_.errors;
    stats_.last_error = e.what();
  }
}

bool SessionBridge::send_session(uint64_t viewer,
                                 std::shared_ptr<const std::vector<uint8_t>> message,
                                 uint64_t coalesce_key) {
  Remote r;
  {
    std::lock_guard lock(mutex_);
    auto it = remotes_.find(viewer);
    if (it == remotes_.end()) return false;
    r = it->second;
    ++stats_.messages_out;
  }
  publish(r.relay, PieceKind::kMessage, r.viewer, coalesce_key, *message);
  return true;
}

void SessionBridge::disconnect(uint64_t viewer, const std::string& why) {
  Remote r;
  {
    std::lock_guard lock(mutex_);
    auto it = remotes_.find(viewer);
    if (it == remotes_.end()) return;
    r = it->second;
    ids_.erase({r.relay, r.viewer});
    remotes_.erase(it);
  }
  const std::string reason = why.substr(0, kMaxSessionReason);
  publish(r.relay, PieceKind::kLeft, r.viewer, 0,
          {reinterpret_cast<const uint8_t*>(reason.data()), reason.size()});
  // The hub calls this holding its lock, having let the viewer go already: telling it again
  // (on_viewer_left) here would deadlock, and is not needed.
}

// ---- SessionForwarder (a relay's end) ----

SessionForwarder::SessionForwarder(NatsConnection& nats, std::string site, std::string relay)
    : nats_(nats), site_(std::move(site)), relay_(relay.empty() ? random_token() : relay) {
  up_ = session_up_subject(site_, relay_);
  sub_ = nats_.subscribe(
      session_down_subject(site_, relay_),
      [this](const std::string&, std::span<const uint8_t> data) { on_piece(data); });
}

SessionForwarder::~SessionForwarder() {
  sub_.reset();
}

void SessionForwarder::attach(SessionOutlet* server) {
  std::lock_guard lock(mutex_);
  server_ = server;
}

SessionLinkStats SessionForwarder::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

uint32_t SessionForwarder::max_payload(uint8_t type) const {
  return session::max_payload(type);
}

void SessionForwarder::publish(PieceKind kind, uint8_t type, uint64_t viewer,
                               std::span<const uint8_t> bytes) {
  try {
    std::lock_guard lock(publish_mutex_);
    publish_session_message(nats_, up_, kind, type, viewer, 0, bytes);
  } catch (const Error& e) {
    std::lock_guard lock(mutex_);
    ++stats_.errors;
    stats_.last_error = e.what();
  }
}

void SessionForwarder::on_message(uint64_t viewer, uint8_t type, std::span<const uint8_t> payload) {
  // Rate limited here, before NATS and the site's hub see it (the hub limits it again, the same).
  const session::Admission a = limiter_.admit(viewer, type, steady_us());
  if (!a.report.empty()) {
    spdlog::warn("relay {}: session: viewer {}: {}", relay_, viewer, a.report);
    std::lock_guard lock(mutex_);
    if (a.started && server_)
      server_->send_session(viewer,
                            std::make_shared<const std::vector<uint8_t>>(session::message(
                                session::Type::kSessionError, session::serialize_error(a.report))));
  }
  if (!a.admitted) {
    std::lock_guard lock(mutex_);
    ++stats_.rate_limited;
    return;
  }
  // The hub checks the message itself; a refusal comes back as a disconnect.
  publish(PieceKind::kMessage, type, viewer, payload);
  std::lock_guard lock(mutex_);
  ++stats_.messages_out;
}

void SessionForwarder::on_viewer_left(uint64_t viewer, const std::string& why) {
  if (const std::string dropped = limiter_.forget(viewer, steady_us()); !dropped.empty())
    spdlog::warn("relay {}: session: viewer {} left: {}", relay_, viewer, dropped);
  const std::string reason = why.substr(0, kMaxSessionReason);
  publish(PieceKind::kLeft, 0, viewer,
          {reinterpret_cast<const uint8_t*>(reason.data()), reason.size()});
}

void SessionForwarder::on_piece(std::span<const uint8_t> data) {
  std::optional<std::vector<uint8_t>> whole;
  SessionPiece p;
  try {
    p = parse_session_piece(data);
    if (p.kind == PieceKind::kMessage) whole = assembler_.add("down", p, kMaxDownBytes);
  } catch (const Error& e) {
    std::lock_guard lock(mutex_);
    ++stats_.malformed;
    stats_.last_error = e.what();
    return;
  }
  std::lock_guard lock(mutex_);
  if (!server_) return;
  if (p.kind == PieceKind::kLeft) {
    server_->disconnect(
        p.viewer, "the site's session: " + printable(std::string(p.bytes.begin(), p.bytes.end())));
    return;
  }
  if (!whole) return;
  ++stats_.messages_in;
  server_->send_session(p.viewer, std::make_shared<const std::vector<uint8_t>>(std::move(*whole)),
                        p.coalesce_key);
}

}  // namespace volcast::cluster
