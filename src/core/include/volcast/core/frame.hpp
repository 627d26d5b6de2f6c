#pragma once
// Frame sets: one capture of every camera of a site.
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "volcast/core/image.hpp"
#include "volcast/core/tier.hpp"

namespace volcast {

/// One camera's capture: depth (mm) and color registered to the depth pixel grid (same size),
/// or an empty color image if the camera has none.
struct CameraFrame {
  DepthImage depth;
  ColorImage color;
  int64_t device_timestamp_us = 0;  ///< the camera's own clock (recording timestamp), microseconds
};

/// One capture of every camera of a site, in camera order, as a receiver holds it after decoding
/// (buffers it owns and reuses). capture_time_us is the server's wall clock (microseconds since
/// the Unix epoch) when the set was captured/read.
struct FrameSet {
  uint64_t sequence = 0;
  int64_t capture_time_us = 0;
  std::vector<CameraFrame> cameras;
};

/// A frame set that arrives already encoded for one tier -- a recording being replayed: its
/// FrameSet body (volcast/net/protocol/protocol.hpp 1.1) as recorded. A server tier of the same
/// codecs and quality sends these bytes, with the head's sequence and times rewritten, instead of
/// encoding the frames again (volcast/net/stream/server.hpp).
struct EncodedFrameSetBody {
  Tier tier;              ///< the tier it was encoded for (of every frame set: divisor 1)
  uint64_t position = 0;  ///< its place in its stream: a delta decodes after position - 1's
  bool key = false;       ///< every camera decodes on its own
  std::vector<uint8_t> body;
};

/// What a site publishes: one capture of every camera, in camera order, with the cameras' frames
/// shared and immutable. A frame repeated in several sets (a camera slower than the site) and every
/// tier's encoder read the same pixels; nothing is copied on the way out.
/// Times are the sender's wall clock, microseconds since the Unix epoch.
struct CapturedFrameSet {
  uint64_t sequence = 0;        ///< 1, 2, ... per site, without gaps
  int64_t capture_time_us = 0;  ///< when the frames were read from their sources
  int64_t filter_done_us = 0;   ///< when every camera's filter chain had run
  std::vector<std::shared_ptr<const CameraFrame>> cameras;
  /// The same frames as encoded for one tier (a replay), or null.
  std::shared_ptr<const EncodedFrameSetBody> encoded;
  /// `cameras` are an earlier frame set's images, standing in (a relay passes `encoded` through
  /// without decoding it): a tier encoded from the images skips this frame set.
  bool images_stale = false;
};

}  // namespace volcast
