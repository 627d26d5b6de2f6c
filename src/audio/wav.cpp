#include "volcast/audio/wav.hpp"

#include <sndfile.h>
#include <speex/speex_resampler.h>

#include <algorithm>
#include <string>

#include "volcast/core/error.hpp"

namespace volcast::audio {
namespace {

constexpr int kResamplerQuality = 10;  // SPEEX_RESAMPLER_QUALITY_MAX: offline files, best quality
constexpr sf_count_t kMaxSamples = sf_count_t{1} << 31;  // 12 h of 48 kHz mono: a sane bound

struct SndfileCloser {
  void operator()(SNDFILE* f) const { sf_close(f); }
};
using SndfilePtr = std::unique_ptr<SNDFILE, SndfileCloser>;

std::string describe(const std::filesystem::path& path) {
  return "'" + path.string() + "'";
}

}  // namespace

Pcm read_wav(const std::filesystem::path& path) {
  SF_INFO info{};
  SndfilePtr file(sf_open(path.c_str(), SFM_READ, &info));
  if (!file) {
    throw Error("cannot read audio file " + describe(path) + ": " + sf_strerror(nullptr));
  }
  if (info.channels < 1 || info.samplerate < 1 || info.frames < 0 ||
      info.frames > kMaxSamples / info.channels) {
    throw Error("audio file " + describe(path) + " has a bad shape: " +
                std::to_string(info.channels) + " channels, " + std::to_string(info.samplerate) +
                " Hz, " + std::to_string(info.frames) + " frames");
  }
  Pcm pcm;
  pcm.sample_rate = info.samplerate;
  pcm.channels = info.channels;
  pcm.samples.resize(static_cast<size_t>(info.frames) * static_cast<size_t>(info.channels));
  const sf_count_t got = sf_readf_float(file.get(), pcm.samples.data(), info.frames);
  if (got != info.frames) {
    throw Error("cannot read audio file " + describe(path) + ": " + sf_strerror(file.get()) +
                " (read " + std::to_string(got) + " of " + std::to_string(info.frames) +
                " frames)");
  }
  return pcm;
}

std::vector<float> resample_to_voice(std::span<const float> samples, int from_rate) {
  if (from_rate < 1000 || from_rate > 384000) {
    throw Error("cannot resample from " + std::to_string(from_rate) + " Hz (1000..384000)");
  }
  if (from_rate == kSampleRate) return {samples.begin(), samples.end()};
  int err = 0;
  SpeexResamplerState* st = speex_resampler_init(1, static_cast<spx_uint32_t>(from_rate),
                                                 kSampleRate, kResamplerQuality, &err);
  if (st == nullptr) {
    throw Error(std::string("speex_resampler_init: ") + speex_resampler_strerror(err));
  }
  std::unique_ptr<SpeexResamplerState, void (*)(SpeexResamplerState*)> owner(
      st, speex_resampler_destroy);
  speex_resampler_skip_zeros(st);  // drop the leading latency: output aligned with input
  const auto expected = static_cast<size_t>(
      (static_cast<int64_t>(samples.size()) * kSampleRate + from_rate / 2) / from_rate);
  // Input plus zeros that flush the filter's tail.
  std::vector<float> in(samples.begin(), samples.end());
  in.resize(in.size() + static_cast<size_t>(speex_resampler_get_input_latency(st)) + 16, 0.0f);
  std::vector<float> out(expected + 64);
  size_t in_pos = 0;
  size_t out_pos = 0;
  while (in_pos < in.size() && out_pos < out.size()) {
    auto in_len = static_cast<spx_uint32_t>(std::min<size_t>(in.size() - in_pos, 1u << 20));
    auto out_len = static_cast<spx_uint32_t>(std::min<size_t>(out.size() - out_pos, 1u << 20));
    speex_resampler_process_float(st, 0, in.data() + in_pos, &in_len, out.data() + out_pos,
                                  &out_len);
    if (in_len == 0 && out_len == 0) break;
    in_pos += in_len;
    out_pos += out_len;
  }
  out.resize(std::min(expected, out_pos));
  out.resize(expected, 0.0f);
  return out;
}

std::vector<float> read_voice(const std::filesystem::path& path) {
  const Pcm pcm = read_wav(path);
  std::vector<float> mono(pcm.frames());
  const auto channels = static_cast<size_t>(pcm.channels);
  for (size_t i = 0; i < mono.size(); ++i) {
    float sum = 0.0f;
    for (size_t c = 0; c < channels; ++c) sum += pcm.samples[i * channels + c];
    mono[i] = sum / static_cast<float>(channels);
  }
  if (pcm.sample_rate == kSampleRate) return mono;
  return resample_to_voice(mono, pcm.sample_rate);
}

struct WavSink::File {
  SndfilePtr handle;
};

namespace {

SndfilePtr open_for_write(const std::filesystem::path& path, int channels, int sample_rate) {
  if (channels < 1 || sample_rate < 1) {
    throw Error("cannot write WAV " + describe(path) + ": bad shape " + std::to_string(channels) +
                " channels, " + std::to_string(sample_rate) + " Hz");
  }
  SF_INFO info{};
  info.channels = channels;
  info.samplerate = sample_rate;
  info.format = SF_FORMAT_WAV | SF_FORMAT_PCM_16;
  SndfilePtr file(sf_open(path.c_str(), SFM_WRITE, &info));
  if (!file) {
    throw Error("cannot create WAV " + describe(path) + ": " + sf_strerror(nullptr));
  }
  sf_command(file.get(), SFC_SET_CLIPPING, nullptr, SF_TRUE);
  return file;
}

void write_frames(SNDFILE* file, const std::filesystem::path& path, std::span<const float> data,
                  int channels) {
  if (data.size() % static_cast<size_t>(channels) != 0) {
    throw Error("cannot write WAV " + describe(path) + ": " + std::to_string(data.size()) +
                " samples is not a whole number of " + std::to_string(channels) +
                "-channel frames");
  }
  const auto frames = static_cast<sf_count_t>(data.size() / static_cast<size_t>(channels));
  if (sf_writef_float(file, data.data(), frames) != frames) {
    throw Error("cannot write WAV " + describe(path) + ": " + sf_strerror(file));
  }
}

}  // namespace

void write_wav(const std::filesystem::path& path, const Pcm& pcm) {
  SndfilePtr file = open_for_write(path, pcm.channels, pcm.sample_rate);
  write_frames(file.get(), path, pcm.samples, pcm.channels);
  if (sf_close(file.release()) != 0) throw Error("cannot close WAV " + describe(path));
}

WavSink::WavSink(const std::filesystem::path& path, int channels, int sample_rate)
    : file_(std::make_unique<File>()), path_(path), channels_(channels) {
  file_->handle = open_for_write(path, channels, sample_rate);
  // Rewrite the header after each write: a killed process leaves a valid file.
  sf_command(file_->handle.get(), SFC_SET_UPDATE_HEADER_AUTO, nullptr, SF_TRUE);
}

WavSink::~WavSink() {
  close();
}
WavSink::WavSink(WavSink&&) noexcept = default;
WavSink& WavSink::operator=(WavSink&& other) noexcept {
  if (this != &other) {
    close();
    file_ = std::move(other.file_);
    path_ = std::move(other.path_);
    channels_ = other.channels_;
    frames_written_ = other.frames_written_;
  }
  return *this;
}

void WavSink::write(std::span<const float> interleaved) {
  if (!file_ || !file_->handle) throw Error("WAV " + describe(path_) + " is closed");
  write_frames(file_->handle.get(), path_, interleaved, channels_);
  frames_written_ += interleaved.size() / static_cast<size_t>(channels_);
}

void WavSink::close() {
  if (file_) file_->handle.reset();
}

}  // namespace volcast::audio
