#pragma once
// Turns one tier's FrameSet bodies (protocol.hpp 1.1) back into images: depth (mm) and color per
// camera, as a viewer of the tier decodes them. Used where frame sets arrive as bytes from
// somewhere other than a Server connection: a recording (record/decode.hpp), a NATS relay
// (cluster/relay.hpp).
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/net/protocol.hpp"

namespace volcast {

class FrameSetDecoder {
 public:
  /// One depth and one color decoder per camera of `cameras` for the tier's codecs. Throws Error
  /// naming a codec this build lacks.
  FrameSetDecoder(const std::string& depth_codec, const std::string& color_codec,
                  std::vector<protocol::CameraInfo> cameras);
  /// Decodes `message` -- 8 bytes of room for a send time (ignored), then a FrameSet body -- into
  /// `out` (its images resized, buffers reused): sequence and capture time as the body's head
  /// says, device timestamps per camera. A zero-length color stream leaves that camera's color
  /// empty (0 x 0). A temporal tier's delta decodes only right after the frame set it follows
  /// (the caller's concern). Throws Error naming the camera if the bytes are corrupt, the camera
  /// count differs from the tier's, or a stream declares another size than its calibration; the
  /// decoders' state is then unusable until the next key frame set.
  void decode(std::span<const uint8_t> message, FrameSet& out);
  /// The parsed view of the last message decode() read (views into it).
  const protocol::FrameSetView& view() const { return view_; }
  /// True if both codecs are temporal-free: every frame set decodes on its own.
  bool stateless() const { return stateless_; }
  const std::vector<protocol::CameraInfo>& cameras() const { return cameras_; }

 private:
  std::vector<protocol::CameraInfo> cameras_;
  std::vector<std::unique_ptr<DepthDecoder>> depth_;
  std::vector<std::unique_ptr<ColorDecoder>> color_;
  protocol::FrameSetView view_;
  bool stateless_ = false;
};

}  // namespace volcast
