#pragma once
// Where voice comes from and goes to: a microphone and a loudspeaker, each a sound device
// (PortAudio: ALSA, PulseAudio or JACK, by name) or a WAV file (how tests, demos and recordings
// feed it). Audio is 48 kHz, in 20 ms blocks (audio/voice_format.hpp): the microphone mono, the
// loudspeaker mono or stereo (interleaved left, right).
//
// Files play in real time: a file microphone hands out its next 20 ms when the wall clock reaches
// it (then silence once the file has ended), so a file paces a voice loop as a device would.
#include <cstdint>
#include <memory>
#include <span>
#include <string>

#include "volcast/audio/voice_format.hpp"

namespace volcast::voice {

/// A microphone: 20 ms mono blocks, in order, at the sample rate.
class Microphone {
 public:
  virtual ~Microphone() = default;
  /// Waits for the next 20 ms and fills `out`; returns its capture time (µs, local wall clock, of
  /// its first sample). Throws Error if the device failed.
  virtual int64_t read(std::span<float, audio::kFrameSamples> out) = 0;
  /// A file's samples have all been read (always false for a device).
  virtual bool ended() const = 0;
  /// Paced by the wall clock (a file read in real time, a simulation); false for a sound device,
  /// which keeps its own clock (and its own underruns).
  virtual bool on_wall_clock() const = 0;
};

/// A loudspeaker: 20 ms blocks of `channels()` interleaved channels.
class Speaker {
 public:
  virtual ~Speaker() = default;
  virtual int channels() const = 0;
  /// Plays (or writes) 20 ms: channels() x kFrameSamples samples. Throws Error if the device
  /// failed or the file could not be written (a full disk).
  virtual void write(std::span<const float> block) = 0;
  /// How long a sample written now takes to be heard (µs): the device's output latency, 0 for a
  /// file.
  virtual int64_t latency_us() const = 0;
  /// A file (written as blocks come: the caller's clock is its clock), or a simulation; false for
  /// a sound device, which plays at its own clock.
  virtual bool on_wall_clock() const = 0;
};

/// `spec`: a path ending in .wav (read as mono 48 kHz: mixed down and resampled), or a device:
/// "default" or (part of) a PortAudio input device's name. `start_us`: a file's first sample is
/// captured then (local wall clock; 0: when first read). Throws Error naming the file or device.
std::unique_ptr<Microphone> open_microphone(const std::string& spec, int64_t start_us = 0);
/// `spec`: a path ending in .wav (written as 16-bit PCM, kept playable while written) or a device
/// as for open_microphone, of PortAudio's output devices. `channels`: 1 or 2.
std::unique_ptr<Speaker> open_speaker(const std::string& spec, int channels);
/// Whether `spec` names a file rather than a device.
bool is_file_spec(const std::string& spec);

}  // namespace volcast::voice
