#pragma once
// Volcast stream protocol, version 1, over one TCP connection per viewer.
//
// Every message: a 12-byte header, little-endian:
//   magic "VCST" (4 bytes) | protocol version u16 | message type u16 | payload length u32
// then the payload. Strings are u16 length + UTF-8 bytes; doubles are IEEE-754 binary64.
//
// Conversation:
//   viewer -> server  Hello      depth codec name, color codec name
//   server -> viewer  Welcome    camera count, then per camera: width u16, height u16, the 15
//                                intrinsics fx fy cx cy k1..k6 p1 p2 codx cody metric_radius (f64),
//                                world_from_camera rotation (9 f64, row-major) and translation
//                                (3 f64, metres), and a description string
//                  or Reject     a reason string (unknown codec, wrong version, server full), then
//                                the server closes the connection
//   server -> viewer  FrameSet   sequence u64, capture time i64 (server wall clock, microseconds),
//                                camera count u32, per camera: device timestamp i64 (us),
//                                depth bytes (u32 length + codec stream), color bytes (likewise)
//   viewer -> server  Ack        sequence u64 of a frame set the viewer has decoded
// The server sends calibration once (Welcome) and then frame sets, at most `window` of them
// unacknowledged (default 2): the newest frame set goes out only when the viewer has caught up, so
// a slow viewer misses whole frame sets (sequence numbers jump) instead of letting them queue in
// socket buffers, and its latency stays bounded.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "volcast/core/calibration.hpp"

namespace volcast::protocol {

inline constexpr uint32_t kMagic = 0x54534356;  // "VCST" as little-endian bytes
inline constexpr uint16_t kVersion = 1;
inline constexpr size_t kHeaderBytes = 12;
inline constexpr uint32_t kMaxHelloBytes = 4096;
inline constexpr uint32_t kMaxPayloadBytes = 256u << 20;  ///< 256 MiB: any larger is hostile
inline constexpr int kMaxCameras = 64;

enum class MessageType : uint16_t {
  kHello = 1,
  kWelcome = 2,
  kReject = 3,
  kFrameSet = 4,
  kAck = 5
};

struct Header {
  uint16_t version = kVersion;
  MessageType type{};
  uint32_t payload_bytes = 0;
};

/// Encodes a header for `type` with `payload_bytes` into 12 bytes.
void write_header(MessageType type, uint32_t payload_bytes, uint8_t out[kHeaderBytes]);
/// Parses and validates a header: magic, version (must equal kVersion), known type, and a payload
/// no larger than `max_payload`. Throws Error naming the first bad field.
Header parse_header(std::span<const uint8_t> bytes, uint32_t max_payload = kMaxPayloadBytes);

struct Hello {
  std::string depth_codec;
  std::string color_codec;
};

struct CameraInfo {
  CameraCalibration calibration;
  std::string description;
};

struct Welcome {
  std::vector<CameraInfo> cameras;
};

/// One camera's share of a frame set, still encoded.
struct EncodedCamera {
  int64_t device_timestamp_us = 0;
  std::vector<uint8_t> depth;
  std::vector<uint8_t> color;
};

struct EncodedFrameSet {
  uint64_t sequence = 0;
  int64_t capture_time_us = 0;
  std::vector<EncodedCamera> cameras;
};

// Payload serialisation. The parse_* functions throw Error("malformed <message>: ...") on any
// truncated, oversized or inconsistent field and never read past `payload`.
std::vector<uint8_t> serialize(const Hello& m);
std::vector<uint8_t> serialize(const Welcome& m);
std::vector<uint8_t> serialize_reject(const std::string& reason);
/// Appends header + payload of a frame set to `out` (cleared first; capacity reused).
void serialize(const EncodedFrameSet& m, std::vector<uint8_t>& out);

std::vector<uint8_t> serialize_ack(uint64_t sequence);
uint64_t parse_ack(std::span<const uint8_t> payload);

Hello parse_hello(std::span<const uint8_t> payload);
Welcome parse_welcome(std::span<const uint8_t> payload);
std::string parse_reject(std::span<const uint8_t> payload);
/// Parses into `out`, reusing its buffers.
void parse_frame_set(std::span<const uint8_t> payload, EncodedFrameSet& out);

/// Header + payload as one message.
std::vector<uint8_t> message(MessageType type, const std::vector<uint8_t>& payload);

}  // namespace volcast::protocol
