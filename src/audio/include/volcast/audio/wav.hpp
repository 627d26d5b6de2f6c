#pragma once
// Audio files through libsndfile (http://libsndfile.github.io/libsndfile/api.html): reading any
// format it knows, writing 16-bit PCM WAV, and a crash-safe streaming WAV writer.
#include <cstddef>
#include <filesystem>
#include <memory>
#include <span>
#include <vector>

#include "volcast/audio/voice_format.hpp"

namespace volcast::audio {

/// Decoded audio: `samples` interleaved (frame-major, `channels` per frame), float in [-1, 1].
struct Pcm {
  int sample_rate = kSampleRate;  ///< Hz
  int channels = 1;
  std::vector<float> samples;  ///< interleaved, [-1, 1]
  /// Number of frames (samples per channel).
  size_t frames() const {
    return channels > 0 ? samples.size() / static_cast<size_t>(channels) : 0;
  }
};

/// Reads any file libsndfile reads (WAV, FLAC, Ogg...). Throws volcast::Error naming the file and
/// libsndfile's reason when it cannot be opened or read.
Pcm read_wav(const std::filesystem::path& path);

/// Reads a file as Volcast voice: mono (channels averaged), 48 kHz (resampled with speexdsp's
/// resampler, quality 10, latency removed, when the file's rate differs). Length in samples is
/// round(frames * 48000 / rate). Errors as read_wav.
std::vector<float> read_voice(const std::filesystem::path& path);

/// Resamples mono `samples` from `from_rate` Hz to 48 kHz (speexdsp, quality 10); the output is
/// aligned with the input (the resampler's latency removed) and round(n * 48000 / from_rate) long.
/// Throws volcast::Error for a rate outside 1000..384000 Hz.
std::vector<float> resample_to_voice(std::span<const float> samples, int from_rate);

/// Writes `pcm` as 16-bit PCM WAV (samples clipped to [-1, 1]). Throws volcast::Error naming the
/// file on a bad shape (channels < 1, rate < 1, samples not a whole number of frames) or a failed
/// write.
void write_wav(const std::filesystem::path& path, const Pcm& pcm);

/// A streaming 16-bit PCM WAV writer. The header is rewritten after every write
/// (SFC_SET_UPDATE_HEADER_AUTO), so a process killed mid-stream leaves a playable file holding
/// every frame written. Owns the open file; movable, not copyable.
class WavSink {
 public:
  /// Creates (truncates) `path`. Throws volcast::Error naming it if it cannot be created or the
  /// shape is bad (channels < 1, sample_rate < 1).
  WavSink(const std::filesystem::path& path, int channels, int sample_rate = kSampleRate);
  ~WavSink();
  WavSink(WavSink&&) noexcept;
  WavSink& operator=(WavSink&&) noexcept;
  WavSink(const WavSink&) = delete;
  WavSink& operator=(const WavSink&) = delete;

  /// Appends interleaved frames (size a multiple of channels, float [-1, 1], clipped). Throws
  /// volcast::Error on a partial frame, a closed sink or a failed write.
  void write(std::span<const float> interleaved);
  /// Finishes the file; later writes throw. Idempotent; the destructor calls it.
  void close();
  /// Frames (samples per channel) written so far.
  size_t frames_written() const { return frames_written_; }

 private:
  struct File;
  std::unique_ptr<File> file_;
  std::filesystem::path path_;
  int channels_ = 1;
  size_t frames_written_ = 0;
};

}  // namespace volcast::audio
