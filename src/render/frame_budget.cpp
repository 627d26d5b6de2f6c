#include "volcast/render/frame_budget.hpp"

#include <fmt/format.h>
#include <algorithm>

#include "volcast/core/error.hpp"

namespace volcast {

BlendPolicy parse_blend_policy(const std::string& text) {
  if (text == "auto") return BlendPolicy::kAuto;
  if (text == "on") return BlendPolicy::kOn;
  if (text == "off") return BlendPolicy::kOff;
  throw Error("blend: expected auto, on or off, not '" + text + "'");
}

FrameBudget::FrameBudget(int64_t period_us, int64_t window_us, int min_frames, double over)
    : period_us_(period_us), window_us_(window_us), min_frames_(min_frames), over_(over) {
  if (period_us <= 0)
    throw Error(fmt::format("frame budget: the period must be positive, not {} us", period_us));
  if (window_us <= 0)
    throw Error(fmt::format("frame budget: the window must be positive, not {} us", window_us));
  if (min_frames < 1 || size_t(min_frames) > kMaxFrames)
    throw Error(
        fmt::format("frame budget: min_frames must be 1..{}, not {}", kMaxFrames, min_frames));
  if (!(over > 0)) throw Error(fmt::format("frame budget: over must be positive, not {}", over));
  ring_.resize(kMaxFrames);
}

void FrameBudget::clear() {
  first_ = count_ = over_count_ = 0;
  span_us_ = 0;
}

int64_t FrameBudget::limit_us() const {
  return int64_t(over_ * double(period_us_));
}

void FrameBudget::set_period(int64_t period_us) {
  if (period_us <= 0 || period_us == period_us_) return;
  period_us_ = period_us;
  clear();
}

bool FrameBudget::add(int64_t frame_us, bool blended) {
  if (!blend_ || !blended || frame_us <= 0 || frame_us > kLongestCountedUs) return false;
  const int64_t limit = limit_us();
  auto drop_oldest = [&] {
    const int64_t oldest = ring_[first_];
    span_us_ -= oldest;
    over_count_ -= oldest > limit;
    first_ = (first_ + 1) % kMaxFrames;
    --count_;
  };
  if (count_ == kMaxFrames) drop_oldest();
  ring_[(first_ + count_) % kMaxFrames] = frame_us;
  ++count_;
  span_us_ += frame_us;
  over_count_ += frame_us > limit;
  while (count_ > size_t(min_frames_) && span_us_ - ring_[first_] >= window_us_) drop_oldest();
  const bool full = count_ == kMaxFrames || span_us_ >= window_us_;
  if (!full || count_ < size_t(min_frames_)) return false;
  // The median (the sorted window's element n / 2) is over the limit iff at least n - n / 2
  // frames are.
  if (over_count_ < count_ - count_ / 2) return false;
  std::vector<int64_t> sorted;  // once, for the reason
  for (size_t i = 0; i < count_; ++i) sorted.push_back(ring_[(first_ + i) % kMaxFrames]);
  std::nth_element(sorted.begin(), sorted.begin() + std::ptrdiff_t(count_ / 2), sorted.end());
  blend_ = false;
  reason_ = fmt::format(
      "blending off: frames took {:.1f} ms blended (the median of the last {}), the display's "
      "period is {:.1f} ms (--blend on keeps it on)",
      double(sorted[count_ / 2]) / 1000.0, count_, double(period_us_) / 1000.0);
  return true;
}

}  // namespace volcast
