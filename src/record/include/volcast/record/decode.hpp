#pragma once
// Turns a recording's frame sets back into images: depth (mm) and color per camera, as a viewer of
// the recorded tier would have decoded them.
#include <cstddef>
#include <memory>
#include <span>
#include <vector>

#include "volcast/core/frame.hpp"
#include "volcast/net/protocol/frame_set.hpp"
#include "volcast/net/protocol/protocol.hpp"
#include "volcast/record/recording.hpp"

namespace volcast {

/// Decodes frame sets of a RecordingReader in any order. A temporal tier's delta frame set needs
/// the frame sets from the key frame set before it: decoding frame set k after k - 1 costs one
/// frame set, anything else decodes from the nearest key frame set at or before k. Not
/// thread-safe. Holds a reference to `reader`, which must outlive it.
class RecordingDecoder {
 public:
  /// Makes one depth and one color decoder per camera for the recording's tier. Throws Error
  /// naming a codec this build lacks.
  explicit RecordingDecoder(RecordingReader& reader);
  /// Decodes frame set `k` into `out` (images resized, buffers reused): its sequence and capture
  /// time are the recorded ones, device timestamps per camera. A zero-length color stream leaves
  /// that camera's color empty (0 x 0). Throws Error naming the recording, frame set and camera if
  /// its bytes are corrupt, a stream declares another size than the camera's calibration, or a
  /// delta frame set has no key frame set before it.
  void decode(size_t k, FrameSet& out);
  /// The encoded body of the frame set decode() last read (protocol.hpp FrameSet 1.1 body).
  std::span<const uint8_t> body() const { return std::span(message_).subspan(8); }
  /// The parsed view of body(): per camera depth and color streams.
  const protocol::FrameSetView& view() const { return frames_.view(); }
  /// True if both codecs are temporal-free: every frame set decodes on its own.
  bool stateless() const { return frames_.stateless(); }

 private:
  void decode_one(size_t k, FrameSet& out);
  RecordingReader& reader_;
  FrameSetDecoder frames_;
  std::vector<uint8_t> message_;  // 8 bytes (a FrameSet's send time, 0) then the body
  FrameSet scratch_;
  size_t last_ = static_cast<size_t>(-1);  // the frame set the decoders hold state for
};

}  // namespace volcast
