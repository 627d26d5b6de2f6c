#pragma once
// The frame-set format (protocol.hpp: FrameSet 1.1 and SealedFrameSet 1.2) in one place,
// frame_set.cpp: its one writer -- the body with its head, the head rewritten for a body passed
// through, the per-viewer prefixes, the sealed descriptor -- and its one reader, parse_frame_set
// (head and per-camera bodies), behind FrameSetDecoder, which turns bodies into images for every
// receiver: the viewer's Client (stream/client.hpp), a NATS relay or capture node (src/cluster)
// and a recording (src/record).
#include <array>
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "volcast/core/frame.hpp"
#include "volcast/net/protocol/protocol.hpp"

namespace volcast {
class DepthDecoder;
class ColorDecoder;
class WorkerPool;
}  // namespace volcast

namespace volcast::protocol {

/// Sender-side times of one frame set (wall clock, microseconds since the Unix epoch).
struct SenderTimes {
  int64_t capture_us = 0;      ///< frames read from the sources
  int64_t filter_done_us = 0;  ///< filter chains done
  int64_t encode_done_us = 0;  ///< every camera of the tier encoded
  int64_t send_us = 0;         ///< this server began writing the message to this viewer
};

/// One camera's share of a parsed frame set: views into the received payload (valid while it is).
struct EncodedCameraView {
  int64_t device_timestamp_us = 0;
  std::span<const uint8_t> depth;
  std::span<const uint8_t> color;
};

struct FrameSetView {
  uint64_t sequence = 0;
  bool key = false;
  SenderTimes times;
  std::vector<EncodedCameraView> cameras;
};

/// One camera's encoded streams, for building a frame set body.
struct EncodedCamera {
  int64_t device_timestamp_us = 0;
  std::vector<uint8_t> depth;
  std::vector<uint8_t> color;
};

/// Writes a FrameSet's shared body (everything after the send time) into `out` (cleared first;
/// capacity reused). `times.send_us` is not part of the body.
void serialize_frame_set_body(uint64_t sequence, bool key, const SenderTimes& times,
                              std::span<const EncodedCamera> cameras, std::vector<uint8_t>& out);
/// The 20 bytes a FrameSet message starts with for one viewer: header (payload = 8 + body size)
/// and the send time. The message is these bytes followed by the shared body (a gather write).
inline constexpr size_t kFrameSetPrefixBytes = kHeaderBytes + 8;
std::array<uint8_t, kFrameSetPrefixBytes> frame_set_prefix(size_t body_bytes, int64_t send_us);
/// Rewrites the head of a FrameSet body (its first kFrameSetHeadBytes: sequence, key flag,
/// capture, filter-done and encode-done times; `times.send_us` is not part of it) in place, as
/// serialize_frame_set_body writes it: a tier that passes a recorded body through stamps it as
/// its own. Throws Error if `body` is shorter than the head.
void rewrite_frame_set_head(std::span<uint8_t> body, uint64_t sequence, bool key,
                            const SenderTimes& times);

/// One chunk of a sealed body: its detached AES-GCM tag and the SHA-256 of its ciphertext.
struct SealChunk {
  std::array<uint8_t, kSealTagBytes> tag{};
  std::array<uint8_t, kSealDigestBytes> digest{};
};

/// What a SealedFrameSet (1.2) carries inside TLS: how to check and open the sealed body that
/// follows it outside TLS (seal.hpp seals and opens).
struct SealedFrameSet {
  int64_t send_us = 0;  ///< as in FrameSet: when this server began writing to this viewer
  /// Copies of the sealed body's sequence, key flag and sender times (send_us unused here).
  uint64_t sequence = 0;
  bool key_frame_set = false;
  SenderTimes times;
  uint32_t body_bytes = 0;   ///< sealed bytes that follow (= the FrameSet body's length)
  uint32_t chunk_bytes = 0;  ///< power of two in [kMinSealChunkBytes, kMaxSealChunkBytes]
  std::array<uint8_t, kSealKeyBytes> key{};
  std::vector<SealChunk> chunks;  ///< ceil(body_bytes / chunk_bytes) of them
};

/// The SealedFrameSet payload after its send time (shared by every viewer of the tier), written
/// into `out` (cleared first; capacity reused). Throws Error if `m` breaks the limits above.
void serialize_sealed_frame_set_rest(const SealedFrameSet& m, std::vector<uint8_t>& out);
/// The 20 bytes a SealedFrameSet message starts with for one viewer (header with payload
/// 8 + rest_bytes, and the send time), followed by the shared rest (a gather write).
std::array<uint8_t, kFrameSetPrefixBytes> sealed_frame_set_prefix(size_t rest_bytes,
                                                                  int64_t send_us);
/// Parses a SealedFrameSet payload into `out` (its chunk list reused). Throws Error("malformed
/// sealed frame set: ...") on a chunk length that is not a power of two in range, a chunk count
/// other than ceil(body / chunk) or above kMaxSealChunks, truncation or trailing bytes.
void parse_sealed_frame_set(std::span<const uint8_t> payload, SealedFrameSet& out);

/// Parses a FrameSet payload (send time + body) into `out` (its camera list reused); the views
/// point into `payload`.
void parse_frame_set(std::span<const uint8_t> payload, FrameSetView& out);

}  // namespace volcast::protocol

