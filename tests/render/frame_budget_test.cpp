// The native viewers' frame budget (volcast/render/frame_budget.hpp): frame times fed as a
// display presents them. Synthetic times: exact behaviour only. The cases and figures are those of
// the page's (web/test/frame_budget_test.mjs, WebFrameBudget.*), so both decide alike.
#include "volcast/render/frame_budget.hpp"

#include <gtest/gtest.h>

#include <vector>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

constexpr int64_t kPeriod = 1'000'000 / 72;  // a headset's display, µs

// Feeds `n` frames of `us` each, drawn blended or not; returns the index of the frame that turned
// blending off, or -1.
int feed(FrameBudget& budget, int64_t us, int n, bool blended = true) {
  int off = -1;
  for (int i = 0; i < n; ++i)
    if (budget.add(us, blended)) {
      EXPECT_EQ(off, -1) << "blending is turned off once";
      off = i;
    }
  return off;
}

// Frames at the display's rate, and a little slower (within 1.5 periods), keep blending.
TEST(FrameBudget, KeepsBlendingWhileFramesKeepTheDisplaysRate) {
  FrameBudget b(kPeriod);
  EXPECT_EQ(feed(b, kPeriod, 500), -1);
  EXPECT_EQ(feed(b, kPeriod * 145 / 100, 500), -1);
  EXPECT_TRUE(b.blend());
  EXPECT_EQ(b.reason(), "");
}

// Frames of 40 ms (under 25 a second) on a 72 Hz display turn blending off once they span the
// window (2 s: the 50th), and the reason says the figures and how to keep blending.
TEST(FrameBudget, TurnsBlendingOffWhenTheMedianFrameIsTooSlow) {
  FrameBudget b(kPeriod);
  EXPECT_EQ(feed(b, 40'000, 200), 49);
  EXPECT_FALSE(b.blend());
  EXPECT_EQ(b.reason(),
            "blending off: frames took 40.0 ms blended (the median of the last 50), the display's "
            "period is 13.9 ms (--blend on keeps it on)");
  // It stays off, whatever comes after.
  EXPECT_EQ(feed(b, kPeriod, 500), -1);
  EXPECT_FALSE(b.blend());
}

// The median of the window, not its mean: 20 ms frames keep a 13.9 ms period (under 20.8 ms),
// 25 ms ones do not. 40 slow then 200 fast: the median is fast, blending stays; 40 fast then slow
// ones span 2 s with the median slow at the 88th.
TEST(FrameBudget, DecidesOnTheMedian) {
  FrameBudget b(kPeriod);
  EXPECT_EQ(feed(b, 25'000, 40), -1);
  EXPECT_EQ(feed(b, 20'000, 200), -1);
  EXPECT_TRUE(b.blend());
  FrameBudget c(kPeriod);
  EXPECT_EQ(feed(c, 20'000, 40), -1);
  EXPECT_EQ(feed(c, 25'000, 200), 87 - 40);
}

// A stalled window (6 s), frames drawn plain and fewer than 10 frames, however long, count for
// nothing.
TEST(FrameBudget, StallsPlainFramesAndAShortStartCountForNothing) {
  FrameBudget b(kPeriod);
  EXPECT_EQ(feed(b, 6'000'000, 30), -1);
  EXPECT_EQ(feed(b, 3 * kPeriod, 300, false), -1);
  EXPECT_EQ(feed(b, 300'000, 9), -1) << "2.7 s in 9 frames";
  EXPECT_TRUE(b.blend());
  EXPECT_EQ(feed(b, 300'000, 1), 0) << "the 10th frame decides";
}

// A new display period (a headset's runtime gave another) forgets the frames measured against the
// old one.
TEST(FrameBudget, ANewPeriodStartsTheWindowAgain) {
  FrameBudget b(1'000'000 / 60);
  EXPECT_EQ(feed(b, 30'000, 60), -1) << "1.8 s: not yet";
  b.set_period(1'000'000 / 20);
  EXPECT_EQ(feed(b, 30'000, 300), -1) << "30 ms frames keep a 50 ms period";
  b.set_period(1'000'000 / 60);
  EXPECT_EQ(feed(b, 30'000, 100), 66) << "2 s of 30 ms frames: the 67th";
  EXPECT_THROW(FrameBudget(0), Error);
  EXPECT_THROW(FrameBudget(kPeriod, 0), Error);
  EXPECT_THROW(FrameBudget(kPeriod, FrameBudget::kWindowUs, 0), Error);
}

// Frames too short to span the window in kMaxFrames (0.3 ms on a 0.1 ms period: 1.2 s) decide
// once the ring is full.
TEST(FrameBudget, AFullRingDecidesBeforeTheWindowIsSpanned) {
  FrameBudget b(100);
  EXPECT_EQ(feed(b, 300, 5000), int(FrameBudget::kMaxFrames) - 1);
  EXPECT_FALSE(b.blend());
}

TEST(FrameBudget, PolicyParsesItsThreeWordsAndNamesAnyOther) {
  EXPECT_EQ(parse_blend_policy("auto"), BlendPolicy::kAuto);
  EXPECT_EQ(parse_blend_policy("on"), BlendPolicy::kOn);
  EXPECT_EQ(parse_blend_policy("off"), BlendPolicy::kOff);
  try {
    parse_blend_policy("sometimes");
    ADD_FAILURE() << "no throw";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("'sometimes'"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace volcast
