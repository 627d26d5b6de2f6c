#pragma once
// Spatial audio: many mono voices rendered to stereo, each from where its speaker stands, through
// OpenAL Soft (1.19) with HRTF on a loopback device (ALC_SOFT_loopback: the mix is pulled frame by
// frame, no sound card), with inverse-distance-clamped attenuation (OpenAL 1.1 spec §3.4.2).
//
// Frames: positions are in the room frame (metres, y up; see volcast/room/room.hpp). The
// listener's head is OpenXR view space (x right, y up, looking down -z), which is also OpenAL's
// listener convention, and is given as `room_from_head`.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "volcast/audio/voice_format.hpp"

namespace volcast::audio {

/// How voices are rendered.
struct SpatialConfig {
  bool hrtf = true;                   ///< binaural (HRTF) rendering; false: stereo panning
  float reference_distance_m = 1.0f;  ///< distance at which a voice plays at its own gain
  float rolloff = 1.0f;               ///< gain = ref / (ref + rolloff * (d - ref))
  float max_distance_m = 15.0f;       ///< beyond this the gain no longer falls
  int max_sources = 32;               ///< voices that may be placed at once
};

/// Mixes mono 20 ms frames of many voices into one stereo 20 ms frame for one listener. Owns an
/// OpenAL Soft loopback device and context; several mixers may live in one process (each AL call
/// is made under the mixer's own thread-local context, ALC_EXT_thread_local_context). All members
/// are thread-safe (one mutex). After construction push() and render() allocate nothing of their
/// own (AL buffers are reused); OpenAL Soft 1.19's alSourceQueueBuffers itself callocs one small
/// queue entry per queued buffer (freed on unqueue).
class SpatialMixer {
 public:
  /// Opens the loopback device (float stereo at 48 kHz) and its context. HRTF is requested when
  /// config.hrtf (the 48 kHz data set if the device lists several); whether it was granted is
  /// hrtf(). Throws volcast::Error if OpenAL Soft lacks ALC_SOFT_loopback or
  /// ALC_EXT_thread_local_context, the format is refused, or the device or context fails.
  explicit SpatialMixer(SpatialConfig config = {});
  ~SpatialMixer();
  SpatialMixer(const SpatialMixer&) = delete;
  SpatialMixer& operator=(const SpatialMixer&) = delete;

  /// Places the listener: room_from_head as its position (room frame, metres) and orientation.
  void set_listener(const Eigen::Vector3f& room_position, const Eigen::Quaternionf& room_from_head);
  /// Places voice `id` at room_position (room frame, metres) with a linear gain (1: as pushed),
  /// adding it if new. Throws volcast::Error if max_sources voices are already placed.
  void set_source(uint32_t id, const Eigen::Vector3f& room_position, float gain = 1);
  /// Removes voice `id` and drops what it had queued; unknown ids are ignored.
  void remove_source(uint32_t id);
  /// Queues the next 20 ms of voice `id` (mono, float [-1, 1], 48 kHz). A voice starts playing
  /// once two frames are queued (one frame of latency against jitter); if it gets more than
  /// kMaxQueuedFrames ahead of render(), its oldest frame is dropped. Throws volcast::Error for an
  /// id not placed with set_source().
  void push(uint32_t id, std::span<const float, kFrameSamples> mono);
  /// Mixes exactly 20 ms of every voice at its position relative to the listener into
  /// `stereo_out` (interleaved left, right; float, OpenAL Soft's output limiter keeps it in
  /// [-1, 1]). A voice with nothing queued is silent for this frame.
  void render(std::span<float, 2 * kFrameSamples> stereo_out);

  /// Whether HRTF rendering is on (ALC_HRTF_STATUS_SOFT is enabled or required).
  bool hrtf() const;
  /// The HRTF data set in use (ALC_HRTF_SPECIFIER_SOFT), or "" when HRTF is off.
  std::string hrtf_name() const;
  /// ALC_HRTF_STATUS_SOFT in words ("enabled", "denied", "unsupported format", ...).
  std::string hrtf_status() const;

  /// Most frames a voice may have queued (pending and in OpenAL): 100 ms.
  static constexpr int kMaxQueuedFrames = 5;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast::audio
