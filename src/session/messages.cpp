#include "volcast/session/messages.hpp"

#include <algorithm>
#include <cmath>

#include "feature_layouts.hpp"
#include "volcast/codec/registry.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/net/protocol/calibration_wire.hpp"
#include "volcast/net/protocol/protocol.hpp"
#include "wire_fields.hpp"

namespace volcast::session {
using fields::decode;
using fields::encode;
using fields::Fields;
using fields::In;
using fields::Of;
using wire::Reader;
using wire::Writer;

const char* to_string(Role role) {
  return role == Role::kOrSite ? "OR site" : "remote";
}

const char* to_string(LeftReason reason) {
  switch (reason) {
    case LeftReason::kLeft:
      return "left";
    case LeftReason::kTimedOut:
      return "timed out";
    case LeftReason::kDisconnected:
      return "disconnected";
    case LeftReason::kDropped:
      return "dropped for a bad message";
  }
  return "?";
}

RigidTransform room_from_playarea(const Spot& spot) {
  RigidTransform t;
  t.rotation = Eigen::AngleAxisd(spot.yaw, Eigen::Vector3d::UnitY()).toRotationMatrix();
  t.translation = {spot.x, 0, spot.z};
  return t;
}

std::vector<uint8_t> message(Type type, std::span<const uint8_t> payload) {
  std::vector<uint8_t> out(protocol::kHeaderBytes + payload.size());
  protocol::write_header(static_cast<protocol::MessageType>(0x0200 | static_cast<uint8_t>(type)),
                         static_cast<uint32_t>(payload.size()), out.data());
  if (!payload.empty())
    std::memcpy(out.data() + protocol::kHeaderBytes, payload.data(), payload.size());
  return out;
}

// ---- Each message's layout once (wire_fields.hpp), then its encoder and decoder ----------------

template <typename Io, Of<Join> M>
void layout(Io& io, M& m) {
  io.name(m.session, "session_name");
  io.flag(m.create, "create");
  io.name(m.name, "display_name");
  io.enumeration(m.role, 1, "role");
  io.flag(m.has_camera, "has_camera");
  if (io.tail(m.rejoin_key[0] != 0 || m.rejoin_key[1] != 0)) {
    io.number(m.rejoin_key[0], "rejoin_key_low");
    io.number(m.rejoin_key[1], "rejoin_key_high");
    io.check(m.rejoin_key[0] != 0 || m.rejoin_key[1] != 0, "a rejoin key is all zero");
  }
}

template <typename Io, Of<Joined> M>
void layout(Io& io, M& m) {
  io.number(m.participant, "participant");
  io.number(m.session, "session");
  io.name(m.session_name, "session_name");
  io.spot(m.spot, "spot");
  io.vec3(m.site_translation, "site_translation");
  io.finite(m.site_yaw, "site_yaw");
}

template <typename Io, Of<ParticipantInfo> M>
void layout(Io& io, M& m) {
  io.number(m.id, "id");
  io.name(m.name, "display_name");
  io.enumeration(m.role, 1, "role");
  io.flag(m.has_camera, "has_camera");
  io.spot(m.spot, "spot");
}

template <typename Io, Of<PoseMessage> M>
void layout(Io& io, M& m) {
  io.number(m.sequence, "sequence");
  io.number(m.time_us, "time_us");
  io.flag(m.echo_wanted, "echo_wanted");
  io.flag(m.body.hands_tracked, "hands_tracked", "unknown body flags");
  io.pose(m.body.head, "head");
  io.pose(m.body.left_hand, "left_hand");
  io.pose(m.body.right_hand, "right_hand");
}

template <typename Io, Of<Spot> M>
void layout(Io& io, M& m) {
  io.spot(m, "spot");
}

template <typename Io, Of<Teleported> M>
void layout(Io& io, M& m) {
  io.number(m.participant, "participant");
  io.spot(m.from, "from");
  io.spot(m.to, "to");
  io.number(m.time_us, "time_us");
}

template <typename Io, Of<RecordingState> M>
void layout(Io& io, M& m) {
  io.flag(m.recording, "recording");
  io.number(m.since_us, "since_us");
  io.string(m.by, "by");
  io.check(m.by.size() <= kMaxRecorderBytes, "who records is longer than 200 bytes");
  io.check(
      std::none_of(m.by.begin(), m.by.end(), [](unsigned char c) { return c < 0x20 || c == 0x7f; }),
      "who records has a control character");
  io.check(m.recording == (m.since_us != 0), "a recording's start is 0, or a stop has one");
}

template <typename Io, Of<AvatarFrameView> M>
void layout(Io& io, M& m) {
  io.number(m.sequence, "sequence");
  io.number(m.capture_us, "capture_us");
  io.bytes(m.depth, "depth");
  io.bytes(m.color, "color");
}

namespace {

struct Left {
  uint32_t participant = 0;
  LeftReason reason{};
};

template <typename Io, Of<Left> M>
void layout(Io& io, M& m) {
  io.number(m.participant, "participant");
  io.enumeration(m.reason, 3, "reason");
}

struct Echo {
  uint32_t participant = 0, sequence = 0;
};

template <typename Io, Of<Echo> M>
void layout(Io& io, M& m) {
  io.number(m.participant, "participant");
  io.number(m.sequence, "sequence");
}

struct SessionList {
  std::vector<SessionSummary> sessions;
};

// Each session: id, name, participants (clamped to u16).
const auto kSummary = [](auto& io, auto& s) {
  io.number(s.id, "id");
  io.name(s.name, "session_name");
  io.template number_as<uint16_t>(s.participants, "participants");
};

template <typename Io, Of<SessionList> M>
void layout(Io& io, M& m) {
  io.list(m.sessions, kMaxListedSessions, 8, "sessions", kSummary);
}

struct SessionError {
  std::string reason;
};

template <typename Io, Of<SessionError> M>
void layout(Io& io, M& m) {
  io.string(m.reason, "reason");
}

struct Empty {};

template <typename Io, Of<Empty> M>
void layout(Io&, M&) {}

}  // namespace

std::vector<uint8_t> serialize(const Join& m) {
  return encode(m);
}

Join parse_join(std::span<const uint8_t> p) {
  return decode<Join>(p, "join");
}

std::vector<uint8_t> serialize(const std::vector<SessionSummary>& m) {
  return encode(SessionList{{m.begin(), m.begin() + std::min(m.size(), kMaxListedSessions)}});
}

std::vector<SessionSummary> parse_session_list(std::span<const uint8_t> p) {
  return decode<SessionList>(p, "session list").sessions;
}

std::vector<uint8_t> serialize(const Joined& m) {
  return encode(m);
}

Joined parse_joined(std::span<const uint8_t> p) {
  return decode<Joined>(p, "joined");
}

std::vector<uint8_t> serialize_error(const std::string& reason) {
  return encode(SessionError{reason.substr(0, 1024)});
}

std::string parse_error(std::span<const uint8_t> p) {
  return decode<SessionError>(p, "session error").reason;
}

std::vector<uint8_t> serialize(const ParticipantInfo& m) {
  return encode(m);
}

ParticipantInfo parse_participant(std::span<const uint8_t> p) {
  return decode<ParticipantInfo>(p, "participant joined");
}

std::vector<uint8_t> serialize_left(uint32_t participant, LeftReason reason) {
  return encode(Left{participant, reason});
}

std::pair<uint32_t, LeftReason> parse_left(std::span<const uint8_t> p) {
  const Left m = decode<Left>(p, "participant left");
  return {m.participant, m.reason};
}

std::vector<uint8_t> serialize(const PoseMessage& m) {
  return encode(m, Fields{}, 4 + 8 + 1 + 1 + 3 * 28);
}

PoseMessage parse_pose(std::span<const uint8_t> p) {
  return decode<PoseMessage>(p, "pose");
}

std::vector<uint8_t> serialize_echo(uint32_t participant, uint32_t sequence) {
  return encode(Echo{participant, sequence});
}

std::pair<uint32_t, uint32_t> parse_echo(std::span<const uint8_t> p) {
  const Echo m = decode<Echo>(p, "pose echo");
  return {m.participant, m.sequence};
}

std::vector<uint8_t> serialize(const Spot& m) {
  return encode(m);
}

Spot parse_teleport(std::span<const uint8_t> p) {
  return decode<Spot>(p, "teleport");
}

std::vector<uint8_t> serialize(const Teleported& m) {
  return encode(m);
}

Teleported parse_teleported(std::span<const uint8_t> p) {
  return decode<Teleported>(p, "teleported");
}

std::vector<uint8_t> serialize(const RecordingState& m) {
  return encode(m);
}

RecordingState parse_recording_state(std::span<const uint8_t> p) {
  return decode<RecordingState>(p, "recording state");
}

std::vector<uint8_t> serialize(const AvatarCamera& m) {
  std::vector<uint8_t> out;
  Writer w(out);
  protocol::put_calibration(w, m.calibration);
  w.put_string(m.depth_codec);
  w.put_string(m.color_codec);
  return out;
}

AvatarCamera parse_avatar_camera(std::span<const uint8_t> p) {
  Reader r(p, "avatar camera");
  AvatarCamera m;
  m.calibration = protocol::get_calibration(r);
  const Intrinsics& k = m.calibration.depth;
  if (k.width > kMaxAvatarSide || k.height > kMaxAvatarSide)
    r.fail("image size " + std::to_string(k.width) + "x" + std::to_string(k.height) + " exceeds " +
           std::to_string(kMaxAvatarSide) + " pixels per side");
  m.depth_codec = r.get_string();
  m.color_codec = r.get_string();
  r.expect_end();
  const DepthCodecInfo* d = find_depth_codec(m.depth_codec);
  const ColorCodecInfo* c = find_color_codec(m.color_codec);
  if (!d || !d->lossless || d->temporal)
    r.fail("depth codec '" + m.depth_codec.substr(0, 32) +
           "' is not a lossless, non-temporal codec of this build");
  if (!c || c->temporal)
    r.fail("color codec '" + m.color_codec.substr(0, 32) +
           "' is not a non-temporal codec of this build");
  return m;
}

std::vector<uint8_t> serialize_avatar_frame(uint64_t sequence, int64_t capture_us,
                                            std::span<const uint8_t> depth,
                                            std::span<const uint8_t> color) {
  return encode(AvatarFrameView{sequence, capture_us, depth, color}, Fields{},
                8 + 8 + 8 + depth.size() + color.size());
}

uint32_t avatar_frame_limit(const CameraCalibration& camera) {
  const uint64_t pixels =
      uint64_t(std::max(camera.depth.width, 0)) * uint64_t(std::max(camera.depth.height, 0));
  return static_cast<uint32_t>(std::min<uint64_t>(
      kMaxAvatarBytesPerPixel * pixels + kMaxAvatarFrameOverhead, kMaxAvatarFrameBytes));
}

AvatarFrameView parse_avatar_frame(std::span<const uint8_t> p, const CameraCalibration& camera) {
  if (p.size() > avatar_frame_limit(camera))
    Reader(p, "avatar frame")
        .fail(std::to_string(p.size()) + " bytes exceed the limit of " +
              std::to_string(avatar_frame_limit(camera)) + " for its camera");
  return decode<AvatarFrameView>(p, "avatar frame");
}

std::vector<uint8_t> forward(Type type, uint32_t participant, std::span<const uint8_t> payload) {
  std::vector<uint8_t> out(protocol::kHeaderBytes + 4 + payload.size());
  protocol::write_header(static_cast<protocol::MessageType>(0x0200 | static_cast<uint8_t>(type)),
                         static_cast<uint32_t>(4 + payload.size()), out.data());
  wire::store<uint32_t>(out.data() + protocol::kHeaderBytes, participant);
  if (!payload.empty())
    std::memcpy(out.data() + protocol::kHeaderBytes + 4, payload.data(), payload.size());
  return out;
}

bool describe_presence(Type type, std::vector<LayoutField>& out) {
  using fields::describe;
  using fields::forwarded;
  switch (type) {
    case Type::kListSessions:
    case Type::kLeave:
    case Type::kHeartbeat:
      out = describe<Empty>();
      return true;
    case Type::kJoin:
      out = describe<Join>();
      return true;
    case Type::kPose:
      out = describe<PoseMessage>();
      return true;
    case Type::kPoseEcho:
    case Type::kPoseEchoFrom:
      out = describe<Echo>();
      return true;
    case Type::kTeleport:
      out = describe<Spot>();
      return true;
    case Type::kSessionList:
      out = describe<SessionList>();
      return true;
    case Type::kJoined:
      out = describe<Joined>();
      return true;
    case Type::kSessionError:
      out = describe<SessionError>();
      return true;
    case Type::kParticipantJoined:
      out = describe<ParticipantInfo>();
      return true;
    case Type::kParticipantLeft:
      out = describe<Left>();
      return true;
    case Type::kPoseFrom:
      out = forwarded(describe<PoseMessage>());
      return true;
    case Type::kTeleported:
      out = describe<Teleported>();
      return true;
    case Type::kRecordingState:
      out = describe<RecordingState>();
      return true;
    default:
      return false;
  }
}

std::pair<uint32_t, std::span<const uint8_t>> split_forwarded(std::span<const uint8_t> p) {
  if (p.size() < 4) throw Error("malformed forwarded session message: truncated");
  return {wire::load<uint32_t>(p.data()), p.subspan(4)};
}

}  // namespace volcast::session
