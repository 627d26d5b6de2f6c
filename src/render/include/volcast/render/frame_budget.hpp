#pragma once
// Whether a viewer's camera pass blends, kept by its frame rate: the native twin of the browser's
// web/page/frame_budget.js, deciding alike. Blending costs 2-3x the plain draw (docs/benchmarks.md,
// `volcast bench --render`), and a headset's or a laptop's GPU may not keep its display's rate with
// it: there a dropped frame is worse than a seam between two cameras.
#include <cstdint>
#include <string>
#include <vector>

namespace volcast {

/// What a viewer does about blending (`volcast view --blend`, the page's blend= parameter).
enum class BlendPolicy {
  kAuto,  ///< blend while the frames keep the display's rate (FrameBudget); the default
  kOn,    ///< always blend
  kOff,   ///< never blend: the depth test picks between overlapping cameras
};

/// "auto", "on" or "off" as a BlendPolicy. Throws volcast::Error naming `text` otherwise.
BlendPolicy parse_blend_policy(const std::string& text);

/// Decides when blending must go. Fed each frame's time and whether it was drawn blended, it turns
/// blending off once the median of the last `window_us` of blended frames (at least `min_frames`
/// of them) is over `over` x the display's period, and says why (reason()). It never turns
/// blending back on: a frame's time cannot tell how much a plain frame leaves to spare (the
/// display's vsync rounds it up to its period). A frame over 5 s (a stalled or hidden window) and
/// a frame drawn plain count for nothing.
///
/// A frame's time is what the viewer measures: the interval between two frames' display times (a
/// headset's runtime paces the frames), or from the start of drawing to the return of the swap
/// (a window, whose swap waits for the display).
///
/// Allocation-free per frame: the window is a ring of kMaxFrames, filled in the constructor.
class FrameBudget {
 public:
  static constexpr int64_t kWindowUs = 2'000'000;
  static constexpr int kMinFrames = 10;
  static constexpr double kOver = 1.5;
  static constexpr int64_t kLongestCountedUs = 5'000'000;
  /// Frames the window holds at most (2 s of frames of 0.5 ms); past that the oldest go even if
  /// the rest spans less than window_us.
  static constexpr size_t kMaxFrames = 4096;

  /// `period_us`: the display's frame period (µs, 1e6 / its refresh rate). Throws volcast::Error
  /// if `period_us` <= 0, `window_us` <= 0, `min_frames` is not 1..kMaxFrames or `over` <= 0.
  explicit FrameBudget(int64_t period_us, int64_t window_us = kWindowUs,
                       int min_frames = kMinFrames, double over = kOver);

  /// The display changed (a headset's runtime gave another period): the frames so far are
  /// forgotten. Ignored if `period_us` <= 0 or equal to the period.
  void set_period(int64_t period_us);
  /// One frame that took `frame_us` (µs), drawn blended or not. Returns true if this frame turned
  /// blending off.
  bool add(int64_t frame_us, bool blended);

  bool blend() const { return blend_; }
  int64_t period_us() const { return period_us_; }
  /// Why blending went off, in one line naming the median frame time, the period and how to keep
  /// blending; empty while it is on.
  const std::string& reason() const { return reason_; }

 private:
  void clear();
  int64_t limit_us() const;

  int64_t period_us_, window_us_;
  int min_frames_;
  double over_;
  bool blend_ = true;
  std::string reason_;
  std::vector<int64_t> ring_;  // kMaxFrames slots; the window is count_ of them from first_
  size_t first_ = 0, count_ = 0;
  int64_t span_us_ = 0;    // the window's sum
  size_t over_count_ = 0;  // frames in the window over limit_us()
};

}  // namespace volcast
