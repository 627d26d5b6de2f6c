#include "volcast/session/message_table.hpp"

#include <array>
#include <iterator>
#include <string>

#include "volcast/core/error.hpp"
#include "volcast/session/annotations.hpp"
#include "volcast/session/objects.hpp"
#include "volcast/session/voice_messages.hpp"

namespace volcast::session {
namespace {

using Payload = std::span<const uint8_t>;

constexpr uint32_t kSmall = kMaxSessionMessageBytes;
constexpr Sender kUp = Sender::kParticipant;
constexpr Sender kDown = Sender::kServer;
constexpr RateLimit kServers{};
constexpr Feature kPresence = Feature::kPresence, kAvatars = Feature::kAvatars,
                  kVoice = Feature::kVoice, kDrawing = Feature::kDrawing,
                  kObjects = Feature::kObjects;

void empty(Payload p, const char* name) {
  if (!p.empty()) throw Error(std::string("malformed ") + name + ": not empty");
}

// The server -> participant types that forward a participant's payload (messages.hpp forward).
template <auto parse>
void forwarded(Payload p) {
  parse(split_forwarded(p).second);
}

// Its feature, who sends it, its name, the largest payload, the rate limit, the decoder: one row
// per type.
// clang-format off
constexpr std::array kTable{
    MessageKind{Type::kListSessions, kPresence, "list sessions", kUp, kSmall, {2, 5, "session lists"},
                [](Payload p) { empty(p, "list sessions"); }},
    MessageKind{Type::kJoin, kPresence, "join", kUp, kSmall, {2, 5, "joins"},
                [](Payload p) { parse_join(p); }},
    MessageKind{Type::kLeave, kPresence, "leave", kUp, kSmall, {2, 5, "leaves"},
                [](Payload p) { empty(p, "leave"); }},
    MessageKind{Type::kPose, kPresence, "pose", kUp, kSmall, {150, 75, "poses"},
                [](Payload p) { parse_pose(p); }},
    MessageKind{Type::kPoseEcho, kPresence, "pose echo", kUp, kSmall, {600, 300, "pose echoes"},
                [](Payload p) { parse_echo(p); }},
    MessageKind{Type::kTeleport, kPresence, "teleport", kUp, kSmall, {4, 8, "teleports"},
                [](Payload p) { parse_teleport(p); }},
    MessageKind{Type::kAvatarCamera, kAvatars, "avatar camera", kUp, kSmall, {1, 2, "avatar cameras"},
                [](Payload p) { parse_avatar_camera(p); }},
    MessageKind{Type::kAvatarFrame, kAvatars, "avatar frame", kUp, kMaxAvatarFrameBytes,
                {30, 15, "avatar frames"}, nullptr},
    MessageKind{Type::kHeartbeat, kPresence, "heartbeat", kUp, kSmall, {10, 10, "heartbeats"},
                [](Payload p) { empty(p, "heartbeat"); }},
    MessageKind{Type::kGrab, kObjects, "grab", kUp, kSmall, {10, 10, "grabs"},
                [](Payload p) { parse_object_request(p, false); }},
    MessageKind{Type::kObjectMove, kObjects, "object move", kUp, kSmall, {150, 75, "object moves"},
                [](Payload p) { parse_object_request(p, true); }},
    MessageKind{Type::kRelease, kObjects, "release", kUp, kSmall, {10, 10, "releases"},
                [](Payload p) { parse_object_request(p, true); }},
    MessageKind{Type::kSetMonitor, kObjects, "set monitor", kUp, kSmall, {150, 75, "monitor changes"},
                [](Payload p) { parse_set_monitor(p); }},
    // Voice: 50 packets a second while talking; a burst after a stall of the sender's link or
    // thread. A client holds up to kMaxHeldPerStream (50, session_port.hpp) and sends them at
    // once: the burst admits twice that (was 40: a loaded client's held second lost 11 packets).
    MessageKind{Type::kVoice, kVoice, "voice", kUp, kVoiceMessageLimit, {60, 100, "voice packets"},
                [](Payload p) { parse_voice(p); }},
    MessageKind{Type::kVoiceState, kVoice, "voice state", kUp, kSmall, {5, 10, "voice states"},
                [](Payload p) { parse_voice_state(p); }},
    // Pointers at the pose rate; annotations a few a second, a burst of a quick sketch.
    MessageKind{Type::kPointer, kDrawing, "pointer", kUp, kSmall, {150, 75, "pointers"},
                [](Payload p) { parse_pointer(p); }},
    MessageKind{Type::kAnnotate, kDrawing, "annotate", kUp, kSmall, {5, 20, "annotations"},
                [](Payload p) { parse_annotate(p); }},
    MessageKind{Type::kErase, kDrawing, "erase", kUp, kSmall, {10, 20, "erases"},
                [](Payload p) { parse_erase(p); }},
    MessageKind{Type::kSessionList, kPresence, "session list", kDown, kSmall, kServers,
                [](Payload p) { parse_session_list(p); }},
    MessageKind{Type::kJoined, kPresence, "joined", kDown, kSmall, kServers,
                [](Payload p) { parse_joined(p); }},
    MessageKind{Type::kSessionError, kPresence, "session error", kDown, kSmall, kServers,
                [](Payload p) { parse_error(p); }},
    MessageKind{Type::kParticipantJoined, kPresence, "participant joined", kDown, kSmall, kServers,
                [](Payload p) { parse_participant(p); }},
    MessageKind{Type::kParticipantLeft, kPresence, "participant left", kDown, kSmall, kServers,
                [](Payload p) { parse_left(p); }},
    MessageKind{Type::kPoseFrom, kPresence, "pose", kDown, kSmall, kServers, forwarded<parse_pose>},
    MessageKind{Type::kPoseEchoFrom, kPresence, "pose echo", kDown, kSmall, kServers,
                [](Payload p) { parse_echo(p); }},
    MessageKind{Type::kTeleported, kPresence, "teleported", kDown, kSmall, kServers,
                [](Payload p) { parse_teleported(p); }},
    MessageKind{Type::kAvatarCameraFrom, kAvatars, "avatar camera", kDown, kSmall, kServers,
                forwarded<parse_avatar_camera>},
    MessageKind{Type::kAvatarFrameFrom, kAvatars, "avatar frame", kDown, kMaxAvatarFrameBytes + 4, kServers,
                nullptr},
    MessageKind{Type::kCase, kObjects, "case", kDown, kMaxCaseBytes, kServers,
                [](Payload p) { parse_case(p); }},
    MessageKind{Type::kObjectState, kObjects, "object state", kDown, kSmall, kServers,
                [](Payload p) { parse_object_state(p); }},
    MessageKind{Type::kMonitorState, kObjects, "monitor state", kDown, kSmall, kServers,
                [](Payload p) { parse_monitor_state(p); }},
    MessageKind{Type::kVoiceFrom, kVoice, "voice", kDown, kVoiceMessageLimit + 4, kServers,
                forwarded<parse_voice>},
    MessageKind{Type::kVoiceStateFrom, kVoice, "voice state", kDown, kSmall, kServers,
                forwarded<parse_voice_state>},
    MessageKind{Type::kPointerFrom, kDrawing, "pointer", kDown, kSmall, kServers, forwarded<parse_pointer>},
    MessageKind{Type::kAnnotation, kDrawing, "annotation", kDown, kSmall, kServers,
                [](Payload p) { parse_annotation(p); }},
    MessageKind{Type::kErased, kDrawing, "erased", kDown, kSmall, kServers,
                [](Payload p) { parse_erased(p); }},
    MessageKind{Type::kRecordingState, kPresence, "recording state", kDown, kSmall, kServers,
                [](Payload p) { parse_recording_state(p); }},
};
// clang-format on

}  // namespace

const char* to_string(Feature f) {
  constexpr const char* kNames[] = {"presence", "avatars", "voice", "drawing", "objects"};
  const auto i = static_cast<size_t>(f);
  return i < std::size(kNames) ? kNames[i] : "?";
}

std::span<const MessageKind> message_table() {
  return kTable;
}

const MessageKind* find_message(uint8_t type) {
  for (const MessageKind& m : kTable)
    if (static_cast<uint8_t>(m.type) == type) return &m;
  return nullptr;
}

uint32_t max_payload(uint8_t type) {
  const MessageKind* m = find_message(type);
  return m ? m->max_payload : 0;
}

RateLimit limit_of(uint8_t type) {
  const MessageKind* m = find_message(type);
  if (m && m->sender == Sender::kParticipant) return m->rate;
  return {0, 0, "messages of a type participants do not send"};
}

}  // namespace volcast::session
