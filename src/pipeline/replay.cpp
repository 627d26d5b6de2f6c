#include "volcast/pipeline/replay.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdlib>
#include <set>

#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/session/annotations.hpp"
#include "volcast/session/hub.hpp"

namespace volcast {

ReplayPlayer::ReplayPlayer(const std::filesystem::path& path, ReplayOptions options)
    : reader_(path),
      decoder_(reader_),
      options_(options),
      buffers_(reader_.info().stream.welcome.cameras.size()) {
  const auto& sets = reader_.info().frame_sets;
  if (sets.empty()) throw Error("replay " + path.string() + ": the recording holds no frame sets");
  timeline_ = playback_timeline(sets);
  if (timeline_.clamped_gaps)
    spdlog::warn(
        "replay {}: the capture time {} by {} between frame sets {} and {}; replaying them one "
        "frame interval ({}) apart{}",
        path.string(), timeline_.first_clamped_gap_us < 0 ? "goes back" : "jumps",
        describe_span_us(std::abs(timeline_.first_clamped_gap_us)), timeline_.first_clamped - 1,
        timeline_.first_clamped, describe_span_us(timeline_.frame_interval_us),
        timeline_.clamped_gaps > 1
            ? fmt::format(" ({} such gaps, each replayed so)", timeline_.clamped_gaps)
            : std::string());
  const auto at = [&](size_t k) { return static_cast<double>(timeline_.offset_us[k]) / 1e6; };
  first_ = sets.size();
  for (size_t k = 0; k < sets.size(); ++k)
    if (at(k) >= options.from_s - 1e-6) {
      first_ = k;
      break;
    }
  last_ = first_;
  for (size_t k = first_; k < sets.size() && (options.to_s < 0 || at(k) <= options.to_s + 1e-6);
       ++k)
    last_ = k;
  if (first_ >= sets.size() || (options.to_s >= 0 && options.to_s < options.from_s))
    throw Error("replay " + path.string() + ": no frame sets between " +
                std::to_string(options.from_s) + " s and " +
                (options.to_s < 0 ? std::string("the end") : std::to_string(options.to_s) + " s") +
                " (the recording lasts " + std::to_string(at(sets.size() - 1)) + " s)");
  voices_ = voice_plan(reader_.info(), timeline_, first_, last_);
  bad_voice_.assign(voices_.cues.size(), 0);
  if (voices_.outside)
    spdlog::warn(
        "replay {}: {} of its {} voice packets lie outside its frame sets' time line (before the "
        "first, after the last, or in a gap replayed shorter) and are not played",
        path.string(), voices_.outside, reader_.info().voices.size());
  drawing_ = drawing_plan(reader_.info(), timeline_, first_, last_);
  for (const DrawingCue& c : drawing_) {
    drawing_payloads_.emplace_back();
    try {
      reader_.read_drawing(reader_.info().drawings[c.drawing], drawing_payloads_.back());
    } catch (const Error& e) {
      drawing_payloads_.back().clear();
      spdlog::warn("replay: a recorded annotation is skipped: {}", e.what());
    }
  }
}

ReplayPlayer::~ReplayPlayer() {
  stop();
}

std::vector<protocol::CameraInfo> ReplayPlayer::cameras() const {
  return reader_.info().stream.welcome.cameras;
}

double ReplayPlayer::fps() const {
  const int64_t span = timeline_.offset_us[last_] - timeline_.offset_us[first_];
  return last_ > first_ && span > 0
             ? static_cast<double>(last_ - first_) * 1e6 / static_cast<double>(span)
             : 30.0;
}

void ReplayPlayer::start(Server& server, SessionHub* hub) {
  start([&server](std::shared_ptr<const CapturedFrameSet> f) { server.publish(std::move(f)); },
        hub);
}

void ReplayPlayer::start(Publish publish, SessionHub* hub) {
  stop();  // the threads read hub_ids_
  Speak speak;
  Draw draw;
  if (hub && hub_ != hub) {
    // A recorded speaker for each voice, and for each author or eraser of the drawing whom the
    // recording names (a Speaker record).
    std::set<uint32_t> people;
    for (const VoicePlan::Speaker& s : voices_.speakers) people.insert(s.speaker.participant);
    for (size_t c = 0; c < drawing_.size(); ++c) {
      const std::vector<uint8_t>& p = drawing_payloads_[c];
      if (p.empty()) continue;
      people.insert(reader_.info().drawings[drawing_[c].drawing].type == kDrawingAnnotation
                        ? session::parse_annotation(p).author
                        : session::parse_erased(p).second);
    }
    hub_ids_.clear();
    for (const RecordedSpeaker& s : reader_.info().speakers)
      if (people.contains(s.participant))
        hub_ids_[s.participant] = hub->add_recorded_speaker(s.name, s.role == 1);
    hub_ = hub;
  }
  if (hub && !voices_.speakers.empty())
    speak = [hub, this](uint32_t speaker, const session::VoicePacketView& p) {
      if (const auto it = hub_ids_.find(speaker); it != hub_ids_.end())
        hub->recorded_voice(it->second, p);
    };
  if (hub && !drawing_.empty())
    draw = [hub, this](uint8_t type, std::span<const uint8_t> p) {
      try {
        const uint32_t who = type == kDrawingAnnotation ? session::parse_annotation(p).author
                                                        : session::parse_erased(p).second;
        const auto it = hub_ids_.find(who);
        hub->recorded_drawing(type, p, it == hub_ids_.end() ? 0 : it->second);
      } catch (const Error& e) {
        spdlog::warn("replay: a recorded annotation is skipped: {}", e.what());
      }
    };
  start(std::move(publish), std::move(speak), std::move(draw));
}

void ReplayPlayer::start(Publish publish, Speak speak, Draw draw) {
  stop();
  stop_ = false;
  frames_done_ = false;
  voices_done_ = !speak || voices_.cues.empty();
  drawing_done_ = !draw || drawing_.empty();
  const auto epoch = Clock::now();
  const int64_t epoch_wall = wall_clock_us();
  thread_ = std::thread([this, publish = std::move(publish), epoch, epoch_wall] {
    run(publish, epoch, epoch_wall);
    frames_done_ = true;
  });
  if (!voices_done_)
    voice_thread_ = std::thread([this, speak = std::move(speak), epoch, epoch_wall] {
      run_voices(speak, epoch, epoch_wall);
      voices_done_ = true;
    });
  if (!drawing_done_)
    drawing_thread_ = std::thread([this, draw = std::move(draw), epoch] {
      run_drawing(draw, epoch);
      drawing_done_ = true;
    });
}

void ReplayPlayer::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  if (voice_thread_.joinable()) voice_thread_.join();
  if (drawing_thread_.joinable()) drawing_thread_.join();
}

