#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>

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

std::string describe_span_us(int64_t us) {
  const double s = static_cast<double>(us) / 1e6, a = std::abs(s);
  if (a >= 2 * 86400.0) return fmt::format("{:.1f} days", s / 86400);
  if (a >= 2 * 3600.0) return fmt::format("{:.1f} h", s / 3600);
  if (a >= 120.0) return fmt::format("{:.1f} min", s / 60);
  if (a >= 1.0) return fmt::format("{:.1f} s", s);
  return fmt::format("{:.0f} ms", s * 1e3);
}

}  // namespace volcast
