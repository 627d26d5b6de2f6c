#include "volcast/voice/site_voice.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>

#include "level.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"

namespace volcast::voice {

using audio::kFrameSamples;
using audio::kFrameUs;

struct SiteVoice::Heard {
  explicit Heard(const audio::VoiceStreamConfig& playout) : stream(playout) {}
  audio::VoiceStream stream;
  Latencies latencies;
};

SiteVoice::SiteVoice(SiteVoiceConfig config, std::unique_ptr<Microphone> mic,
                     std::unique_ptr<Speaker> speaker, Send send)
    : config_(std::move(config)),
      mic_(std::move(mic)),
      speaker_(std::move(speaker)),
      send_(std::move(send)),
      encoder_(config_.encoder),
      block_(kFrameSamples),
      heard_(kFrameSamples),
      mix_(kFrameSamples) {
  if (speaker_ && speaker_->channels() != 1)
    throw Error("the OR site's loudspeaker plays one channel (a mix)");
  if (config_.echo_cancellation && mic_ && speaker_)
    echo_ = std::make_unique<audio::EchoCanceller>(config_.echo);
  muted_ = config_.muted;
  thread_ = std::thread([this] { run(); });
}

SiteVoice::~SiteVoice() {
  stop();
}

void SiteVoice::stop() {
  stopping_ = true;
  if (thread_.joinable()) thread_.join();
  speaker_.reset();  // closes a file
}

void SiteVoice::put(uint32_t participant, const session::VoicePacketView& packet) {
  std::lock_guard lock(mutex_);
  auto& h = heard_voices_[participant];
  if (!h) h = std::make_unique<Heard>(config_.playout);
  h->stream.put(packet.sequence, packet.frame, packet.capture_us, packet.opus);
}

std::string SiteVoice::error() const {
  std::lock_guard lock(mutex_);
  return error_;
}

void SiteVoice::run() {
  const int64_t start = wall_clock_us();
  {
    std::lock_guard lock(mutex_);
    stats_.started_us = start;
  }
  const bool wall_clock_paced =
      (!mic_ || mic_->on_wall_clock()) && (!speaker_ || speaker_->on_wall_clock());
  try {
    for (int64_t tick = 0; !stopping_; ++tick) {
      int64_t due = start + (tick + 1) * kFrameUs;  // this block's end: when it is played
      if (mic_) {
        const int64_t captured =
            mic_->read(std::span<float, kFrameSamples>(block_.data(), kFrameSamples));
        capture(captured);
        mic_ended_ = mic_->ended();
        due = captured + kFrameUs;
      } else {
        const int64_t wait = due - wall_clock_us();
        if (wait > 0) std::this_thread::sleep_for(std::chrono::microseconds(wait));
      }
      const int64_t now = wall_clock_us();
      // A whole block behind: the loudspeaker ran dry, the voices wait (VoiceLink::run).
      play(now, wall_clock_paced && now - due >= kFrameUs);
    }
  } catch (const Error& e) {
    spdlog::error("OR site voice: {}", e.what());
    std::lock_guard lock(mutex_);
    error_ = e.what();
  }
}

void SiteVoice::capture(int64_t captured_us) {
  const std::span<float, kFrameSamples> block(block_.data(), kFrameSamples);
  const uint32_t frame = frame_++;
  std::span<const uint8_t> packet;
  {
    std::lock_guard lock(mutex_);
    if (echo_) echo_->near_end(block);  // the loudspeaker's echo out of the room's microphone
    ++stats_.frames_captured;
    if (muted_) return;
    packet = encoder_.encode(block);  // only this thread encodes: valid until the next frame
    if (encoder_.last_was_dtx()) {
      ++stats_.dtx_frames;
      return;
    }
    ++stats_.packets_sent;
    stats_.bytes_sent += packet.size();
  }
  // Outside the lock: the hub calls put() with its own lock held.
  send_({sequence_++, frame, captured_us, packet});
}

void SiteVoice::play(int64_t now_us, bool underrun) {
  const int64_t heard_at = now_us + (speaker_ ? speaker_->latency_us() : 0);
  std::fill(mix_.begin(), mix_.end(), 0.0f);
  {
    std::lock_guard lock(mutex_);
    if (underrun) ++stats_.frames_underrun;
    for (auto& [id, h] : heard_voices_) {
      if (underrun) {
        h->stream.hold();
        continue;
      }
      const audio::PlayedFrame played =
          h->stream.next(std::span<float, kFrameSamples>(heard_.data(), kFrameSamples));
      if (played.source == audio::PlayedFrame::Source::kPacket ||
          played.source == audio::PlayedFrame::Source::kFec)
        h->latencies.add(double(heard_at - played.capture_us) / 1000.0);
      for (size_t i = 0; i < kFrameSamples; ++i) mix_[i] += heard_[i];
    }
    ++stats_.frames_played;
    for (float& x : mix_) x = soft_clip(x);
    if (echo_) echo_->far_end(std::span<const float, kFrameSamples>(mix_.data(), kFrameSamples));
  }
  if (speaker_) speaker_->write(mix_);
}

SiteVoiceStats SiteVoice::stats() const {
  std::lock_guard lock(mutex_);
  SiteVoiceStats out = stats_;
  if (echo_) out.echo = echo_->stats();
  for (const auto& [id, h] : heard_voices_)
    out.heard.push_back(
        {id, h->stream.stats(), h->latencies.percentile(0.5), h->latencies.percentile(0.99)});
  return out;
}

}  // namespace volcast::voice
