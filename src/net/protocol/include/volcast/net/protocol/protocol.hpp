#pragma once
// Volcast stream protocol, version 6: versioned messages on channels, over one connection per
// viewer (TLS 1.3 by default, plain TCP on loopback with --insecure; for browsers, a WebSocket on
// /stream over the same TLS port carries the same bytes in binary messages, which a reader treats
// as one byte stream, and is never sent SealedFrameSet 1.2). Little-endian throughout.
//
// Every message: a 12-byte header
//   magic "VCST" (4 bytes) | protocol version u16 (= 6) | channel u8 | type u8 | payload length u32
// then the payload. Strings are u16 length + UTF-8 bytes; byte strings u32 length + bytes; doubles
// IEEE-754 binary64; times i64 microseconds of the sender's wall clock (Unix epoch).
//
// Channels and their messages (channel.type):
//   0 control
//     0.1 Hello      viewer -> server: join token (16 bytes, join.hpp), depth codec string, color
//                    codec string, color quality u8 (1..100, 0 = the codec's default). (depth
//                    codec, color codec, quality) is the viewer's tier. The server compares the
//                    token (constant time) before it parses anything after it; at most
//                    kMaxHelloBytes, and it must arrive within the server's handshake timeout.
//                    Then, optionally (a viewer that sends neither is pinned and never told
//                    anything of its path): adaptation flags u8 (Hello::kAdapt, kKeepLossless,
//                    kKeepFullRate, kNotify; other bits refused) | the most the viewer wants to be
//                    sent u64 (bits per second of frame sets, 0 = no cap) [| the codecs it can
//                    decode: count u8 (1..kMaxDecodableCodecs) then that many codec name strings
//                    (depth and color together); absent: every codec of the server's ladder. A
//                    browser sends it: its WebAssembly decoder has no video depth codec].
//     0.2 Welcome    server -> viewer: camera count u32, then per camera: width u16, height u16,
//                    the 15 intrinsics fx fy cx cy k1..k6 p1 p2 codx cody metric_radius (f64),
//                    world_from_camera rotation (9 f64, row-major) and translation (3 f64, metres),
//                    the camera's name string (for people; never a file path); then the server's
//                    wall clock i64 when it sent Welcome (the viewer estimates the offset between
//                    the two clocks from it).
//     0.3 Reject     server -> viewer: a reason string (wrong token, a tier the server does not
//                    offer -- naming the offered ones --, wrong version, server full); the server
//                    then closes the connection.
//     0.4 Ack        viewer -> server: sequence u64 of a frame set the viewer has received and
//                    decoded (or, for a receive-only peer, read). The server paces by Acks.
//     0.5 KeyFrameRequest  viewer -> server, empty: the viewer's decoder refused a delta frame;
//                    the server sends the viewer's tier's next key frame (rate-limited per tier).
//     0.6 TierChange server -> viewer, only to a viewer whose Hello set kAdapt or kNotify: depth
//     codec
//                    string, color codec string, color quality u8, frame divisor u8 (1..8: the
//                    tier encodes every Nth site frame set), the server's estimate of the path
//                    (delivery rate in kbit/s, u32) and a reason string for people (at most
//                    kMaxReasonBytes). Every frame set after it is of this tier, beginning with a
//                    key frame set. The same tier as before is a notice: the path cannot carry it
//                    and the viewer's floor (or its pin) keeps it there. At most kMaxControlBytes.
//   1 frames       (its code, writer and reader: frame_set.hpp)
//     1.1 FrameSet   server -> viewer: send time i64 (when this server began writing the message
//                    to this viewer), then the tier's shared body, byte-identical for every viewer
//                    of the tier: sequence u64 | flags u8 (bit 0: key frame set, every camera's
//                    depth and color decode on their own) | capture time i64 | filter done i64 |
//                    encode done i64 | camera count u32 | per camera: device timestamp i64 (us),
//                    depth bytes (u32 length + codec stream), color bytes (likewise). A color
//                    stream of length 0 means "no color for this frame" (a depth-only camera, or
//                    a frame whose color is missing) under every color codec: the viewer does not
//                    decode it and leaves that camera's color image empty (0 x 0); it decodes on
//                    its own (counts as key). A temporal color codec's first frame after one is a
//                    key frame. Sent over plain TCP, and over TLS to a tier with fewer viewers
//                    than the server seals for (ServerConfig::seal_from_viewers; TLS then encrypts
//                    it per viewer, which costs less for one or two).
//     1.2 SealedFrameSet  server -> viewer, only over TLS: the same frame set, its body encrypted
//                    once per tier instead of once per viewer (TLS would encrypt it again for each
//                    viewer); a viewer may get 1.1 and 1.2 in turn as others join and leave. The
//                    payload, inside TLS like every other message: send time i64 | the
//                    body's first 33 bytes, copied: sequence u64 | flags u8 | capture time i64 |
//                    filter done i64 | encode done i64 (a viewer that opens the body refuses a
//                    copy that differs; a receive-only one acknowledges from it unopened) |
//                    body length u32 | chunk length u32 (a power of two, kMinSealChunkBytes to
//                    kMaxSealChunkBytes) | key (16 bytes: AES-128, random, fresh for every frame
//                    set of every tier) | per chunk, ceil(body length / chunk length) of them (at
//                    most kMaxSealChunks): its AES-GCM tag (16 bytes) | the SHA-256 of its
//                    ciphertext (32 bytes). Directly after the TLS record that ends this message,
//                    OUTSIDE TLS on the same TCP stream, come `body length` bytes: the 1.1 body
//                    (everything after its send time) encrypted with AES-128-GCM, chunk i = body
//                    bytes [i * chunk length, min((i + 1) * chunk length, body length)) under the
//                    key with the 12-byte nonce (i as u32, then 8 zero bytes) and no associated
//                    data; the tags are detached (above). The viewer checks each chunk's SHA-256,
//                    then its tag, and only then decrypts it: the digests come through its own
//                    authenticated TLS session, so not even another viewer of the tier, who holds
//                    the same key, can alter the bytes unnoticed (GCM alone would let it: a key
//                    holder can forge a tag). Confidentiality: the key travels only inside each
//                    viewer's TLS session; a viewer that left never learns a later key. This is
//                    the pattern of SFrame (RFC 9605: media encrypted once for a group) and of
//                    encrypted attachments (key and digest in the secure channel, bulk outside).
//   2 session        the shared virtual room: lobby, participants, poses, teleports, camera
//                    avatars -- every message and its limits in volcast/session/messages.hpp.
//                    parse_header accepts any type here; the server hands them to its session
//                    service (ServerConfig::session, which bounds each type's payload before it is
//                    read), a viewer to its session handler (Client::set_session_handler); a peer
//                    without one skips payloads of up to kMaxControlBytes. They may come between
//                    any two messages of the conversation below, in both directions.
//
// Conversation: Hello, then Welcome or Reject; then FrameSets (1.1 or 1.2) and TierChanges from
// the server and Acks (and KeyFrameRequests) from the viewer. Any other order is a protocol error
// that ends the connection; so is a TLS record that straddles the sealed bytes of a 1.2 message.
//
// Limits a viewer enforces on what a server claims, before it allocates for it (a message over a
// limit ends the connection with an Error naming it; the constants are below):
//   Welcome payload <= kMaxWelcomeBytes; 1..kMaxCameras cameras; each camera's width and height
//   1..kMaxCameraSide; all cameras' pixels together <= kMaxSitePixels.
//   SealedFrameSet payload <= kMaxSealedFrameSetBytes, and 8 + its body length within the
//   FrameSet limit below, checked before any sealed byte is read.
//   FrameSet payload <= frame_set_payload_limit(Welcome): room for every camera's depth and
//   color at kFrameSetBytesPerPixel bytes per pixel (more than raw depth + raw BGRA, and than
//   any codec's worst case) plus kFrameSetCameraOverhead bytes each; never above
//   kMaxPayloadBytes. Each codec stream's own header must declare the camera's calibrated size.
//   A viewer reads a payload in chunks and grows its buffer only as bytes arrive.
// A server must stay within them (sites of up to 16 Azure Kinects at 1024x1024 do).
//
// Pacing (see server.hpp): the server keeps about one bandwidth-delay product of frame sets in
// flight (sent, not acknowledged), always sends the newest frame set, and never one older than its
// latency budget, so a slow viewer skips whole frame sets instead of building latency.
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "volcast/codec/tier.hpp"
#include "volcast/core/calibration.hpp"

