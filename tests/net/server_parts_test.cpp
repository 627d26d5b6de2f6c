// The server's parts on their own (src/net/stream: session_outbox.hpp, ladder.hpp,
// tier_budget.hpp), on synthetic timelines and configs: exact behaviour, no network, no clock.
// What a viewer sees of them end to end is in stream_test.cpp and adapt_stream_test.cpp.
#include <gtest/gtest.h>

#include <memory>
#include <vector>

#include "ladder.hpp"
#include "session_outbox.hpp"
#include "tier_budget.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/stream/server.hpp"
#include "volcast/net/stream/session_port.hpp"

namespace volcast::detail {
namespace {

using Wake = SessionOutbox::Wake;

std::shared_ptr<const std::vector<uint8_t>> msg(uint8_t b) {
  return std::make_shared<const std::vector<uint8_t>>(1, b);
}

// A talker's voice key as the hub makes it (hub_state.hpp): a queued stream per speaker.
uint64_t voice(uint64_t speaker) {
  return kQueuedStreamKey | (uint64_t{5} << 32) | speaker;
}

struct OutboxTimeline {
  SessionOutbox box;
  uint64_t dropped = 0;
  int64_t coalesce_us = 8'000;
  Wake queue(uint64_t key, uint8_t b, int64_t now) {
    return box.queue(
        msg(b), key, now, coalesce_us, [] { return false; }, dropped);
  }
  std::vector<uint8_t> take(int64_t now, SessionOutbox::Taken* taken = nullptr) {
    std::vector<SessionOutbox::Message> batch;
    const auto t = box.take(now, coalesce_us, batch);
    if (taken) *taken = t;
    std::vector<uint8_t> out;
    for (const auto& m : batch) out.push_back(m->at(0));
    return out;
  }
};

TEST(SessionOutbox, OneTalkersPacketsWakeTheThreadOnceForWhatIsWaiting) {
  OutboxTimeline t;
  EXPECT_EQ(t.queue(voice(1), 1, 0), Wake::kNow);        // nobody else talks: nothing to wait for
  EXPECT_EQ(t.queue(voice(1), 2, 20'000), Wake::kNone);  // told already; not taken yet
  EXPECT_EQ(t.take(20'000), (std::vector<uint8_t>{1, 2}));
  EXPECT_EQ(t.queue(voice(1), 3, 40'000), Wake::kNow);  // taken: told again
  EXPECT_EQ(t.dropped, 0u);
}

TEST(SessionOutbox, TwoTalkersPacketsGoOutTogetherOrWhenTheOldestIsDue) {
  OutboxTimeline t;
  // Both talk: their packets 20 ms apart each, 3 ms apart from each other.
  t.queue(voice(1), 1, 0);
  t.queue(voice(2), 2, 3'000);
  ASSERT_EQ(t.take(3'000), (std::vector<uint8_t>{1, 2}));
  // Talker 1's next packet waits for talker 2's: the timer is armed for 8 ms after it.
  EXPECT_EQ(t.queue(voice(1), 3, 20'000), Wake::kAt);
  EXPECT_EQ(t.box.timer_due_us(), 28'000);
  SessionOutbox::Taken taken;
  EXPECT_TRUE(t.take(21'000, &taken).empty());
  EXPECT_EQ(taken.due_us, 28'000);
  // Talker 2's arrives: both complete, the thread is woken now, and the timer is disarmed.
  EXPECT_EQ(t.queue(voice(2), 4, 23'000), Wake::kNow);
  EXPECT_EQ(t.take(23'000, &taken), (std::vector<uint8_t>{3, 4}));
  EXPECT_TRUE(taken.disarm);
  // Talker 2 falls silent: talker 1's packet goes when it is 8 ms old, not before.
  EXPECT_EQ(t.queue(voice(1), 5, 40'000), Wake::kAt);
  EXPECT_TRUE(t.take(47'999).empty());
  EXPECT_EQ(t.take(48'000, &taken), (std::vector<uint8_t>{5}));
  EXPECT_FALSE(taken.disarm);  // the timer fired: nothing to disarm
  // 30 ms after its last packet talker 2 no longer counts as talking: nothing is held.
  EXPECT_EQ(t.queue(voice(1), 6, 60'000), Wake::kNow);
}

TEST(SessionOutbox, AnyOtherMessageSendsHeldPacketsAtOnceAndInOrder) {
  OutboxTimeline t;
  t.queue(voice(1), 1, 0);
  t.queue(voice(2), 2, 1'000);
  t.take(1'000);
  EXPECT_EQ(t.queue(voice(1), 3, 20'000), Wake::kAt);
  EXPECT_EQ(t.queue(0, 9, 20'500), Wake::kNow);  // a pose, an annotation: not held
  EXPECT_EQ(t.take(20'500), (std::vector<uint8_t>{3, 9}));
}

TEST(SessionOutbox, WithoutCoalescingNothingIsHeldAndAKeyedMessageIsReplaced) {
  OutboxTimeline t;
  t.coalesce_us = 0;
  t.queue(voice(1), 1, 0);
  t.queue(voice(2), 2, 1'000);
  t.take(1'000);
  EXPECT_EQ(t.queue(voice(1), 3, 20'000), Wake::kNow);
  t.queue(7, 4, 20'100);  // a pose under its participant's key
  t.queue(7, 5, 20'200);  // the newer replaces it, in its place
  EXPECT_EQ(t.take(20'300), (std::vector<uint8_t>{3, 5}));
  EXPECT_EQ(t.dropped, 0u);
}

TEST(SessionOutbox, ATalkerNotReadDropsItsOldestBeyondTheHeldSecond) {
  OutboxTimeline t;
  for (int i = 0; i < int(kMaxHeldPerStream) + 2; ++i) t.queue(voice(1), uint8_t(i), i * 20'000);
  EXPECT_EQ(t.dropped, 2u);
  const auto sent = t.take(10'000'000);
  ASSERT_EQ(sent.size(), kMaxHeldPerStream);
  EXPECT_EQ(sent.front(), 2);  // the two oldest went
}

ServerConfig ladder_config(std::vector<std::string> rungs, std::vector<double> sizes = {}) {
  ServerConfig c;
  c.ladder = std::move(rungs);
  c.ladder_sizes = std::move(sizes);
  return c;
}

TEST(Ladder, OffersTakeTheirCodecsAndTheQualityOnlyWhenNamed) {
  const auto offers = parse_offers({"volcast/jpeg", "rvl/jpeg/90"});
  EXPECT_TRUE(offered(offers, parse_tier("volcast/jpeg/40", "t")));
  EXPECT_TRUE(offered(offers, parse_tier("rvl/jpeg/90", "t")));
  EXPECT_FALSE(offered(offers, parse_tier("rvl/jpeg/80", "t")));
  EXPECT_FALSE(offered(offers, parse_tier("volcast/none", "t")));
  EXPECT_TRUE(offered({}, parse_tier("volcast/none", "t")));  // no list: everything
  EXPECT_THROW(parse_offers({"volcast/jpeg@2"}), Error);      // @N is the ladder's alone
  EXPECT_THROW(parse_offers({"nosuch/jpeg"}), Error);
}

TEST(Ladder, KeepsTheOfferedRungsWithTheirSizesAndRefusesABadOne) {
  const auto l = make_ladder(
      ladder_config({"volcast/jpeg/70", "rvl/jpeg/50", "volcast/jpeg/50@2"}, {1.0, 0.6, 0.5}),
      parse_offers({"volcast/jpeg"}));
  ASSERT_EQ(l.rungs.size(), 2u);
  EXPECT_EQ(to_string(l.rungs[1]), "volcast/jpeg/50@2");
  EXPECT_EQ(l.sizes, (std::vector<double>{1.0, 0.5}));
  EXPECT_THROW(make_ladder(ladder_config({"volcast/nosuch"}), {}), Error);
  EXPECT_THROW(make_ladder(ladder_config({"volcast/jpeg"}, {0.0}), {}), Error);
}

TEST(Ladder, AViewersFloorsDecodersRefusalsAndCapLeaveItsRungs) {
  const auto l = make_ladder(
      ladder_config({"volcast/jpeg/70", "volcast-n2/jpeg/50", "volcast/jpeg/50@2", "volcast/none"}),
      {});
  const std::vector<double> bits{40e6, 20e6, 0, 5e6};  // rung 2 not measured: under any cap
  std::vector<char> ok;
  ViewerFloor f;
  allowed_rungs(l, f, bits, 0, ok);
  EXPECT_EQ(ok, (std::vector<char>{1, 1, 1, 1}));
  f.adapt = protocol::Hello::kAdapt | protocol::Hello::kKeepLossless;
  allowed_rungs(l, f, bits, 0, ok);
  EXPECT_EQ(ok, (std::vector<char>{1, 0, 1, 1}));
  f.adapt |= protocol::Hello::kKeepFullRate;
  f.max_bits_per_s = 30'000'000;
  allowed_rungs(l, f, bits, 0, ok);
  EXPECT_EQ(ok, (std::vector<char>{0, 0, 0, 1}));
  allowed_rungs(l, f, bits, 0, ok, false);  // the floors alone
  EXPECT_EQ(ok, (std::vector<char>{1, 0, 0, 1}));
  f = {};
  f.decodes = {"volcast", "jpeg"};
  f.top = 1;
  f.refused_until = {0, 0, 5'000'000, 0};
  allowed_rungs(l, f, bits, 4'000'000, ok);
  EXPECT_EQ(ok, (std::vector<char>{0, 0, 0, 0}));  // above its top; refused; no "none" decoder
  allowed_rungs(l, f, bits, 5'000'000, ok);
  EXPECT_EQ(ok, (std::vector<char>{0, 0, 1, 0}));
}

TEST(Ladder, RungsNotRunningAreEstimatedFromARunningOneBySize) {
  const auto l = make_ladder(
      ladder_config({"volcast/jpeg/70", "volcast-n2/jpeg/50", "volcast/jpeg/50@2"}, {1, 0.5, 0.25}),
      {});
  std::vector<double> bits{0, 10e6, 0};
  estimate_unmeasured(l, 1, bits);
  EXPECT_EQ(bits, (std::vector<double>{20e6, 10e6, 5e6}));
  bits = {0, 0, 0};
  estimate_unmeasured(l, 0, bits);  // nothing measured: nothing to scale
  EXPECT_EQ(bits, (std::vector<double>{0, 0, 0}));
}

TEST(TierBudgetRules, CountsAtThePeakRateAndRefusesTheTierThatDoesNotFit) {
  TierBudget b;
  b.cores = 2;
  EXPECT_EQ(b.site_fps(), 30);                                // before a second of frame sets
  for (int i = 0; i < 33; ++i) b.note_published(i * 20'000);  // 50 fps
  EXPECT_DOUBLE_EQ(b.site_fps(), 50);
  for (int i = 33; i < 100; ++i) b.note_published(i * 100'000);  // slowed to 10 fps for 6.7 s
  EXPECT_DOUBLE_EQ(b.site_fps(), 50);                            // the peak of the last 30 s holds
  EXPECT_DOUBLE_EQ(b.cores_of(10e6), 0.5);
  EXPECT_NO_THROW(check_tier_fits(b, "a", 0.5, {1.4, 0, 0}, 4, true));
  EXPECT_THROW(check_tier_fits(b, "a", 0.7, {1.4, 0, 0}, 4, true), Error);
  EXPECT_THROW(check_tier_fits(b, "a", 0.5, {0.9, 0.6, 1}, 4, true), Error);  // over its half
  EXPECT_NO_THROW(check_tier_fits(b, "a", 0.5, {0.9, 0.6, 1}, 4, false));     // a rung: total only
  EXPECT_THROW(check_tier_fits(b, "a", 0.1, {0.4, 0.4, 4}, 4, true), Error);  // four held alone
  b.site_pixels = 640 * 576;  // one Azure Kinect's depth
  b.passed_through = parse_tier("volcast/jpeg", "t");
  EXPECT_EQ(b.encode_ns(parse_tier("volcast/jpeg", "t")), 0);
  EXPECT_GT(b.encode_ns(parse_tier("volcast/jpeg/50", "t")), 0);
}

}  // namespace
}  // namespace volcast::detail