namespace volcast {

/// Turns one tier's FrameSet bodies back into images: depth (mm) and color per camera, as a
/// viewer of the tier decodes them, with one depth and one color decoder per camera. Not
/// thread-safe: one caller at a time.
class FrameSetDecoder {
 public:
  /// Decoders for `cameras` (the Welcome's, in order) under the tier's codecs. Throws Error
  /// naming a codec this build lacks.
  FrameSetDecoder(const std::string& depth_codec, const std::string& color_codec,
                  std::vector<protocol::CameraInfo> cameras);
  ~FrameSetDecoder();
  FrameSetDecoder(FrameSetDecoder&&) noexcept;
  FrameSetDecoder& operator=(FrameSetDecoder&&) noexcept;

  /// Reads `message` -- 8 bytes of send time (or room for one), then a FrameSet body -- with
  /// protocol::parse_frame_set into view() (views into `message`, valid while it is). Throws
  /// Error("malformed frame set: ...") like it, or "frame set has N cameras, the site has M".
  const protocol::FrameSetView& read(std::span<const uint8_t> message);
  /// Checks that each camera's depth and color streams in view() declare the camera's calibrated
  /// size (codec/*_codec.hpp declared_*_size), before a decoder allocates for what they declare.
  /// Throws Error "camera I (NAME): its depth stream declares WxH, its calibration is WxH".
  void check_declared_sizes() const;
  /// Decodes view()'s cameras into `out.cameras` (resized; buffers reused) with their device
  /// timestamps, depth and color as separate tasks in parallel on `pool` (null: in turn on this
  /// thread). A camera with `skip[i]` != 0 is left as it is (`skip` empty: none skipped). A
  /// zero-length color stream leaves that camera's color empty (0 x 0). A temporal tier's delta
  /// decodes only right after the frame set it follows (the caller's concern). Throws Error
  /// "camera I: <the decoder's reason>" on corrupt bytes or a missing reference; the decoders'
  /// state is then unusable until the next key frame set.
  void decode_cameras(FrameSet& out, WorkerPool* pool = nullptr, std::span<const char> skip = {});
  /// read(), check_declared_sizes() and decode_cameras() on this thread; `out`'s sequence and
  /// capture time are the head's (the sender's clock).
  void decode(std::span<const uint8_t> message, FrameSet& out);
  /// The parsed view of the last message read (views into it).
  const protocol::FrameSetView& view() const { return view_; }
  /// True if both codecs are temporal-free: every frame set decodes on its own.
  bool stateless() const { return stateless_; }
  const std::vector<protocol::CameraInfo>& cameras() const { return cameras_; }

 private:
  std::vector<protocol::CameraInfo> cameras_;
  std::vector<std::unique_ptr<DepthDecoder>> depth_;
  std::vector<std::unique_ptr<ColorDecoder>> color_;
  std::vector<size_t> tasks_;  // decode_cameras: t < n depth of camera t, else color of t - n
  protocol::FrameSetView view_;
  bool stateless_ = false;
};

}  // namespace volcast
