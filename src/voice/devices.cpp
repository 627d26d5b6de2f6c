#include "volcast/voice/devices.hpp"

#include <portaudio.h>

#include <algorithm>
#include <chrono>
#include <mutex>
#include <thread>
#include <vector>

#include "volcast/audio/wav.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"

namespace volcast::voice {
namespace {

using audio::kFrameSamples;
using audio::kFrameUs;

void sleep_until_wall(int64_t at_us) {
  const int64_t wait = at_us - wall_clock_us();
  if (wait > 0) std::this_thread::sleep_for(std::chrono::microseconds(wait));
}

class FileMicrophone final : public Microphone {
 public:
  FileMicrophone(const std::string& path, int64_t start_us)
      : samples_(audio::read_voice(path)), start_us_(start_us) {}
  int64_t read(std::span<float, kFrameSamples> out) override {
    if (start_us_ == 0) start_us_ = wall_clock_us();
    const int64_t at = start_us_ + static_cast<int64_t>(blocks_) * kFrameUs;
    sleep_until_wall(at + kFrameUs);  // the block has been "spoken" by its end
    const size_t from = std::min(samples_.size(), blocks_ * kFrameSamples);
    const size_t n = std::min(kFrameSamples, samples_.size() - from);
    std::copy_n(samples_.begin() + static_cast<std::ptrdiff_t>(from), n, out.begin());
    std::fill(out.begin() + static_cast<std::ptrdiff_t>(n), out.end(), 0.0f);
    ++blocks_;
    return at;
  }
  bool ended() const override { return blocks_ * kFrameSamples >= samples_.size(); }
  bool on_wall_clock() const override { return true; }

 private:
  std::vector<float> samples_;
  int64_t start_us_;
  size_t blocks_ = 0;
};

class FileSpeaker final : public Speaker {
 public:
  FileSpeaker(const std::string& path, int channels) : sink_(path, channels), channels_(channels) {}
  int channels() const override { return channels_; }
  void write(std::span<const float> block) override { sink_.write(block); }
  int64_t latency_us() const override { return 0; }
  bool on_wall_clock() const override { return true; }

 private:
  audio::WavSink sink_;
  int channels_;
};

// PortAudio, initialised once for the process (Pa_Initialize is reference counted, but not
// thread-safe).
void portaudio() {
  static const PaError init = Pa_Initialize();
  if (init != paNoError)
    throw Error(std::string("sound devices: PortAudio failed to start: ") + Pa_GetErrorText(init));
}

PaDeviceIndex find_device(const std::string& spec, bool input) {
  portaudio();
  if (spec == "default") {
    const PaDeviceIndex d = input ? Pa_GetDefaultInputDevice() : Pa_GetDefaultOutputDevice();
    if (d == paNoDevice)
      throw Error(std::string("sound devices: there is no default ") +
                  (input ? "microphone" : "loudspeaker"));
    return d;
  }
  std::string names;
  for (PaDeviceIndex d = 0; d < Pa_GetDeviceCount(); ++d) {
    const PaDeviceInfo* info = Pa_GetDeviceInfo(d);
    if (!info || (input ? info->maxInputChannels : info->maxOutputChannels) < 1) continue;
    if (std::string(info->name).find(spec) != std::string::npos) return d;
    names += std::string(names.empty() ? "" : ", ") + "'" + info->name + "'";
  }
  throw Error("sound devices: no " + std::string(input ? "input" : "output") + " device named '" +
              spec + "' (there are: " + (names.empty() ? "none" : names) + ")");
}

PaStream* open_stream(const std::string& spec, bool input, int channels) {
  const PaDeviceIndex d = find_device(spec, input);
  PaStreamParameters p{};
  p.device = d;
  p.channelCount = channels;
  p.sampleFormat = paFloat32;
  p.suggestedLatency = input ? Pa_GetDeviceInfo(d)->defaultLowInputLatency
                             : Pa_GetDeviceInfo(d)->defaultLowOutputLatency;
  PaStream* stream = nullptr;
  PaError e = Pa_OpenStream(&stream, input ? &p : nullptr, input ? nullptr : &p, audio::kSampleRate,
                            kFrameSamples, paClipOff, nullptr, nullptr);
  if (e == paNoError) e = Pa_StartStream(stream);
  if (e != paNoError) {
    if (stream) Pa_CloseStream(stream);
    throw Error("sound device '" + spec + "': " + Pa_GetErrorText(e));
  }
  return stream;
}

class DeviceMicrophone final : public Microphone {
 public:
  explicit DeviceMicrophone(const std::string& spec)
      : spec_(spec), stream_(open_stream(spec, true, 1)) {}
  ~DeviceMicrophone() override { Pa_CloseStream(stream_); }
  int64_t read(std::span<float, kFrameSamples> out) override {
    const PaError e = Pa_ReadStream(stream_, out.data(), kFrameSamples);
    if (e != paNoError && e != paInputOverflowed)
      throw Error("microphone '" + spec_ + "': " + Pa_GetErrorText(e));
    const PaStreamInfo* info = Pa_GetStreamInfo(stream_);
    return wall_clock_us() - kFrameUs - static_cast<int64_t>((info ? info->inputLatency : 0) * 1e6);
  }
  bool ended() const override { return false; }
  bool on_wall_clock() const override { return false; }

 private:
  std::string spec_;
  PaStream* stream_;
};

class DeviceSpeaker final : public Speaker {
 public:
  DeviceSpeaker(const std::string& spec, int channels)
      : spec_(spec), channels_(channels), stream_(open_stream(spec, false, channels)) {}
  ~DeviceSpeaker() override { Pa_CloseStream(stream_); }
  int channels() const override { return channels_; }
  void write(std::span<const float> block) override {
    const PaError e = Pa_WriteStream(
        stream_, block.data(),
        static_cast<unsigned long>(block.size()) / static_cast<unsigned long>(channels_));
    if (e != paNoError && e != paOutputUnderflowed)
      throw Error("loudspeaker '" + spec_ + "': " + Pa_GetErrorText(e));
  }
  bool on_wall_clock() const override { return false; }
  int64_t latency_us() const override {
    const PaStreamInfo* info = Pa_GetStreamInfo(stream_);
    return static_cast<int64_t>((info ? info->outputLatency : 0) * 1e6);
  }

 private:
  std::string spec_;
  int channels_;
  PaStream* stream_;
};

}  // namespace

bool is_file_spec(const std::string& spec) {
  return spec.size() > 4 && (spec.ends_with(".wav") || spec.ends_with(".WAV"));
}

std::unique_ptr<Microphone> open_microphone(const std::string& spec, int64_t start_us) {
  if (is_file_spec(spec)) return std::make_unique<FileMicrophone>(spec, start_us);
  return std::make_unique<DeviceMicrophone>(spec);
}

std::unique_ptr<Speaker> open_speaker(const std::string& spec, int channels) {
  if (channels != 1 && channels != 2) throw Error("a loudspeaker has 1 or 2 channels");
  if (is_file_spec(spec)) return std::make_unique<FileSpeaker>(spec, channels);
  return std::make_unique<DeviceSpeaker>(spec, channels);
}

}  // namespace volcast::voice
