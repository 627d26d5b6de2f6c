#include "volcast/net/protocol/protocol.hpp"

#include <algorithm>
#include <cmath>
#include <cstring>

#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/net/protocol/calibration_wire.hpp"

namespace volcast::protocol {
using wire::Reader;
using wire::Writer;

void put_calibration(Writer& w, const CameraCalibration& c) {
  const Intrinsics& k = c.depth;
  w.put<uint16_t>(static_cast<uint16_t>(k.width));
  w.put<uint16_t>(static_cast<uint16_t>(k.height));
  for (double v : {k.fx, k.fy, k.cx, k.cy, k.k1, k.k2, k.k3, k.k4, k.k5, k.k6, k.p1, k.p2, k.codx,
                   k.cody, k.metric_radius})
    w.put<double>(v);
  const RigidTransform& t = c.world_from_camera;
  for (int i = 0; i < 9; ++i) w.put<double>(t.rotation(i / 3, i % 3));
  for (int i = 0; i < 3; ++i) w.put<double>(t.translation[i]);
}

CameraCalibration get_calibration(Reader& r) {
  CameraCalibration c;
  Intrinsics& k = c.depth;
  k.width = r.get<uint16_t>();
  k.height = r.get<uint16_t>();
  if (k.width == 0 || k.height == 0) r.fail("empty image size");
  for (double* v : {&k.fx, &k.fy, &k.cx, &k.cy, &k.k1, &k.k2, &k.k3, &k.k4, &k.k5, &k.k6, &k.p1,
                    &k.p2, &k.codx, &k.cody, &k.metric_radius}) {
    *v = r.get<double>();
    if (!std::isfinite(*v)) r.fail("intrinsics must be finite");
  }
  if (!(k.fx > 0 && k.fy > 0)) r.fail("focal length must be positive");
  RigidTransform& t = c.world_from_camera;
  for (int i = 0; i < 9; ++i) t.rotation(i / 3, i % 3) = r.get<double>();
  for (int i = 0; i < 3; ++i) t.translation[i] = r.get<double>();
  if (!t.rotation.allFinite() || !t.translation.allFinite() ||
      !(t.rotation * t.rotation.transpose()).isIdentity(1e-3) || t.rotation.determinant() < 0)
    r.fail("the camera's pose is not a rigid transform");
  return c;
}

void write_header(MessageType type, uint32_t payload_bytes, uint8_t out[kHeaderBytes]) {
  const uint16_t t = static_cast<uint16_t>(type);
  wire::store<uint32_t>(out, kMagic);
  wire::store<uint16_t>(out + 4, kVersion);
  out[6] = static_cast<uint8_t>(t >> 8);    // channel
  out[7] = static_cast<uint8_t>(t & 0xff);  // type within the channel
  wire::store<uint32_t>(out + 8, payload_bytes);
}

Header parse_header(std::span<const uint8_t> bytes, uint32_t max_payload) {
  if (bytes.size() < kHeaderBytes) throw Error("malformed header: truncated");
  Header h;
  const uint32_t magic = wire::load<uint32_t>(bytes.data());
  h.version = wire::load<uint16_t>(bytes.data() + 4);
  const uint8_t channel = bytes[6], type = bytes[7];
  h.payload_bytes = wire::load<uint32_t>(bytes.data() + 8);
  if (magic != kMagic) throw Error("malformed header: bad magic (not a Volcast peer)");
  if (h.version != kVersion)
    throw Error("protocol version mismatch: peer speaks " + std::to_string(h.version) +
                ", this build speaks " + std::to_string(kVersion));
  const bool known = (channel == 0 && type >= 1 && type <= 6) ||
                     (channel == 1 && (type == 1 || type == 2)) ||
                     channel == static_cast<uint8_t>(Channel::kSession);
  if (!known)
    throw Error("malformed header: unknown message type " + std::to_string(channel) + "." +
                std::to_string(type));
  h.channel = static_cast<Channel>(channel);
  h.type = static_cast<MessageType>(channel << 8 | type);
  if (h.payload_bytes > max_payload)
    throw Error("malformed header: payload of " + std::to_string(h.payload_bytes) +
                " bytes exceeds the limit of " + std::to_string(max_payload));
  return h;
}

std::vector<uint8_t> serialize(const Hello& m) {
  std::vector<uint8_t> out;
  Writer w(out);
  w.append(m.token.data(), m.token.size());
  w.put_string(m.tier.depth_codec);
  w.put_string(m.tier.color_codec);
  w.put<uint8_t>(static_cast<uint8_t>(m.tier.color_quality));
  if (m.adapt != 0 || m.max_bits_per_s != 0 || !m.decodes.empty()) {
    w.put<uint8_t>(m.adapt);
    w.put<uint64_t>(m.max_bits_per_s);
  }
  if (!m.decodes.empty()) {
    w.put<uint8_t>(static_cast<uint8_t>(m.decodes.size()));
    for (const std::string& c : m.decodes) w.put_string(c);
  }
  return out;
}

std::span<const uint8_t, kTokenBytes> hello_token(std::span<const uint8_t> payload) {
  if (payload.size() < kTokenBytes) throw Error("malformed hello: truncated");
  return payload.first<kTokenBytes>();
}

Hello parse_hello(std::span<const uint8_t> payload) {
  Reader r(payload, "hello");
  Hello h;
  for (uint8_t& b : h.token) b = r.get<uint8_t>();
  h.tier.depth_codec = r.get_string();
  h.tier.color_codec = r.get_string();
  h.tier.color_quality = r.get<uint8_t>();
  if (h.tier.color_quality > 100)
    r.fail("color quality " + std::to_string(h.tier.color_quality) + " > 100");
  if (r.remaining() > 0) {
    h.adapt = r.get<uint8_t>("adaptation flags");
    constexpr uint8_t kKnown =
        Hello::kAdapt | Hello::kKeepLossless | Hello::kKeepFullRate | Hello::kNotify;
    if (h.adapt & ~kKnown) r.fail("unknown adaptation flags " + std::to_string(h.adapt));
    h.max_bits_per_s = r.get<uint64_t>("max rate");
  }
  if (r.remaining() > 0) {
    const uint8_t n = r.get<uint8_t>("codec count");
    if (n == 0 || n > kMaxDecodableCodecs)
      r.fail("codec count " + std::to_string(n) + " (1 to " + std::to_string(kMaxDecodableCodecs) +
             ")");
    for (uint8_t i = 0; i < n; ++i) {
      std::string c = r.get_string("codec name");
      if (c.empty() || c.size() > 32)
        r.fail("a codec name of " + std::to_string(c.size()) + " bytes");
      h.decodes.push_back(std::move(c));
    }
  }
  r.expect_end();
  return h;
}

std::vector<uint8_t> serialize(const Welcome& m) {
  std::vector<uint8_t> out;
  Writer w(out);
  w.put<uint32_t>(static_cast<uint32_t>(m.cameras.size()));
  for (const CameraInfo& cam : m.cameras) {
    put_calibration(w, cam.calibration);
    w.put_string(cam.description);
  }
  w.put<int64_t>(m.server_time_us);
  return out;
}

Welcome parse_welcome(std::span<const uint8_t> payload) {
  Reader r(payload, "welcome");
  Welcome m;
  const uint32_t n = r.get<uint32_t>();
  if (n == 0 || n > kMaxCameras)
    r.fail("camera count " + std::to_string(n) + " (1 to " + std::to_string(kMaxCameras) + ")");
  m.cameras.resize(n);
  uint64_t pixels = 0;
  for (size_t c = 0; c < n; ++c) {
    CameraInfo& cam = m.cameras[c];
    Intrinsics& k = cam.calibration.depth;
    k.width = r.get<uint16_t>();
    k.height = r.get<uint16_t>();
    const std::string size = std::to_string(k.width) + "x" + std::to_string(k.height);
    if (k.width == 0 || k.height == 0) r.fail("camera " + std::to_string(c) + ": empty image size");
    if (k.width > kMaxCameraSide || k.height > kMaxCameraSide)
      r.fail("camera " + std::to_string(c) + ": image size " + size + " exceeds " +
             std::to_string(kMaxCameraSide) + " pixels per side");
    pixels += static_cast<uint64_t>(k.width) * static_cast<uint64_t>(k.height);
    if (pixels > kMaxSitePixels)
      r.fail("the cameras up to camera " + std::to_string(c) + " (" + size + ") have " +
             std::to_string(pixels) + " pixels, more than the limit of " +
             std::to_string(kMaxSitePixels));
    for (double* v : {&k.fx, &k.fy, &k.cx, &k.cy, &k.k1, &k.k2, &k.k3, &k.k4, &k.k5, &k.k6, &k.p1,
                      &k.p2, &k.codx, &k.cody, &k.metric_radius})
      *v = r.get<double>();
    if (!(k.fx > 0 && k.fy > 0)) r.fail("focal length must be positive");
    RigidTransform& t = cam.calibration.world_from_camera;
    for (int i = 0; i < 9; ++i) t.rotation(i / 3, i % 3) = r.get<double>();
    for (int i = 0; i < 3; ++i) t.translation[i] = r.get<double>();
    cam.description = r.get_string();
  }
  m.server_time_us = r.get<int64_t>();
  r.expect_end();
  return m;
}

uint32_t frame_set_payload_limit(const Welcome& welcome) {
  // send time, sequence, flags, capture / filter / encode times, camera count
  uint64_t bytes = 8 + 8 + 1 + 8 + 8 + 8 + 4;
  for (const CameraInfo& cam : welcome.cameras) {
    const Intrinsics& k = cam.calibration.depth;
    const uint64_t pixels =
        static_cast<uint64_t>(std::max(k.width, 0)) * static_cast<uint64_t>(std::max(k.height, 0));
    bytes += 8 + 4 + 4 + kFrameSetCameraOverhead + kFrameSetBytesPerPixel * pixels;
  }
  return static_cast<uint32_t>(std::min<uint64_t>(bytes, kMaxPayloadBytes));
}

std::vector<uint8_t> serialize_ack(uint64_t sequence) {
  std::vector<uint8_t> out;
  Writer(out).put<uint64_t>(sequence);
  return out;
}

std::array<uint8_t, kHeaderBytes + 8> ack_message(uint64_t sequence) {
  std::array<uint8_t, kHeaderBytes + 8> out;
  write_header(MessageType::kAck, 8, out.data());
  wire::store<uint64_t>(out.data() + kHeaderBytes, sequence);
  return out;
}

uint64_t parse_ack(std::span<const uint8_t> payload) {
  Reader r(payload, "ack");
  const uint64_t sequence = r.get<uint64_t>();
  r.expect_end();
  return sequence;
}

std::vector<uint8_t> serialize_reject(const std::string& reason) {
  std::vector<uint8_t> out;
  Writer(out).put_string(reason);
  return out;
}

std::string parse_reject(std::span<const uint8_t> payload) {
  Reader r(payload, "reject");
  std::string s = r.get_string();
  r.expect_end();
  return s;
}

std::vector<uint8_t> message(MessageType type, const std::vector<uint8_t>& payload) {
  std::vector<uint8_t> out(kHeaderBytes);
  write_header(type, static_cast<uint32_t>(payload.size()), out.data());
  out.insert(out.end(), payload.begin(), payload.end());
  return out;
}

std::vector<uint8_t> serialize(const TierChange& m) {
  std::vector<uint8_t> out;
  Writer w(out);
  w.put_string(m.tier.depth_codec);
  w.put_string(m.tier.color_codec);
  w.put<uint8_t>(static_cast<uint8_t>(m.tier.color_quality));
  w.put<uint8_t>(static_cast<uint8_t>(m.tier.frame_divisor));
  w.put<uint32_t>(m.path_kbit_s);
  w.put_string(m.reason.size() > kMaxReasonBytes ? m.reason.substr(0, kMaxReasonBytes) : m.reason);
  return out;
}

TierChange parse_tier_change(std::span<const uint8_t> payload) {
  Reader r(payload, "tier change");
  TierChange m;
  m.tier.depth_codec = r.get_string("depth codec");
  m.tier.color_codec = r.get_string("color codec");
  m.tier.color_quality = r.get<uint8_t>("color quality");
  if (m.tier.color_quality > 100)
    r.fail("color quality " + std::to_string(m.tier.color_quality) + " > 100");
  m.tier.frame_divisor = r.get<uint8_t>("frame divisor");
  if (m.tier.frame_divisor < 1 || m.tier.frame_divisor > 8)
    r.fail("frame divisor " + std::to_string(m.tier.frame_divisor) + " (1 to 8)");
  m.path_kbit_s = r.get<uint32_t>("path rate");
  m.reason = r.get_string("reason");
  if (m.reason.size() > kMaxReasonBytes) r.fail("reason longer than 400 bytes");
  r.expect_end();
  return m;
}

}  // namespace volcast::protocol
