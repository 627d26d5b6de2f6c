#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <numeric>

#include "volcast/record/recording.hpp"

namespace volcast {

PlaybackTimeline playback_timeline(std::span<const RecordedFrameSet> sets) {
  PlaybackTimeline t;
  t.offset_us.reserve(sets.size());
  const auto plausible = [](int64_t gap) { return gap >= 0 && gap <= kMaxReplayGapUs; };
  std::vector<int64_t> gaps;
  gaps.reserve(sets.size());
  for (size_t k = 1; k < sets.size(); ++k) {
    const int64_t gap = sets[k].capture_us - sets[k - 1].capture_us;
    if (plausible(gap)) gaps.push_back(gap);
  }
  if (!gaps.empty()) {
    auto middle = gaps.begin() + static_cast<std::ptrdiff_t>(gaps.size() / 2);
    std::nth_element(gaps.begin(), middle, gaps.end());
    if (*middle > 0) t.frame_interval_us = *middle;
  }
  for (size_t k = 0; k < sets.size(); ++k) {
    if (k == 0) {
      t.offset_us.push_back(0);
      continue;
    }
    int64_t gap = sets[k].capture_us - sets[k - 1].capture_us;
    if (!plausible(gap)) {
      if (t.clamped_gaps++ == 0) t.first_clamped = k, t.first_clamped_gap_us = gap;
      gap = t.frame_interval_us;
    }
    t.offset_us.push_back(t.offset_us.back() + gap);
  }
  return t;
}

VoicePlan voice_plan(const RecordingInfo& info, const PlaybackTimeline& timeline, size_t first,
                     size_t last) {
  VoicePlan plan;
  const std::vector<RecordedFrameSet>& sets = info.frame_sets;
  const std::vector<int64_t>& offset = timeline.offset_us;
  if (sets.empty() || first > last || last >= sets.size() || offset.size() != sets.size())
    return plan;
  const int64_t interval = timeline.frame_interval_us;
  plan.pass_us = offset[last] - offset[first] + interval;
  // The frame sets in capture order: a voice follows the last one captured at or before it.
  std::vector<size_t> by_capture(sets.size());
  std::iota(by_capture.begin(), by_capture.end(), size_t{0});
  std::stable_sort(by_capture.begin(), by_capture.end(),
                   [&](size_t a, size_t b) { return sets[a].capture_us < sets[b].capture_us; });
  // How long frame set k shows in the replay: up to the next one, or a frame interval.
  const auto shown_us = [&](size_t k, size_t end) {
    return k == end ? interval : offset[k + 1] - offset[k];
  };
  for (const RecordedSpeaker& speaker : info.speakers) {
    std::vector<size_t> mine;  // its voices, in capture order (as RecordingReader::voices_of)
    for (size_t i = 0; i < info.voices.size(); ++i)
      if (info.voices[i].participant == speaker.participant) mine.push_back(i);
    std::stable_sort(mine.begin(), mine.end(), [&](size_t a, size_t b) {
      const RecordedVoice &x = info.voices[a], &y = info.voices[b];
      return x.capture_us != y.capture_us ? x.capture_us < y.capture_us : x.frame < y.frame;
    });
    VoicePlan::Speaker s{speaker, 0, 0, 0};
    int64_t seq_lo = 0, seq_hi = 0, frame_lo = 0, frame_hi = 0;
    const RecordedVoice* base = nullptr;  // its first cue: sequences and frames relative to it
    for (size_t i : mine) {
      const RecordedVoice& v = info.voices[i];
      const auto after =
          std::upper_bound(by_capture.begin(), by_capture.end(), v.capture_us,
                           [&](int64_t capture, size_t k) { return capture < sets[k].capture_us; });
      if (after == by_capture.begin()) {
        ++plan.outside;  // before the first frame set
        continue;
      }
      const size_t k = *(after - 1);
      const int64_t d = v.capture_us - sets[k].capture_us;
      if (d >= shown_us(k, sets.size() - 1)) {
        ++plan.outside;
        continue;
      }
      if (k < first || k > last || d >= shown_us(k, last)) continue;
      plan.cues.push_back({i, plan.speakers.size(), k, offset[k] - offset[first] + d});
      if (!base) base = &v;
      const int64_t ds = static_cast<int32_t>(v.sequence - base->sequence);
      const int64_t df = static_cast<int32_t>(v.frame - base->frame);
      seq_lo = std::min(seq_lo, ds), seq_hi = std::max(seq_hi, ds);
      frame_lo = std::min(frame_lo, df), frame_hi = std::max(frame_hi, df);
      ++s.packets;
    }
    if (s.packets == 0) continue;
    s.sequences_per_pass = static_cast<uint32_t>(seq_hi - seq_lo + 1);
    s.frames_per_pass = static_cast<uint32_t>(std::max<int64_t>(
        frame_hi - frame_lo + 1, (plan.pass_us + kVoiceFrameUs - 1) / kVoiceFrameUs));
    plan.speakers.push_back(s);
  }
  std::stable_sort(plan.cues.begin(), plan.cues.end(),
                   [&](const VoiceCue& a, const VoiceCue& b) { return a.at_us < b.at_us; });
  return plan;
}

std::string describe_span_us(int64_t us) {
  const double s = static_cast<double>(us) / 1e6, a = std::abs(s);
  if (a >= 2 * 86400.0) return fmt::format("{:.1f} days", s / 86400);
  if (a >= 2 * 3600.0) return fmt::format("{:.1f} h", s / 3600);
  if (a >= 120.0) return fmt::format("{:.1f} min", s / 60);
  if (a >= 1.0) return fmt::format("{:.1f} s", s);
  return fmt::format("{:.0f} ms", s * 1e3);
}

}  // namespace volcast
