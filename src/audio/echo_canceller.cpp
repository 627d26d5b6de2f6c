// EchoCanceller on webrtc-audio-processing 0.3 (webrtc/modules/audio_processing/include/
// audio_processing.h: the float API with StreamConfig, 10 ms chunks).
#include "volcast/audio/echo_canceller.hpp"

#include <webrtc/modules/audio_processing/include/audio_processing.h>

#include <string>

#include "volcast/core/error.hpp"

namespace volcast::audio {
namespace {

constexpr size_t kChunkSamples = kFrameSamples / 2;  // webrtc processes 10 ms at a time

void check(int result, const char* what) {
  if (result != webrtc::AudioProcessing::kNoError) {
    throw Error(std::string("webrtc-audio-processing: ") + what + " failed (error " +
                std::to_string(result) + ")");
  }
}

webrtc::EchoCancellation::SuppressionLevel suppression_level(EchoSuppression level) {
  switch (level) {
    case EchoSuppression::kLow:
      return webrtc::EchoCancellation::kLowSuppression;
    case EchoSuppression::kModerate:
      return webrtc::EchoCancellation::kModerateSuppression;
    case EchoSuppression::kHigh:
      return webrtc::EchoCancellation::kHighSuppression;
  }
  throw Error("EchoCanceller: unknown suppression level " +
              std::to_string(static_cast<int>(level)));
}

}  // namespace

struct EchoCanceller::Impl {
  EchoConfig config;
  std::unique_ptr<webrtc::AudioProcessing> apm;
  webrtc::StreamConfig stream{kSampleRate, 1};
  uint64_t frames = 0;
};

EchoCanceller::EchoCanceller(EchoConfig config) : impl_(std::make_unique<Impl>()) {
  if (config.stream_delay_ms < 0 || config.stream_delay_ms > 500) {
    throw Error("EchoCanceller: stream_delay_ms must be 0..500, not " +
                std::to_string(config.stream_delay_ms));
  }
  impl_->config = config;
  webrtc::Config extra;
  extra.Set<webrtc::ExtendedFilter>(new webrtc::ExtendedFilter(true));
  extra.Set<webrtc::DelayAgnostic>(new webrtc::DelayAgnostic(true));
  impl_->apm.reset(webrtc::AudioProcessing::Create(extra));
  if (!impl_->apm) throw Error("webrtc-audio-processing: AudioProcessing::Create failed");
  webrtc::AudioProcessing& apm = *impl_->apm;
  webrtc::ProcessingConfig processing = {
      {impl_->stream, impl_->stream, impl_->stream, impl_->stream}};
  check(apm.Initialize(processing), "Initialize (48 kHz mono)");
  webrtc::EchoCancellation& aec = *apm.echo_cancellation();
  check(aec.enable_drift_compensation(false), "enable_drift_compensation");
  check(aec.set_suppression_level(suppression_level(config.suppression)), "set_suppression_level");
  check(aec.enable_metrics(true), "enable_metrics");
  check(aec.enable_delay_logging(true), "enable_delay_logging");
  check(aec.Enable(true), "echo_cancellation()->Enable");
  if (config.noise_suppression) {
    check(apm.noise_suppression()->set_level(webrtc::NoiseSuppression::kModerate),
          "noise_suppression()->set_level");
    check(apm.noise_suppression()->Enable(true), "noise_suppression()->Enable");
  }
  check(apm.high_pass_filter()->Enable(true), "high_pass_filter()->Enable");
}

EchoCanceller::~EchoCanceller() = default;

void EchoCanceller::far_end(std::span<const float, kFrameSamples> speaker) {
  for (size_t offset = 0; offset < kFrameSamples; offset += kChunkSamples) {
    const float* in = speaker.data() + offset;
    // The render path is analysed, not changed: write its (unused) output to a scratch chunk.
    float scratch[kChunkSamples];
    float* out = scratch;
    check(impl_->apm->ProcessReverseStream(&in, impl_->stream, impl_->stream, &out),
          "ProcessReverseStream");
  }
}

void EchoCanceller::near_end(std::span<float, kFrameSamples> mic) {
  for (size_t offset = 0; offset < kFrameSamples; offset += kChunkSamples) {
    float* chunk = mic.data() + offset;
    const float* in = chunk;
    // A warning (kBadStreamParameterWarning) only means the delay was clamped.
    const int delay = impl_->apm->set_stream_delay_ms(impl_->config.stream_delay_ms);
    if (delay != webrtc::AudioProcessing::kBadStreamParameterWarning) {
      check(delay, "set_stream_delay_ms");
    }
    check(impl_->apm->ProcessStream(&in, impl_->stream, impl_->stream, &chunk), "ProcessStream");
  }
  ++impl_->frames;
}

EchoStats EchoCanceller::stats() const {
  EchoStats stats;
  stats.frames = impl_->frames;
  webrtc::EchoCancellation& aec = *impl_->apm->echo_cancellation();
  webrtc::EchoCancellation::Metrics metrics{};
  if (aec.GetMetrics(&metrics) == webrtc::AudioProcessing::kNoError) {
    stats.erle_db = metrics.echo_return_loss_enhancement.average;
  }
  int median = 0;
  int deviation = 0;
  if (aec.GetDelayMetrics(&median, &deviation) == webrtc::AudioProcessing::kNoError) {
    stats.delay_ms = median;
  }
  return stats;
}

}  // namespace volcast::audio
