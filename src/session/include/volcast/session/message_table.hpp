#pragma once
// The session channel's message table: one row per message type (messages.hpp's Type; the
// layouts are in its feature's header) naming its feature, who sends it, the largest payload it
// may have, its rate limit where a participant sends it (rate_limit.hpp enforces them), and its
// decoder. max_payload() and limit_of() read it; message_table.cpp holds the rows. The hub and
// the participant dispatch what they receive through their features' routes, one per row of the
// other side's types (session_test checks both cover the table); web/page/messages.js is made
// from it (`volcast messages --js`).
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

/// What a message is about. Each feature owns its messages: their layouts (the header named),
/// the hub's handlers (hub.hpp's routes, hub_<feature>.cpp) and the participant's
/// (participant_impl.hpp's routes).
enum class Feature : uint8_t {
  kPresence,  ///< the lobby, joining and leaving, poses, teleports (messages.hpp)
  kAvatars,   ///< camera avatars (messages.hpp)
  kVoice,     ///< voice packets and microphone states (voice_messages.hpp)
  kDrawing,   ///< pointers and annotations (annotations.hpp)
  kObjects,   ///< the patient case, its objects and the monitor (objects.hpp)
};
/// "presence", "avatars", "voice", "drawing", "objects".
const char* to_string(Feature f);

/// One session message type.
struct MessageKind {
  Type type{};
  Feature feature{};
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
