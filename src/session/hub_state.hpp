#pragma once
// Private to src/session: a SessionHub's members and sessions (hub.hpp), shared by the lobby,
// presence and forwarding (hub.cpp) and the patient case's objects and monitor (hub_case.cpp).
#include <chrono>
#include <map>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "volcast/session/annotations.hpp"
#include "volcast/session/hub.hpp"

namespace volcast {
namespace hub_detail {

using session::Type;
using Clock = std::chrono::steady_clock;
using Shared = std::shared_ptr<const std::vector<uint8_t>>;

inline constexpr uint32_t kSiteParticipant = 1;

// Coalescing keys: the newest pose / avatar frame of a participant replaces a queued one.
inline uint64_t pose_key(uint32_t id) {
  return (uint64_t{1} << 32) | id;
}
inline uint64_t avatar_key(uint32_t id) {
  return (uint64_t{2} << 32) | id;
}
inline uint64_t object_key(uint16_t object) {
  return (uint64_t{3} << 32) | object;
}
inline constexpr uint64_t kMonitorKey = uint64_t{4} << 32;
// A speaker's voice packets queue up (session_port.hpp kQueuedStreamKey): none replaces another.
inline uint64_t voice_key(uint32_t id) {
  return kQueuedStreamKey | (uint64_t{5} << 32) | id;
}
inline uint64_t voice_state_key(uint32_t id) {
  return (uint64_t{6} << 32) | id;
}
inline uint64_t pointer_key(uint32_t id) {
  return (uint64_t{7} << 32) | id;
}

inline int64_t steady_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(Clock::now().time_since_epoch())
      .count();
}

inline Shared share(std::vector<uint8_t> m) {
  return std::make_shared<const std::vector<uint8_t>>(std::move(m));
}

}  // namespace hub_detail

using namespace hub_detail;

/// A pose of a member's that asked for echoes (messages.hpp PoseMessage echo_wanted) and who
/// answered it: each other member may answer each once (on_pose_echo).
struct EchoAsked {
  bool asked = false;  // a slot not yet used: nothing to answer
  uint32_t sequence = 0;
  uint8_t answers = 0;
  std::array<uint32_t, 16> answered_by{};  // participant ids; more answers than this are dropped
};
/// The asked poses a member keeps, newest last: an answer to an older one is not forwarded
/// (32 asks: 2 s of a page's every-4th of 60 poses a second).
inline constexpr size_t kEchoAskWindow = 32;

struct SessionHub::Member {
  SessionMember info;
  std::array<EchoAsked, kEchoAskWindow> echo_asks{};  // a ring: echo_asks[n % window]
  uint64_t echo_asks_made = 0;
  Session* session = nullptr;
  Clock::time_point last_seen = Clock::now();
  bool dropping = false;  // its last message was malformed: it leaves as kDropped
  std::optional<session::AvatarCamera> camera;
  uint64_t camera_viewer = 0;            // the connection that announced `camera`: once each
  Shared camera_message, last_pose;      // forwarded forms, for participants who join later
  Shared voice_state;                    // forwarded VoiceState, for participants who join later
  uint32_t malformed_voice = 0;          // voice packets refused (voice_messages.hpp)
  Shared pointer;                        // forwarded Pointer while it is held, for those who join
  std::array<uint64_t, 2> rejoin_key{};  // from its Join; all zero: it cannot be taken over
};

struct SessionHub::Session {
  uint32_t id = 0;
  std::string name;
  bool standing = false;  // made by the server (create_session): kept while empty
  Clock::time_point made = Clock::now();
  std::map<uint32_t, std::unique_ptr<Member>> members;  // by participant id, the OR site included
  std::vector<session::ObjectState> objects;            // the case's, by object index
  std::optional<MonitorState> monitor;                  // when the case has a series
  struct Drawn {
    session::Annotation annotation;
    Shared message;         // its 0x51, for those who join later
    uint32_t recorded = 0;  // a replay's (recorded_drawing): its id in the recording; 0: live
  };
  std::map<uint32_t, Drawn> annotations;  // by id (annotations.hpp), in the order drawn
  size_t annotation_points = 0;           // theirs together (kMaxSessionAnnotationPoints)
  uint32_t next_annotation = 1;
};

}  // namespace volcast
