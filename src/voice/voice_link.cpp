#include "volcast/voice/voice_link.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>

#include "level.hpp"
#include "volcast/audio/spatial_mixer.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/voice/devices.hpp"

namespace volcast::voice {

using audio::kFrameSamples;
using audio::kFrameUs;

struct VoiceLink::Speaker {
  explicit Speaker(const audio::VoiceStreamConfig& playout) : stream(playout) {}
  audio::VoiceStream stream;
  std::string name;
  float volume = 1;
  bool volume_set = false;  // by set_volume, or from VoiceConfig::volumes once the name is known
  Loudness loudness;
  Latencies latencies;
  int64_t played_frame = -1;  // HeardVoice::played_frame
};

namespace {

// VoiceConfig::played_log, closed at the end.
struct PlayedLog {
  std::FILE* file = nullptr;
  explicit PlayedLog(const std::string& path)
      : file(path.empty() ? nullptr : std::fopen(path.c_str(), "w")) {
    if (!path.empty() && !file) throw Error("voice: cannot write the played log " + path);
  }
  ~PlayedLog() {
    if (file) std::fclose(file);
  }
  PlayedLog(const PlayedLog&) = delete;
  PlayedLog& operator=(const PlayedLog&) = delete;
};

char played_how(audio::PlayedFrame::Source source) {
  switch (source) {
    case audio::PlayedFrame::Source::kPacket:
      return 'p';
    case audio::PlayedFrame::Source::kFec:
      return 'f';
    case audio::PlayedFrame::Source::kConcealed:
      return 'c';
    case audio::PlayedFrame::Source::kSilence:
      break;
  }
  return 's';
}

}  // namespace

struct VoiceLink::Devices {
  std::unique_ptr<Microphone> mic;
  std::unique_ptr<voice::Speaker> speaker;
  std::unique_ptr<PlayedLog> played;
  std::unique_ptr<audio::SpatialMixer> mixer;
  std::array<float, kFrameSamples> block{}, heard{};
  std::array<float, 2 * kFrameSamples> out{};
};

VoiceLink::VoiceLink(Participant& participant, VoiceConfig config)
    : participant_(participant),
      config_(std::move(config)),
      devices_(std::make_unique<Devices>()),
      encoder_(config_.encoder) {
  Devices& d = *devices_;
  if (!config_.mic.empty()) d.mic = open_microphone(config_.mic, config_.mic_start_us);
  if (!config_.speaker.empty()) d.speaker = open_speaker(config_.speaker, config_.spatial ? 2 : 1);
  if (!config_.played_log.empty()) d.played = std::make_unique<PlayedLog>(config_.played_log);
  if (config_.spatial) {
    d.mixer = std::make_unique<audio::SpatialMixer>();
    stats_.hrtf = d.mixer->hrtf();
  }
  muted_ = config_.muted;
  if (muted_) participant_.set_muted(true);
  participant_.set_voice_handler([this](uint32_t from, const session::VoicePacketView& p) {
    std::lock_guard lock(mutex_);
    auto& s = speakers_[from];
    if (!s) s = std::make_unique<Speaker>(config_.playout);
    s->stream.put(p.sequence, p.frame, p.capture_us, p.opus);
  });
  thread_ = std::thread([this] { run(); });
}

VoiceLink::~VoiceLink() {
  stop();
}

void VoiceLink::stop() {
  stopping_ = true;
  if (thread_.joinable()) thread_.join();
  participant_.set_voice_handler(nullptr);
  devices_->speaker.reset();  // closes the file
  devices_->played.reset();
}

void VoiceLink::set_muted(bool muted) {
  if (muted_.exchange(muted) != muted) participant_.set_muted(muted);
}

void VoiceLink::set_talking(bool talking) {
  talking_ = talking;
}

void VoiceLink::set_volume(uint32_t participant, float volume) {
  std::lock_guard lock(mutex_);
  auto& s = speakers_[participant];
  if (!s) s = std::make_unique<Speaker>(config_.playout);
  s->volume = std::clamp(volume, 0.0f, 4.0f);
  s->volume_set = true;
}

std::string VoiceLink::error() const {
  std::lock_guard lock(mutex_);
  return error_;
}

void VoiceLink::run() {
  Devices& d = *devices_;
  const int64_t start = wall_clock_us();
  const auto started = [this](int64_t at) {
    std::lock_guard lock(mutex_);
    stats_.started_us = at;
  };
  started(start);
  const bool wall_clock_paced =
      (!d.mic || d.mic->on_wall_clock()) && (!d.speaker || d.speaker->on_wall_clock());
  try {
    for (int64_t tick = 0; !stopping_; ++tick) {
      int64_t due = start + (tick + 1) * kFrameUs;  // this block's end: when it is played
      if (d.mic) {
        const int64_t captured = d.mic->read(d.block);
        // The microphone paces the loop: the loudspeaker's first block goes out with its first.
        if (tick == 0) started(captured);
        capture(d.block, captured);
        mic_ended_ = d.mic->ended();
        due = captured + kFrameUs;
      } else {
        const int64_t wait = due - wall_clock_us();
        if (wait > 0) std::this_thread::sleep_for(std::chrono::microseconds(wait));
      }
      const int64_t now = wall_clock_us();
      // A whole block behind (this thread did not run: a loaded machine): the loudspeaker ran
      // dry. That block is silence and every voice's play position waits (VoiceStream::hold), as
      // after a stall of its stream: its packets, held up by the same stall, are often not here
      // yet, and would be lost as late if it played on through it. Only where the wall clock
      // paces the loop (files): a sound device keeps its own clock, and its own underruns.
      if (wall_clock_paced && now - due >= kFrameUs)
        play_underrun();
      else
        play(now);
    }
  } catch (const Error& e) {
    spdlog::error("voice: {}", e.what());
    std::lock_guard lock(mutex_);
    error_ = e.what();
  }
}

void VoiceLink::capture(std::span<const float, kFrameSamples> block, int64_t capture_us) {
  const uint32_t frame = frame_++;
  const bool sending = !muted_ && (!config_.push_to_talk || talking_);
  std::span<const uint8_t> packet;
  {
    std::lock_guard lock(mutex_);
    ++stats_.frames_captured;
    if (!sending) return;
    packet = encoder_.encode(block);  // only this thread encodes: valid until the next frame
    if (encoder_.last_was_dtx()) {
      ++stats_.dtx_frames;
      return;
    }
    ++stats_.packets_sent;
    stats_.bytes_sent += packet.size();
  }
  participant_.send_voice(
      {sequence_++, frame, capture_us + participant_.clock_offset_us(), packet});
}

void VoiceLink::play(int64_t now_us) {
  Devices& d = *devices_;
  VoiceScene& s = scene_;  // storage kept from frame to frame: nothing allocated once warm
  participant_.voice_scene(now_us, s);
  const int64_t heard_at =
      now_us + participant_.clock_offset_us() + (d.speaker ? d.speaker->latency_us() : 0);
  if (d.mixer) {
    const Pose head = listener_head(s);
    d.mixer->set_listener(head.position, head.orientation);
  }
  std::fill(d.out.begin(), d.out.end(), 0.0f);
  std::lock_guard lock(mutex_);
  for (auto& [id, speaker] : speakers_) {
    const audio::PlayedFrame played = speaker->stream.next(d.heard);
    speaker->played_frame = std::max<int64_t>(speaker->played_frame, played.frame);
    if (d.played)
      std::fprintf(d.played->file, "%llu\t%u\t%c\t%u\n",
                   static_cast<unsigned long long>(stats_.frames_played), id,
                   played_how(played.source), played.frame);
    if (played.source == audio::PlayedFrame::Source::kPacket ||
        played.source == audio::PlayedFrame::Source::kFec)
      speaker->latencies.add(double(heard_at - played.capture_us) / 1000.0);
    speaker->loudness.add(d.heard);
    for (const VoiceScene::Speaker& r : s.others)
      if (r.id == id) {
        if (speaker->name != r.name) speaker->name = r.name;
        if (!speaker->volume_set) {  // --volume NAME=GAIN, unless a slider came first
          if (const auto v = config_.volumes.find(r.name); v != config_.volumes.end())
            speaker->volume = v->second;
          speaker->volume_set = true;
        }
      }
    const float volume = speaker->volume;
    if (d.mixer) {
      d.mixer->set_source(id, speaker_position(s, id, config_.site_position), volume);
      d.mixer->push(id, d.heard);
    } else {
      for (size_t i = 0; i < kFrameSamples; ++i) d.out[i] += volume * d.heard[i];
    }
  }
  if (d.mixer) d.mixer->render(d.out);
  if (d.speaker) {
    const size_t n = d.mixer ? 2 * kFrameSamples : kFrameSamples;
    for (size_t i = 0; i < n; ++i) d.out[i] = soft_clip(d.out[i]);
    d.speaker->write(std::span<const float>(d.out.data(), n));
  }
  ++stats_.frames_played;
}

void VoiceLink::play_underrun() {
  Devices& d = *devices_;
  std::fill(d.out.begin(), d.out.end(), 0.0f);
  {
    std::lock_guard lock(mutex_);
    for (auto& [id, speaker] : speakers_) speaker->stream.hold();
    ++stats_.frames_underrun;
    ++stats_.frames_played;
  }
  if (d.speaker)
    d.speaker->write(
        std::span<const float>(d.out.data(), size_t(d.speaker->channels()) * kFrameSamples));
}

VoiceStats VoiceLink::stats() const {
  const SessionSnapshot s = participant_.snapshot(wall_clock_us());
  std::lock_guard lock(mutex_);
  VoiceStats out = stats_;
  const uint64_t sent_frames = out.packets_sent + out.dtx_frames;
  if (sent_frames > 0)
    out.bytes_per_second = double(out.bytes_sent) / (double(sent_frames) * kFrameUs / 1e6);
  for (const auto& [id, speaker] : speakers_) {
    HeardVoice h;
    h.id = id;
    h.name = speaker->name;
    h.stream = speaker->stream.stats();
    h.latency_ms_p50 = speaker->latencies.percentile(0.5);
    h.latency_ms_p99 = speaker->latencies.percentile(0.99);
    h.played_frame = speaker->played_frame;
    h.speaking = speaker->loudness.speaking();
    h.volume = speaker->volume;
    for (const RemoteParticipant& r : s.others)
      if (r.id == id) h.muted = r.muted, h.name = r.name;
    out.heard.push_back(std::move(h));
  }
  return out;
}

}  // namespace volcast::voice
