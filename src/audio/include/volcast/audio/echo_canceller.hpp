#pragma once
// Acoustic echo cancellation for the OR site: the loudspeaker plays the remote voices and the
// room's microphone hears them again; this removes that echo so remote doctors do not hear
// themselves. Debian's webrtc-audio-processing 0.3 (webrtc::AudioProcessing: its AEC, noise
// suppression and high-pass filter), fed in 10 ms chunks, two per 20 ms voice frame.
#include <cstdint>
#include <memory>
#include <span>

#include "volcast/audio/voice_format.hpp"

namespace volcast::audio {

/// How hard webrtc's non-linear processor suppresses what echo its adaptive filter leaves; higher
/// trades the local talker's voice during double talk for less residual echo. Measured in
/// tests/audio/echo_test.cpp (40 ms, -6 dB, 50 ms room, talker as loud as the echo): low 40 dB
/// echo reduction with the talker kept at correlation 0.67; moderate 47 dB / 0.57; high 56 dB /
/// 0.47.
enum class EchoSuppression { kLow, kModerate, kHigh };

/// How the canceller is set up.
struct EchoConfig {
  /// The known delay (ms) between a frame given to far_end() and its echo reaching near_end()
  /// (output buffering + the acoustic path); a hint: the canceller also estimates it itself
  /// (webrtc's delay-agnostic mode).
  int stream_delay_ms = 0;
  bool noise_suppression = true;  ///< webrtc's noise suppressor (moderate) on the microphone
  EchoSuppression suppression = EchoSuppression::kLow;
};

/// What the canceller reports.
struct EchoStats {
  uint64_t frames = 0;  ///< 20 ms microphone frames processed
  /// Echo return loss enhancement (dB, 10 log10(P_echo / P_out)), webrtc's long-term average
  /// (EchoCancellation::GetMetrics); 0 until it has one.
  double erle_db = 0;
  int delay_ms = 0;  ///< webrtc's median estimate of the echo delay (GetDelayMetrics), ms
};

/// One microphone/loudspeaker pair's echo canceller. Not thread-safe: call far_end() then
/// near_end() for each 20 ms frame from one thread (the audio callback). Allocation-free per frame.
class EchoCanceller {
 public:
  /// Creates and configures webrtc::AudioProcessing for 48 kHz mono (AEC with config.suppression,
  /// no drift compensation, the extended filter and delay-agnostic mode, which make it robust to
  /// a wrong stream_delay_ms; noise suppression; high-pass filter). The output lags the
  /// microphone by ~14 ms (band splitting, AEC and noise suppressor blocks). Throws
  /// volcast::Error if the library refuses any of it.
  explicit EchoCanceller(EchoConfig config = {});
  ~EchoCanceller();
  EchoCanceller(const EchoCanceller&) = delete;
  EchoCanceller& operator=(const EchoCanceller&) = delete;

  /// The next 20 ms the loudspeaker is about to play (mono, float [-1, 1], 48 kHz).
  /// Throws volcast::Error if the library fails on it.
  void far_end(std::span<const float, kFrameSamples> speaker);
  /// The microphone's next 20 ms (mono, float [-1, 1], 48 kHz), echo removed in place.
  /// Throws volcast::Error if the library fails on it.
  void near_end(std::span<float, kFrameSamples> mic);
  /// Frames processed so far and the library's own echo metrics.
  EchoStats stats() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast::audio