namespace volcast::protocol {

inline constexpr uint32_t kMagic = 0x54534356;  // "VCST" as little-endian bytes
inline constexpr uint16_t kVersion = 6;         // 6: the session's RecordingState (0x53)
inline constexpr size_t kTokenBytes = 16;
inline constexpr size_t kHeaderBytes = 12;
inline constexpr uint32_t kMaxHelloBytes = 4096;
inline constexpr uint32_t kMaxControlBytes = 4096;        ///< any viewer -> server message
inline constexpr uint32_t kMaxPayloadBytes = 256u << 20;  ///< 256 MiB: any larger is hostile
inline constexpr int kMaxCameras = 64;
/// A viewer refuses a Welcome larger than this (bytes): 64 cameras' calibration take 14 KiB, the
/// rest is room for their descriptions.
inline constexpr uint32_t kMaxWelcomeBytes = 256u << 10;
/// A viewer refuses a camera wider or taller than this (pixels; depth codecs allow 8192).
inline constexpr int kMaxCameraSide = 4096;
/// A viewer refuses a site whose cameras have more pixels than this together (16 Mi pixels: 16
/// cameras of 1024x1024, or one of 4096x4096), which bounds what it allocates per frame set.
inline constexpr uint64_t kMaxSitePixels = uint64_t{16} << 20;
/// FrameSet budget per camera pixel (bytes) and per camera (bytes: codec headers and tables, JPEG
/// markers, video parameter sets): see frame_set_payload_limit().
inline constexpr uint64_t kFrameSetBytesPerPixel = 8;
inline constexpr uint64_t kFrameSetCameraOverhead = 64u << 10;

/// SealedFrameSet (1.2) limits: chunk lengths (bytes, powers of two) and chunks per frame set.
inline constexpr uint32_t kMinSealChunkBytes = 4u << 10;
inline constexpr uint32_t kMaxSealChunkBytes = 16u << 20;
inline constexpr uint32_t kMaxSealChunks = 4096;
inline constexpr size_t kSealKeyBytes = 16, kSealTagBytes = 16, kSealDigestBytes = 32;
/// A FrameSet body's fixed head: sequence, flags and three sender times (a SealedFrameSet copies
/// it).
inline constexpr uint32_t kFrameSetHeadBytes = 8 + 1 + 3 * 8;
/// The largest SealedFrameSet payload (the descriptor inside TLS, not the sealed bytes after it).
inline constexpr uint32_t kMaxSealedFrameSetBytes =
    8 + kFrameSetHeadBytes + 4 + 4 + kSealKeyBytes +
    kMaxSealChunks * (kSealTagBytes + kSealDigestBytes);

enum class Channel : uint8_t { kControl = 0, kFrames = 1, kSession = 2 };

/// channel << 8 | type, as on the wire.
enum class MessageType : uint16_t {
  kHello = 0x0001,
  kWelcome = 0x0002,
  kReject = 0x0003,
  kAck = 0x0004,
  kKeyFrameRequest = 0x0005,
  kTierChange = 0x0006,
  kFrameSet = 0x0101,
  kSealedFrameSet = 0x0102,
};

struct Header {
  uint16_t version = kVersion;
  Channel channel{};
  MessageType type{};  ///< for the session channel, 0x02tt with any tt
  uint32_t payload_bytes = 0;
};

/// Encodes a header for `type` with `payload_bytes` into 12 bytes.
void write_header(MessageType type, uint32_t payload_bytes, uint8_t out[kHeaderBytes]);
/// Parses and validates a header: magic, version (must equal kVersion), a known channel and (on
/// the control and frames channels) a known type, and a payload no larger than `max_payload`.
/// Throws Error naming the first bad field.
Header parse_header(std::span<const uint8_t> bytes, uint32_t max_payload = kMaxPayloadBytes);
/// True if `bytes` begin with the magic "VCST" (at least 4 bytes): a Volcast peer, not a browser's
/// HTTP request.
inline bool starts_with_magic(std::span<const uint8_t> bytes) {
  return bytes.size() >= 4 && bytes[0] == 'V' && bytes[1] == 'C' && bytes[2] == 'S' &&
         bytes[3] == 'T';
}

struct Hello {
  std::array<uint8_t, kTokenBytes> token{};  ///< the session's join token (join.hpp)
  /// The tier asked for: its codecs and color quality (0..100, 0: the codec's default); a Hello
  /// carries no frame divisor (a viewer asks for every frame set: 1).
  Tier tier;
  /// Adaptation flags (the optional tail; 0 with max_bits_per_s 0: not sent).
  static constexpr uint8_t kAdapt = 1;         ///< the server may move it along its tier ladder
  static constexpr uint8_t kKeepLossless = 2;  ///< never a tier with lossy depth
  static constexpr uint8_t kKeepFullRate = 4;  ///< never a tier that skips site frame sets
  static constexpr uint8_t kNotify = 8;        ///< understands TierChange (0.6); implied by kAdapt
  uint8_t adapt = 0;
  uint64_t max_bits_per_s = 0;  ///< frame sets at most this rate (bits/s); 0: no cap
  /// The depth and color codecs the viewer can decode (an adaptive viewer is kept to ladder rungs
  /// of these); empty: any (not sent).
  std::vector<std::string> decodes{};
};

/// The most codec names a Hello's `decodes` may list.
inline constexpr size_t kMaxDecodableCodecs = 32;

/// The longest TierChange reason (bytes).
inline constexpr size_t kMaxReasonBytes = 400;

/// TierChange (0.6): the tier the frame sets after it are of, and why.
struct TierChange {
  Tier tier;                 ///< frame_divisor 1..8: every Nth site frame set
  uint32_t path_kbit_s = 0;  ///< the server's delivery-rate estimate of the path; 0: none yet
  std::string reason;
};

struct CameraInfo {
  CameraCalibration calibration;
  std::string description;  ///< the camera's name for viewers (never a file path: sent to all)
};

struct Welcome {
  std::vector<CameraInfo> cameras;
  int64_t server_time_us = 0;
};

// Payload serialisation (FrameSet 1.1 and SealedFrameSet 1.2: frame_set.hpp). The parse_*
// functions throw Error("malformed <message>: ...") on any truncated, oversized or inconsistent
// field and never read past `payload`.
std::vector<uint8_t> serialize(const Hello& m);
std::vector<uint8_t> serialize(const Welcome& m);
std::vector<uint8_t> serialize_reject(const std::string& reason);
std::vector<uint8_t> serialize_ack(uint64_t sequence);
/// A whole Ack message (header + sequence), without allocating: the viewer sends one per frame set.
std::array<uint8_t, kHeaderBytes + 8> ack_message(uint64_t sequence);

/// The token a Hello payload starts with, without parsing the rest (the server checks it first).
/// Throws Error("malformed hello: truncated") if the payload is shorter than a token.
std::span<const uint8_t, kTokenBytes> hello_token(std::span<const uint8_t> payload);
Hello parse_hello(std::span<const uint8_t> payload);
/// Also refuses (Error "malformed welcome: ...") what exceeds the viewer's limits above: more
/// than kMaxCameras cameras, a side above kMaxCameraSide, more than kMaxSitePixels pixels in all.
Welcome parse_welcome(std::span<const uint8_t> payload);
/// The largest FrameSet payload (bytes) a viewer accepts from the site `welcome` describes: the
/// frame set's fixed fields, and per camera its 16 bytes of fields, kFrameSetCameraOverhead and
/// kFrameSetBytesPerPixel * width * height; at most kMaxPayloadBytes.
uint32_t frame_set_payload_limit(const Welcome& welcome);
std::string parse_reject(std::span<const uint8_t> payload);
std::vector<uint8_t> serialize(const TierChange& m);
/// Refuses (Error "malformed tier change: ...") a quality over 100, a divisor outside 1..8, a
/// reason longer than kMaxReasonBytes, trailing bytes.
TierChange parse_tier_change(std::span<const uint8_t> payload);
uint64_t parse_ack(std::span<const uint8_t> payload);

/// Header + payload as one message.
std::vector<uint8_t> message(MessageType type, const std::vector<uint8_t>& payload);

}  // namespace volcast::protocol
