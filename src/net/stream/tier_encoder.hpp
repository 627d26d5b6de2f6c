#pragma once
// Internal: one tier's encoders. A tier (depth codec, color codec, color quality) encodes each
// frame set once; the result is immutable and shared by every viewer of the tier.
#include <memory>
#include <string>
#include <vector>

#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/codec/tier.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/core/worker_pool.hpp"
#include "volcast/net/protocol/frame_set.hpp"

namespace volcast::detail {

/// Estimated CPU time (ns, one thread) to encode one frame set of tier `key` for a site of
/// `pixels` depth pixels in all (each with a registered color pixel): the codecs'
/// encode_ns_per_pixel (registry.hpp) times `pixels`; a codec without a figure is charged as the
/// costliest registered one of its kind. Throws Error naming an unknown codec.
double tier_encode_ns(const Tier& key, uint64_t pixels);

/// One encoded frame set of a tier: the FrameSet body every viewer of the tier is sent.
struct EncodedFrames {
  uint64_t sequence = 0;  ///< the site's frame-set sequence
  uint64_t index = 0;     ///< the tier's own count: 1, 2, ... (deltas code against index - 1)
  bool key = false;       ///< every camera's depth and color decode on their own
  int64_t capture_us = 0;
  int64_t encode_done_us = 0;
  std::vector<uint8_t> body;  ///< protocol::serialize_frame_set_body
  /// When sealed (TLS, enough viewers: ServerConfig::seal_from_viewers): `body` sealed once for
  /// every viewer (seal.hpp), and the SealedFrameSet payload after its send time (head copy, key,
  /// tags, digests). Both empty when this frame set was not sealed.
  std::vector<uint8_t> sealed;
  std::vector<uint8_t> seal_rest;
};

class TierEncoder {
 public:
  /// Throws Error naming an unknown codec.
  TierEncoder(Tier key, size_t cameras);
  const Tier& key() const { return key_; }
  /// Encodes `frames` (key frames forced if `key`), the cameras' depth and color in parallel on
  /// `pool`, into a recycled buffer. A camera with an empty color image gets a zero-length color
  /// stream (no color, see protocol.hpp) without calling its color encoder, and its next
  /// non-empty color frame is forced to a key frame. A camera whose frame is the one it encoded
  /// last time (a camera slower than the site repeats its frame) keeps its bytes when both codecs
  /// are non-temporal (the same frame encodes to the same bytes). With `seal` it then seals the
  /// body under a fresh key, its chunks in parallel on `pool` (else `sealed` stays empty). Not
  /// thread-safe: one caller at a time.
  ///
  /// Pass-through: if `frames.encoded` was encoded for this tier's codecs and quality, its body is
  /// sent as it is (sequence, key flag and times rewritten) when it is a key frame set, or a delta
  /// that follows the one this tier passed through last (and no key is forced). Otherwise the
  /// frames are encoded (a key frame set after a pass-through: the encoders did not see it).
  std::shared_ptr<const EncodedFrames> encode(const CapturedFrameSet& frames, bool key,
                                              WorkerPool& pool, bool seal);
  /// CPU time (ms, all threads) the last encode() spent in the codecs: 0 for a frame set passed
  /// through or whose cameras all repeated their frames.
  double last_cpu_ms() const { return last_cpu_ms_; }

 private:
  // Numbers `out` as the tier's next frame set and seals it if asked.
  void finish(uint64_t sequence, const std::shared_ptr<EncodedFrames>& out,
              const protocol::SenderTimes& times, WorkerPool& pool, bool seal);
  Tier key_;
  std::vector<std::unique_ptr<DepthEncoder>> depth_;
  std::vector<std::unique_ptr<ColorEncoder>> color_;
  std::vector<protocol::EncodedCamera> encoded_;
  std::vector<char> key_flags_;  // per task: emitted a key frame
  std::vector<char> color_gap_;  // per camera: its last frame had no color (next color is a key)
  std::vector<size_t> tasks_;    // the tasks of this call (tasks 0..n-1 depth, n..2n-1 color)
  std::vector<double> task_cpu_ms_;  // per task of this call: its thread's CPU time
  double last_cpu_ms_ = 0;
  // The frame each camera encoded last, held so its address cannot be reused by a new frame.
  std::vector<std::shared_ptr<const CameraFrame>> last_;
  bool stateless_ = false;  // both codecs non-temporal: bytes depend on the frame alone
  protocol::SealedFrameSet seal_scratch_;                // chunk list reused
  std::vector<std::shared_ptr<EncodedFrames>> buffers_;  // recycled once no viewer holds them
  uint64_t index_ = 0;
  bool passing_ = false;          // the last frame set was passed through
  uint64_t passed_position_ = 0;  // its EncodedFrameSetBody::position
  bool encoders_stale_ = false;   // frames were passed through since the encoders last ran
};

}  // namespace volcast::detail
