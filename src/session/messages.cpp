#include "volcast/session/messages.hpp"

#include <cmath>

#include "volcast/codec/registry.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/net/calibration_wire.hpp"
#include "volcast/net/protocol.hpp"
#include "volcast/session/objects.hpp"
#include "wire_fields.hpp"

namespace volcast::session {
using wire::Reader;
using wire::Writer;
using namespace fields;

uint32_t max_payload(uint8_t type) {
  switch (static_cast<Type>(type)) {
    case Type::kListSessions:
    case Type::kJoin:
    case Type::kLeave:
    case Type::kPose:
    case Type::kPoseEcho:
    case Type::kTeleport:
    case Type::kAvatarCamera:
    case Type::kHeartbeat:
    case Type::kSessionList:
    case Type::kJoined:
    case Type::kSessionError:
    case Type::kParticipantJoined:
    case Type::kParticipantLeft:
    case Type::kPoseFrom:
    case Type::kPoseEchoFrom:
    case Type::kTeleported:
    case Type::kAvatarCameraFrom:
    case Type::kGrab:
    case Type::kObjectMove:
    case Type::kRelease:
    case Type::kSetMonitor:
    case Type::kObjectState:
    case Type::kMonitorState:
      return kMaxSessionMessageBytes;
    case Type::kCase:
      return kMaxCaseBytes;
    case Type::kAvatarFrame:
      return kMaxAvatarFrameBytes;
    case Type::kAvatarFrameFrom:
      return kMaxAvatarFrameBytes + 4;
  }
  return 0;
}

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

std::vector<uint8_t> serialize(const Join& m) {
  std::vector<uint8_t> out;
  Writer w(out);
  w.put_string(m.session);
  w.put<uint8_t>(m.create);
  w.put_string(m.name);
  w.put<uint8_t>(static_cast<uint8_t>(m.role));
  w.put<uint8_t>(m.has_camera);
  return out;
}

Join parse_join(std::span<const uint8_t> p) {
  Reader r(p, "join");
  Join m;
  m.session = get_name(r, "session name");
  m.create = get_flag(r);
  m.name = get_name(r, "display name");
  m.role = checked_enum<Role>(r, 1, "role");
  m.has_camera = get_flag(r);
  r.expect_end();
  return m;
}

std::vector<uint8_t> serialize(const std::vector<SessionSummary>& m) {
  std::vector<uint8_t> out;
  Writer w(out);
  const size_t n = std::min(m.size(), kMaxListedSessions);
  w.put<uint16_t>(static_cast<uint16_t>(n));
  for (size_t i = 0; i < n; ++i) {
    w.put<uint32_t>(m[i].id);
    w.put_string(m[i].name);
    w.put<uint16_t>(static_cast<uint16_t>(std::min<uint32_t>(m[i].participants, 0xffff)));
  }
  return out;
}

std::vector<SessionSummary> parse_session_list(std::span<const uint8_t> p) {
  Reader r(p, "session list");
  const uint16_t n = r.get<uint16_t>();
  if (n > kMaxListedSessions)
    r.fail("more than " + std::to_string(kMaxListedSessions) + " sessions");
  std::vector<SessionSummary> out(n);
  for (auto& s : out) {
    s.id = r.get<uint32_t>();
    s.name = get_name(r, "session name");
    s.participants = r.get<uint16_t>();
  }
  r.expect_end();
  return out;
}

std::vector<uint8_t> serialize(const Joined& m) {
  std::vector<uint8_t> out;
  Writer w(out);
  w.put<uint32_t>(m.participant);
  w.put<uint32_t>(m.session);
  w.put_string(m.session_name);
  put_spot(w, m.spot);
  for (int i = 0; i < 3; ++i) w.put<float>(m.site_translation[i]);
  w.put<float>(m.site_yaw);
  return out;
}

Joined parse_joined(std::span<const uint8_t> p) {
  Reader r(p, "joined");
  Joined m;
  m.participant = r.get<uint32_t>();
  m.session = r.get<uint32_t>();
  m.session_name = get_name(r, "session name");
  m.spot = get_spot(r);
  for (int i = 0; i < 3; ++i) m.site_translation[i] = get_finite(r);
  m.site_yaw = get_finite(r);
  r.expect_end();
  return m;
}

std::vector<uint8_t> serialize_error(const std::string& reason) {
  std::vector<uint8_t> out;
  Writer(out).put_string(reason.substr(0, 1024));
  return out;
}

std::string parse_error(std::span<const uint8_t> p) {
  Reader r(p, "session error");
  std::string s = r.get_string();
  r.expect_end();
  return s;
}

std::vector<uint8_t> serialize(const ParticipantInfo& m) {
  std::vector<uint8_t> out;
  Writer w(out);
  w.put<uint32_t>(m.id);
  w.put_string(m.name);
  w.put<uint8_t>(static_cast<uint8_t>(m.role));
  w.put<uint8_t>(m.has_camera);
  put_spot(w, m.spot);
  return out;
}

ParticipantInfo parse_participant(std::span<const uint8_t> p) {
  Reader r(p, "participant joined");
  ParticipantInfo m;
  m.id = r.get<uint32_t>();
  m.name = get_name(r, "display name");
  m.role = checked_enum<Role>(r, 1, "role");
  m.has_camera = get_flag(r);
  m.spot = get_spot(r);
  r.expect_end();
  return m;
}

std::vector<uint8_t> serialize_left(uint32_t participant, LeftReason reason) {
  std::vector<uint8_t> out;
  Writer w(out);
  w.put<uint32_t>(participant);
  w.put<uint8_t>(static_cast<uint8_t>(reason));
  return out;
}

std::pair<uint32_t, LeftReason> parse_left(std::span<const uint8_t> p) {
  Reader r(p, "participant left");
  const uint32_t id = r.get<uint32_t>();
  const LeftReason why = checked_enum<LeftReason>(r, 3, "reason");
  r.expect_end();
  return {id, why};
}

std::vector<uint8_t> serialize(const PoseMessage& m) {
  std::vector<uint8_t> out;
  out.reserve(4 + 8 + 1 + 1 + 3 * 28);
  Writer w(out);
  w.put<uint32_t>(m.sequence);
  w.put<int64_t>(m.time_us);
  w.put<uint8_t>(m.echo_wanted);
  w.put<uint8_t>(m.body.hands_tracked ? 1 : 0);
  put_pose(w, m.body.head);
  put_pose(w, m.body.left_hand);
  put_pose(w, m.body.right_hand);
  return out;
}

PoseMessage parse_pose(std::span<const uint8_t> p) {
  Reader r(p, "pose");
  PoseMessage m;
  m.sequence = r.get<uint32_t>();
  m.time_us = r.get<int64_t>();
  m.echo_wanted = get_flag(r);
  const uint8_t flags = r.get<uint8_t>();
  if (flags > 1) r.fail("unknown body flags");
  m.body.hands_tracked = flags & 1;
  m.body.head = get_pose(r);
  m.body.left_hand = get_pose(r);
  m.body.right_hand = get_pose(r);
  r.expect_end();
  return m;
}

std::vector<uint8_t> serialize_echo(uint32_t participant, uint32_t sequence) {
  std::vector<uint8_t> out;
  Writer w(out);
  w.put<uint32_t>(participant);
  w.put<uint32_t>(sequence);
  return out;
}

std::pair<uint32_t, uint32_t> parse_echo(std::span<const uint8_t> p) {
  Reader r(p, "pose echo");
  const uint32_t a = r.get<uint32_t>(), b = r.get<uint32_t>();
  r.expect_end();
  return {a, b};
}

std::vector<uint8_t> serialize(const Spot& m) {
  std::vector<uint8_t> out;
  Writer w(out);
  put_spot(w, m);
  return out;
}

Spot parse_teleport(std::span<const uint8_t> p) {
  Reader r(p, "teleport");
  const Spot s = get_spot(r);
  r.expect_end();
  return s;
}

std::vector<uint8_t> serialize(const Teleported& m) {
  std::vector<uint8_t> out;
  Writer w(out);
  w.put<uint32_t>(m.participant);
  put_spot(w, m.from);
  put_spot(w, m.to);
  w.put<int64_t>(m.time_us);
  return out;
}

Teleported parse_teleported(std::span<const uint8_t> p) {
  Reader r(p, "teleported");
  Teleported m;
  m.participant = r.get<uint32_t>();
  m.from = get_spot(r);
  m.to = get_spot(r);
  m.time_us = r.get<int64_t>();
  r.expect_end();
  return m;
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
  std::vector<uint8_t> out;
  out.reserve(8 + 8 + 8 + depth.size() + color.size());
  Writer w(out);
  w.put<uint64_t>(sequence);
  w.put<int64_t>(capture_us);
  w.put_bytes(depth);
  w.put_bytes(color);
  return out;
}

uint32_t avatar_frame_limit(const CameraCalibration& camera) {
  const uint64_t pixels =
      uint64_t(std::max(camera.depth.width, 0)) * uint64_t(std::max(camera.depth.height, 0));
  return static_cast<uint32_t>(std::min<uint64_t>(
      kMaxAvatarBytesPerPixel * pixels + kMaxAvatarFrameOverhead, kMaxAvatarFrameBytes));
}

AvatarFrameView parse_avatar_frame(std::span<const uint8_t> p, const CameraCalibration& camera) {
  Reader r(p, "avatar frame");
  if (p.size() > avatar_frame_limit(camera))
    r.fail(std::to_string(p.size()) + " bytes exceed the limit of " +
           std::to_string(avatar_frame_limit(camera)) + " for its camera");
  AvatarFrameView m;
  m.sequence = r.get<uint64_t>();
  m.capture_us = r.get<int64_t>();
  m.depth = r.get_span();
  m.color = r.get_span();
  r.expect_end();
  return m;
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

std::pair<uint32_t, std::span<const uint8_t>> split_forwarded(std::span<const uint8_t> p) {
  if (p.size() < 4) throw Error("malformed forwarded session message: truncated");
  return {wire::load<uint32_t>(p.data()), p.subspan(4)};
}

}  // namespace volcast::session
