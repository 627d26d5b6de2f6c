#pragma once
// Voice as Volcast carries it: 48 kHz mono, 20 ms frames (Opus, RFC 6716), samples as float in
// [-1, 1]. Stereo output is interleaved left, right.
#include <cstddef>
#include <cstdint>
namespace volcast::audio {
inline constexpr int kSampleRate = 48000;            ///< Hz
inline constexpr size_t kFrameSamples = 960;         ///< one 20 ms mono frame
inline constexpr int64_t kFrameUs = 20'000;          ///< one frame, microseconds
inline constexpr size_t kMaxOpusPacketBytes = 1275;  ///< RFC 6716 §3.4 (one frame)
}  // namespace volcast::audio
