#pragma once
// The session channel's messages (protocol.hpp channel 2): the lobby, participants, poses,
// teleports and camera avatars of a shared virtual operating room (Fischer et al. 2024, §3.4).
// They travel on the same authenticated connection as the stream (TLS 1.3, after the join token);
// every one goes through the server, which checks it and forwards it (the paper's design: the OR
// server hosts the session and relays all traffic but the avatar streams; here those go through
// it too, encoded once by their sender and forwarded to everyone unchanged).
//
// Header as every message: "VCST" | version u16 | channel u8 = 2 | type u8 | payload length u32.
// Little-endian; strings u16 length + UTF-8; byte strings u32 length + bytes; f32/f64 IEEE-754.
// Times are i64 microseconds on the SERVER's wall clock (each participant shifts its own clock by
// the offset it estimated in the handshake, Client::clock_offset_us), so poses and frames of all
// participants share one timeline.
//
// A placement on the floor, "spot": x f32 | z f32 | yaw f32 (metres, metres, radians about +y):
// room_from_playarea = translation (x, 0, z) * rotation yaw about y (room.hpp).
// A pose: position 3 f32 (metres) | orientation 4 f32 (quaternion x, y, z, w; unit within 1e-3).
// A body: flags u8 (bit 0: hands tracked) | head pose | left hand pose | right hand pose, all
// room_from_* (room.hpp).
//
// participant -> server (type):
//   0x01 ListSessions   empty. Answered by 0x41.
//   0x02 Join           session name string (1..64 bytes, printable) | create u8 (1: make the
//                       session if there is none of that name) | display name string (1..64
//                       bytes, printable) | role u8 (0 remote, 1 OR site) | has camera u8
//                       [| rejoin key 16 bytes: optional, not all zero]. A Join whose name is
//                       taken by a member that joined with the same rejoin key takes that
//                       member over (a viewer reconnecting after its path was cut): the same
//                       participant id, objects and annotations; the old connection is closed.
//                       Answered by 0x42 then 0x44 for each participant already there, or 0x43:
//                       for role 1 (the OR site's role is the server's own participant 1; roles
//                       come from the server, every viewer is remote), for a name names.hpp
//                       refuses (UTF-8, NFC; bidi controls, invisible characters, mixed-script
//                       look-alikes) or one that looks like another's in the session, for a new
//                       session over the creator's limit (rate_limit.hpp kSessionCreation).
//   0x03 Leave          empty: back to the lobby (the connection and its stream stay).
//   0x04 Pose           sequence u32 | time i64 | echo wanted u8 (1: every receiver answers with
//                       0x05) | body. Coalesced: the server keeps only the newest pose of a
//                       participant that a receiver has not been sent yet.
//   0x05 PoseEcho       origin participant u32 | sequence u32: "I saw your pose `sequence`"; the
//                       server forwards it to the origin only (the session round trip), and only
//                       as the answer to one of the origin's 32 newest poses that asked for
//                       echoes, once per answering participant: others are dropped (what one
//                       participant may make another receive is bounded by what it asked).
//   0x06 Teleport       spot (where the play area's origin goes, and its new yaw). The server
//                       checks the spot is free (room.hpp) and answers everyone with 0x48, or the
//                       sender with 0x43.
//   0x07 AvatarCamera   the participant's RGB-D camera: calibration (calibration_wire.hpp;
//                       its pose is playarea_from_camera) | depth codec string | color codec
//                       string. The depth codec must be lossless and not temporal (a receiver
//                       joining later decodes any frame), the color codec not temporal. Sent once
//                       per connection, before frames (a second one drops the sender); a member
//                       taken over by a rejoin sends it again on its new connection.
//   0x08 AvatarFrame    sequence u64 | capture time i64 | depth bytes | color bytes (each a codec
//                       stream of the announced codecs, the announced size). Coalesced like poses.
//   0x09 Heartbeat      empty: presence while nothing else is sent.
// server -> participant:
//   0x41 SessionList    count u16 | per session: id u32 | name string | participants u16
//   0x42 Joined         your participant id u32 | session id u32 | session name string | your
//                       spot | room_from_site: translation 3 f32 (metres) | yaw f32 (radians) --
//                       where the OR site's world frame sits in the room (its cameras' poses are
//                       site_from_camera, the Welcome's world_from_camera).
//   0x43 SessionError   reason string (no such session, name taken or refused, session full, a
//                       spot not free, not in a session, a message type over its rate limit:
//                       rate_limit.hpp, once per burst of dropped messages).
//   0x44 ParticipantJoined  id u32 | display name string | role u8 | has camera u8 | spot
//   0x45 ParticipantLeft    id u32 | reason u8 (0 left, 1 timed out: nothing heard for the
//                       server's presence timeout, 2 disconnected, 3 dropped for a bad message)
//   0x46 Pose           participant u32 | the 0x04 payload
//   0x47 PoseEcho       echoing participant u32 | sequence u32 (of your pose)
//   0x48 Teleported     participant u32 | from spot | to spot | time i64
//   0x49 AvatarCamera   participant u32 | the 0x07 payload
//   0x4a AvatarFrame    participant u32 | the 0x08 payload
//   0x53 RecordingState recording u8 (1: what happens in the room is being recorded) | since
//                       i64 (when it started, server clock; 0 when not recording) | by string
//                       (who or what records, as everyone is shown it: 0..kMaxRecorderBytes
//                       bytes without control characters). Sent after 0x42 while a recording
//                       runs, and to every member of every session when one starts or stops
//                       (SessionHub::set_recording): every viewer shows it (protocol 6).
// The patient case's objects and monitor: 0x0a..0x0d and 0x4b..0x4d, objects.hpp. Voice: 0x0e,
// 0x0f, 0x4e, 0x4f, voice_messages.hpp. Pointers and annotations: 0x10..0x12 and 0x50..0x52,
// annotations.hpp. Every type's
// sender, payload limit, rate limit and decoder in one table: message_table.hpp.
//
// Rates: each participant's messages of each type are limited where they enter the server or a
// relay (rate_limit.hpp); over its rate a message is dropped, not applied or forwarded, and the
// sender is told by 0x43 once per burst.
// Limits (a message over its limit, with a bad field, or of an unknown type is malformed: the
// server drops its sender, a participant ends its connection): 0x08 and 0x4a at most
// kMaxAvatarFrameBytes (+ 4), and within kMaxAvatarBytesPerPixel x the announced pixels +
// kMaxAvatarFrameOverhead; an avatar camera at most kMaxAvatarSide pixels per side; every other
// message at most kMaxSessionMessageBytes (a SessionList up to kMaxListedSessions sessions).
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/room/room.hpp"

