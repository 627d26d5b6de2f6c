#pragma once
// The session channel's message table: one row per message type (messages.hpp's Type; the
// layouts are in messages.hpp and objects.hpp) naming who sends it, the largest payload it may
// have, its rate limit where a participant sends it (rate_limit.hpp enforces them), and its
// decoder. max_payload() and limit_of() read it; message_table.cpp holds the rows.
#include <cstdint>
#include <span>

#include "volcast/session/messages.hpp"

namespace volcast::session {

/// A token bucket's shape: `burst` messages at once, refilled at `per_second`; `what` names the
/// messages in reports ("poses").
struct RateLimit {
  double per_second = 0;
  double burst = 0;
  const char* what = "";
};

enum class Sender : uint8_t { kParticipant, kServer };

/// One session message type.
struct MessageKind {
  Type type{};
  const char* name = "";  ///< as its decoder's errors name it ("malformed <name>: ...")
  Sender sender = Sender::kParticipant;
  uint32_t max_payload = 0;  ///< bytes
  /// A participant's messages of this type (rate_limit.hpp); {0, 0} for the server's.
  RateLimit rate;
  /// Its decoder (the parse_* of messages.hpp, objects.hpp) run for its checks: throws
  /// Error("malformed <name>: ...") on a payload it refuses. Null for an avatar frame (0x08,
  /// 0x4a), which only its sender's camera bounds (parse_avatar_frame).
  void (*check)(std::span<const uint8_t> payload) = nullptr;
};

/// Every session message type, by type.
std::span<const MessageKind> message_table();
/// The row of `type`; null for a type that does not exist.
const MessageKind* find_message(uint8_t type);
/// The largest payload (bytes) a message of `type` may have; 0 for a type that does not exist.
uint32_t max_payload(uint8_t type);
/// The limit of a participant's session messages of `type` (messages.hpp's 0x01..0x1f); for a
/// type a participant does not send, a limit of 0: not limited here (the hub refuses it).
RateLimit limit_of(uint8_t type);

}  // namespace volcast::session