bool ReplayPlayer::sleep_until(Clock::time_point due) const {
  while (!stop_ && Clock::now() < due)
    std::this_thread::sleep_for(
        std::min<Clock::duration>(due - Clock::now(), std::chrono::milliseconds(20)));
  return !stop_;
}

void ReplayPlayer::run_voices(const Speak& speak, Clock::time_point epoch, int64_t epoch_wall_us) {
  const std::vector<VoiceCue>& cues = voices_.cues;
  std::vector<uint8_t> opus;
  for (uint64_t pass = 0; !stop_; ++pass) {
    const int64_t pass_us = static_cast<int64_t>(pass) * voices_.pass_us;
    const auto p = static_cast<uint32_t>(pass);
    for (size_t c = 0; c < cues.size(); ++c) {
      if (!sleep_until(epoch + std::chrono::microseconds(pass_us + cues[c].at_us))) return;
      if (bad_voice_[c]) {
        ++voices_skipped_;
        continue;
      }
      const RecordedVoice& v = reader_.info().voices[cues[c].voice];
      const VoicePlan::Speaker& s = voices_.speakers[cues[c].speaker];
      try {
        reader_.read_voice(v, opus);  // beside the frame sets' thread: pread only
      } catch (const Error& e) {
        bad_voice_[c] = 1;
        ++voices_skipped_;
        spdlog::warn("replay: a voice packet of '{}' ({:.3f} s into a pass) is skipped: {}",
                     printable(s.speaker.name), static_cast<double>(cues[c].at_us) / 1e6, e.what());
        continue;
      }
      speak(v.participant, {v.sequence + p * s.sequences_per_pass, v.frame + p * s.frames_per_pass,
                            epoch_wall_us + pass_us + cues[c].at_us, opus});
      ++voices_sent_;
    }
    if (!options_.loop) return;
  }
}