namespace volcast::session {

inline constexpr uint32_t kMaxSessionMessageBytes = 16u << 10;
inline constexpr uint32_t kMaxAvatarFrameBytes = 8u << 20;
inline constexpr int kMaxAvatarSide = 2048;
inline constexpr uint64_t kMaxAvatarBytesPerPixel = 8;
inline constexpr uint64_t kMaxAvatarFrameOverhead = 64u << 10;
inline constexpr size_t kMaxNameBytes = 64;
inline constexpr size_t kMaxListedSessions = 64;
inline constexpr size_t kMaxRecorderBytes = 200;

enum class Type : uint8_t {
  kListSessions = 0x01,
  kJoin = 0x02,
  kLeave = 0x03,
  kPose = 0x04,
  kPoseEcho = 0x05,
  kTeleport = 0x06,
  kAvatarCamera = 0x07,
  kAvatarFrame = 0x08,
  kHeartbeat = 0x09,
  kGrab = 0x0a,        // objects.hpp
  kObjectMove = 0x0b,  // objects.hpp
  kRelease = 0x0c,     // objects.hpp
  kSetMonitor = 0x0d,  // objects.hpp
  kVoice = 0x0e,       // voice_messages.hpp
  kVoiceState = 0x0f,  // voice_messages.hpp
  kPointer = 0x10,     // annotations.hpp
  kAnnotate = 0x11,    // annotations.hpp
  kErase = 0x12,       // annotations.hpp
  kSessionList = 0x41,
  kJoined = 0x42,
  kSessionError = 0x43,
  kParticipantJoined = 0x44,
  kParticipantLeft = 0x45,
  kPoseFrom = 0x46,
  kPoseEchoFrom = 0x47,
  kTeleported = 0x48,
  kAvatarCameraFrom = 0x49,
  kAvatarFrameFrom = 0x4a,
  kCase = 0x4b,            // objects.hpp
  kObjectState = 0x4c,     // objects.hpp
  kMonitorState = 0x4d,    // objects.hpp
  kVoiceFrom = 0x4e,       // voice_messages.hpp
  kVoiceStateFrom = 0x4f,  // voice_messages.hpp
  kPointerFrom = 0x50,     // annotations.hpp
  kAnnotation = 0x51,      // annotations.hpp
  kErased = 0x52,          // annotations.hpp
  kRecordingState = 0x53,
};

enum class Role : uint8_t { kRemote = 0, kOrSite = 1 };
const char* to_string(Role role);

/// Where a play area stands on the floor: room_from_playarea = translate(x, 0, z) * rotate_y(yaw).
struct Spot {
  float x = 0, z = 0;  ///< metres, room frame
  float yaw = 0;       ///< radians about +y
};
RigidTransform room_from_playarea(const Spot& spot);

struct SessionSummary {
  uint32_t id = 0;
  std::string name;
  uint32_t participants = 0;
};

struct Join {
  std::string session;
  bool create = true;
  std::string name;
  Role role = Role::kRemote;
  bool has_camera = false;
  /// A secret the participant draws once (128 random bits) and sends again when it reconnects,
  /// so that the server hands it back its own place; all zero: none (the field is not sent).
  std::array<uint64_t, 2> rejoin_key{};
};

struct Joined {
  uint32_t participant = 0, session = 0;
  std::string session_name;
  Spot spot;
  Eigen::Vector3f site_translation = Eigen::Vector3f::Zero();  ///< room_from_site, metres
  float site_yaw = 0;                                          ///< room_from_site, radians
};

struct ParticipantInfo {
  uint32_t id = 0;
  std::string name;
  Role role = Role::kRemote;
  bool has_camera = false;
  Spot spot;
};

enum class LeftReason : uint8_t { kLeft = 0, kTimedOut = 1, kDisconnected = 2, kDropped = 3 };
const char* to_string(LeftReason reason);

struct PoseMessage {
  uint32_t sequence = 0;
  int64_t time_us = 0;  ///< server clock
  bool echo_wanted = false;
  BodyPose body;  ///< room frame
};

struct Teleported {
  uint32_t participant = 0;
  Spot from, to;
  int64_t time_us = 0;  ///< server clock
};

struct AvatarCamera {
  CameraCalibration calibration;  ///< world_from_camera is playarea_from_camera
  std::string depth_codec, color_codec;
};

/// An avatar frame's fields; the views point into the parsed payload.
struct AvatarFrameView {
  uint64_t sequence = 0;
  int64_t capture_us = 0;  ///< server clock
  std::span<const uint8_t> depth, color;
};

/// Whether the room is being recorded, as every participant must be shown it (0x53).
struct RecordingState {
  bool recording = false;
  int64_t since_us = 0;  ///< when it started, server clock; 0 when not recording
  std::string by;        ///< who or what records ("the OR server (serve --record)")
};

/// A whole session message (header + payload) of `type`.
std::vector<uint8_t> message(Type type, std::span<const uint8_t> payload);

// Payloads. Every parse_* throws Error("malformed <message>: ...") on truncation, trailing bytes,
// a field out of range (names: 1..64 printable bytes; non-finite numbers; a non-unit quaternion;
// an unknown role) and never reads past the payload.
std::vector<uint8_t> serialize(const Join& m);
Join parse_join(std::span<const uint8_t> p);
std::vector<uint8_t> serialize(const std::vector<SessionSummary>& m);
std::vector<SessionSummary> parse_session_list(std::span<const uint8_t> p);
std::vector<uint8_t> serialize(const Joined& m);
Joined parse_joined(std::span<const uint8_t> p);
std::vector<uint8_t> serialize_error(const std::string& reason);
std::string parse_error(std::span<const uint8_t> p);
std::vector<uint8_t> serialize(const ParticipantInfo& m);
ParticipantInfo parse_participant(std::span<const uint8_t> p);
std::vector<uint8_t> serialize_left(uint32_t participant, LeftReason reason);
std::pair<uint32_t, LeftReason> parse_left(std::span<const uint8_t> p);
std::vector<uint8_t> serialize(const PoseMessage& m);
PoseMessage parse_pose(std::span<const uint8_t> p);
/// 0x05 and 0x47: (participant, sequence).
std::vector<uint8_t> serialize_echo(uint32_t participant, uint32_t sequence);
std::pair<uint32_t, uint32_t> parse_echo(std::span<const uint8_t> p);
std::vector<uint8_t> serialize(const Spot& m);
Spot parse_teleport(std::span<const uint8_t> p);
std::vector<uint8_t> serialize(const Teleported& m);
Teleported parse_teleported(std::span<const uint8_t> p);
std::vector<uint8_t> serialize(const RecordingState& m);
/// Also refuses a recording without a start or a `by` over kMaxRecorderBytes.
RecordingState parse_recording_state(std::span<const uint8_t> p);
std::vector<uint8_t> serialize(const AvatarCamera& m);
/// Also refuses a side above kMaxAvatarSide, an unknown codec, a lossy or temporal depth codec, a
/// temporal color codec.
AvatarCamera parse_avatar_camera(std::span<const uint8_t> p);
std::vector<uint8_t> serialize_avatar_frame(uint64_t sequence, int64_t capture_us,
                                            std::span<const uint8_t> depth,
                                            std::span<const uint8_t> color);
/// Also refuses a frame larger than avatar_frame_limit(camera).
AvatarFrameView parse_avatar_frame(std::span<const uint8_t> p, const CameraCalibration& camera);
/// The largest AvatarFrame payload for `camera` (bytes): kMaxAvatarBytesPerPixel per pixel plus
/// kMaxAvatarFrameOverhead, at most kMaxAvatarFrameBytes.
uint32_t avatar_frame_limit(const CameraCalibration& camera);

/// A server -> participant message forwarding `payload` from `participant`: the 0x4_ types whose
/// payload is "participant u32 | the original payload" (0x46, 0x49, 0x4a, 0x4e, 0x4f, 0x50).
std::vector<uint8_t> forward(Type type, uint32_t participant, std::span<const uint8_t> payload);
/// Splits such a payload into the participant and the original payload. Throws Error if short.
std::pair<uint32_t, std::span<const uint8_t>> split_forwarded(std::span<const uint8_t> p);

}  // namespace volcast::session
