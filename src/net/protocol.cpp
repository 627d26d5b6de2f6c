#include "volcast/net/protocol.hpp"

#include <cstring>

#include "volcast/core/error.hpp"

namespace volcast::protocol {
namespace {

class Writer {
 public:
  explicit Writer(std::vector<uint8_t>& out) : out_(out) {}
  template <typename T>
  void put(T v) {
    append(&v, sizeof(T));  // host is little-endian (x86-64, ARM64 Linux)
  }
  void put_string(const std::string& s) {
    if (s.size() > 0xffff) throw Error("protocol: string too long");
    put<uint16_t>(static_cast<uint16_t>(s.size()));
    append(s.data(), s.size());
  }
  void put_bytes(const std::vector<uint8_t>& b) {
    put<uint32_t>(static_cast<uint32_t>(b.size()));
    append(b.data(), b.size());
  }
  void append(const void* data, size_t n) {
    if (n == 0) return;
    const size_t at = out_.size();
    out_.resize(at + n);
    std::memcpy(out_.data() + at, data, n);
  }

 private:
  std::vector<uint8_t>& out_;
};

class Reader {
 public:
  Reader(std::span<const uint8_t> in, const char* what) : in_(in), what_(what) {}
  template <typename T>
  T get() {
    need(sizeof(T));
    T v;
    std::memcpy(&v, in_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::string get_string() {
    const size_t n = get<uint16_t>();
    need(n);
    std::string s(reinterpret_cast<const char*>(in_.data() + pos_), n);
    pos_ += n;
    return s;
  }
  void get_bytes(std::vector<uint8_t>& out) {
    const size_t n = get<uint32_t>();
    need(n);
    out.assign(in_.data() + pos_, in_.data() + pos_ + n);
    pos_ += n;
  }
  void expect_end() const {
    if (pos_ != in_.size()) fail("trailing bytes");
  }
  [[noreturn]] void fail(const std::string& why) const {
    throw Error(std::string("malformed ") + what_ + ": " + why);
  }

 private:
  void need(size_t n) const {
    if (n > in_.size() - pos_) fail("truncated");
  }
  std::span<const uint8_t> in_;
  size_t pos_ = 0;
  const char* what_;
};

}  // namespace

void write_header(MessageType type, uint32_t payload_bytes, uint8_t out[kHeaderBytes]) {
  const uint16_t t = static_cast<uint16_t>(type);
  std::memcpy(out, &kMagic, 4);
  std::memcpy(out + 4, &kVersion, 2);
  std::memcpy(out + 6, &t, 2);
  std::memcpy(out + 8, &payload_bytes, 4);
}

Header parse_header(std::span<const uint8_t> bytes, uint32_t max_payload) {
  if (bytes.size() < kHeaderBytes) throw Error("malformed header: truncated");
  uint32_t magic;
  uint16_t type;
  Header h;
  std::memcpy(&magic, bytes.data(), 4);
  std::memcpy(&h.version, bytes.data() + 4, 2);
  std::memcpy(&type, bytes.data() + 6, 2);
  std::memcpy(&h.payload_bytes, bytes.data() + 8, 4);
  if (magic != kMagic) throw Error("malformed header: bad magic (not a Volcast peer)");
  if (h.version != kVersion)
    throw Error("protocol version mismatch: peer speaks " + std::to_string(h.version) +
                ", this build speaks " + std::to_string(kVersion));
  if (type < 1 || type > 5)
    throw Error("malformed header: unknown message type " + std::to_string(type));
  h.type = static_cast<MessageType>(type);
  if (h.payload_bytes > max_payload)
    throw Error("malformed header: payload of " + std::to_string(h.payload_bytes) +
                " bytes exceeds the limit of " + std::to_string(max_payload));
  return h;
}

std::vector<uint8_t> serialize(const Hello& m) {
  std::vector<uint8_t> out;
  Writer w(out);
  w.put_string(m.depth_codec);
  w.put_string(m.color_codec);
  return out;
}

Hello parse_hello(std::span<const uint8_t> payload) {
  Reader r(payload, "hello");
  Hello h;
  h.depth_codec = r.get_string();
  h.color_codec = r.get_string();
  r.expect_end();
  return h;
}

std::vector<uint8_t> serialize(const Welcome& m) {
  std::vector<uint8_t> out;
  Writer w(out);
  w.put<uint32_t>(static_cast<uint32_t>(m.cameras.size()));
  for (const CameraInfo& cam : m.cameras) {
    const Intrinsics& k = cam.calibration.depth;
    w.put<uint16_t>(static_cast<uint16_t>(k.width));
    w.put<uint16_t>(static_cast<uint16_t>(k.height));
    for (double v : {k.fx, k.fy, k.cx, k.cy, k.k1, k.k2, k.k3, k.k4, k.k5, k.k6, k.p1, k.p2, k.codx,
                     k.cody, k.metric_radius})
      w.put<double>(v);
    const RigidTransform& t = cam.calibration.world_from_camera;
    for (int i = 0; i < 9; ++i) w.put<double>(t.rotation(i / 3, i % 3));
    for (int i = 0; i < 3; ++i) w.put<double>(t.translation[i]);
    w.put_string(cam.description);
  }
  return out;
}

Welcome parse_welcome(std::span<const uint8_t> payload) {
  Reader r(payload, "welcome");
  Welcome m;
  const uint32_t n = r.get<uint32_t>();
  if (n == 0 || n > kMaxCameras) r.fail("camera count " + std::to_string(n));
  m.cameras.resize(n);
  for (CameraInfo& cam : m.cameras) {
    Intrinsics& k = cam.calibration.depth;
    k.width = r.get<uint16_t>();
    k.height = r.get<uint16_t>();
    if (k.width == 0 || k.height == 0) r.fail("empty camera image size");
    for (double* v : {&k.fx, &k.fy, &k.cx, &k.cy, &k.k1, &k.k2, &k.k3, &k.k4, &k.k5, &k.k6, &k.p1,
                      &k.p2, &k.codx, &k.cody, &k.metric_radius})
      *v = r.get<double>();
    if (!(k.fx > 0 && k.fy > 0)) r.fail("focal length must be positive");
    RigidTransform& t = cam.calibration.world_from_camera;
    for (int i = 0; i < 9; ++i) t.rotation(i / 3, i % 3) = r.get<double>();
    for (int i = 0; i < 3; ++i) t.translation[i] = r.get<double>();
    cam.description = r.get_string();
  }
  r.expect_end();
  return m;
}

std::vector<uint8_t> serialize_ack(uint64_t sequence) {
  std::vector<uint8_t> out;
  Writer(out).put<uint64_t>(sequence);
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

void serialize(const EncodedFrameSet& m, std::vector<uint8_t>& out) {
  out.resize(kHeaderBytes);
  Writer w(out);
  w.put<uint64_t>(m.sequence);
  w.put<int64_t>(m.capture_time_us);
  w.put<uint32_t>(static_cast<uint32_t>(m.cameras.size()));
  for (const EncodedCamera& c : m.cameras) {
    w.put<int64_t>(c.device_timestamp_us);
    w.put_bytes(c.depth);
    w.put_bytes(c.color);
  }
  write_header(MessageType::kFrameSet, static_cast<uint32_t>(out.size() - kHeaderBytes),
               out.data());
}

void parse_frame_set(std::span<const uint8_t> payload, EncodedFrameSet& out) {
  Reader r(payload, "frame set");
  out.sequence = r.get<uint64_t>();
  out.capture_time_us = r.get<int64_t>();
  const uint32_t n = r.get<uint32_t>();
  if (n == 0 || n > kMaxCameras) r.fail("camera count " + std::to_string(n));
  out.cameras.resize(n);
  for (EncodedCamera& c : out.cameras) {
    c.device_timestamp_us = r.get<int64_t>();
    r.get_bytes(c.depth);
    r.get_bytes(c.color);
  }
  r.expect_end();
}

std::vector<uint8_t> message(MessageType type, const std::vector<uint8_t>& payload) {
  std::vector<uint8_t> out(kHeaderBytes);
  write_header(type, static_cast<uint32_t>(payload.size()), out.data());
  out.insert(out.end(), payload.begin(), payload.end());
  return out;
}

}  // namespace volcast::protocol