void ReplayPlayer::run_drawing(const Draw& draw, Clock::time_point epoch) {
  const std::vector<RecordedDrawing>& drawings = reader_.info().drawings;
  for (uint64_t pass = 0; !stop_; ++pass) {
    const int64_t pass_us = static_cast<int64_t>(pass) * voices_.pass_us;
    std::set<uint32_t> standing;  // recorded ids this pass added and did not erase
    for (size_t c = 0; c < drawing_.size(); ++c) {
      if (!sleep_until(epoch + std::chrono::microseconds(pass_us + drawing_[c].at_us))) return;
      const std::vector<uint8_t>& p = drawing_payloads_[c];
      if (p.empty()) continue;  // unreadable: warned when the file was opened
      const uint8_t type = drawings[drawing_[c].drawing].type;
      const uint32_t id = type == kDrawingAnnotation ? session::parse_annotation(p).id
                                                     : session::parse_erased(p).first;
      if (type == kDrawingAnnotation)
        standing.insert(id);
      else
        standing.erase(id);
      draw(type, p);
      ++drawings_sent_;
    }
    if (!options_.loop) return;
    // The pass ends: what it drew goes, so that the next one begins as the recording did.
    if (!sleep_until(epoch + std::chrono::microseconds(pass_us + voices_.pass_us))) return;
    for (const uint32_t id : standing) draw(kDrawingErased, session::serialize_erased(id, 0));
  }
}

void ReplayPlayer::run(const Publish& publish, Clock::time_point epoch, int64_t epoch_wall_us) {
  const auto& sets = reader_.info().frame_sets;
  const RecordingStream& s = reader_.info().stream;
  const size_t n = s.welcome.cameras.size();
  FrameSet decoded;
  decoded.cameras.resize(n);
  uint64_t sequence = 0, position = 0;
  std::string last_warning;
  for (uint64_t pass = 0; !stop_; ++pass) {
    const int64_t pass_start_us = static_cast<int64_t>(pass) * voices_.pass_us;
    const auto start = epoch + std::chrono::microseconds(pass_start_us);
    position += 2;  // a new pass: its first delta does not follow the last pass's end
    for (size_t k = first_; k <= last_ && !stop_; ++k, ++position) {
      const int64_t at_us = timeline_.offset_us[k] - timeline_.offset_us[first_];
      if (!sleep_until(start + std::chrono::microseconds(at_us))) break;
      auto frames = std::make_shared<CapturedFrameSet>();
      // Stamped when it is due, on the voices' time line (run_voices): a thread woken late
      // shows as latency, not as a shift between the clouds and the voices.
      frames->capture_time_us = epoch_wall_us + pass_start_us + at_us;
      try {
        decoder_.decode(k, decoded);
      } catch (const Error& e) {
        ++skipped_;
        if (e.what() != last_warning) spdlog::warn("replay: frame set {} skipped: {}", k, e.what());
        last_warning = e.what();
        continue;
      }
      // Each camera's images go to a recycled frame no published frame set holds any more, whose
      // old buffers the next decode reuses (decoders keep their own references).
      for (size_t i = 0; i < n; ++i) {
        std::shared_ptr<CameraFrame> f = buffers_.take(i);
        std::swap(decoded.cameras[i], *f);
        frames->cameras.push_back(std::move(f));
      }
      auto body = std::make_shared<EncodedFrameSetBody>();
      body->tier = s.tier;
      body->position = position;
      body->key = sets[k].key;
      const auto b = decoder_.body();
      body->body.assign(b.begin(), b.end());
      frames->encoded = std::move(body);
      frames->sequence = ++sequence;
      frames->filter_done_us = wall_clock_us();
      publish(std::move(frames));
      ++published_;
    }
    if (!options_.loop) break;
  }
}

}  // namespace volcast
