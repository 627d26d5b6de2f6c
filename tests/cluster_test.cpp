// The stream over NATS (issue 17, part 1): chunks (exact behaviour, synthetic bytes), and the real
// hands site's tier published through a nats-server the test starts.
#include <gtest/gtest.h>

#include <algorithm>
#include <map>
#include <mutex>
#include <random>

#include "hands_site.hpp"
#include "nats_server.hpp"
#include "test_data.hpp"
#include "volcast/cluster/chunks.hpp"
#include "volcast/cluster/nats.hpp"
#include "volcast/cluster/tier_publisher.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {
using namespace cluster;
using namespace std::chrono_literals;

// Synthetic bytes (exact behaviour only).
std::vector<uint8_t> bytes_of(size_t n, uint32_t seed) {
  std::mt19937 rng(seed);
  std::vector<uint8_t> v(n);
  for (auto& b : v) b = static_cast<uint8_t>(rng());
  return v;
}

NatsOptions nats_at(const std::string& url, const std::string& user = "",
                    const std::string& password = "") {
  NatsOptions o;
  o.urls = {url};
  o.user = user;
  o.password = password;
  return o;
}

std::vector<std::vector<uint8_t>> chunks_of(const ChunkedFrameSet& f, size_t max_message) {
  std::vector<std::vector<uint8_t>> out;
  std::vector<uint8_t> scratch;
  chunk_frame_set(f, max_message, scratch,
                  [&](std::span<const uint8_t> m) { out.emplace_back(m.begin(), m.end()); });
  return out;
}

TEST(Chunks, RoundTripAtEverySizeAroundTheChunkBoundary) {
  constexpr size_t per = 1000;
  for (size_t n : {size_t{1}, per - 1, per, per + 1, 3 * per, 3 * per + 7}) {
    SCOPED_TRACE(n);
    const auto body = bytes_of(n, static_cast<uint32_t>(n));
    const ChunkedFrameSet f{42, 1'700'000'000'000'000, true, body};
    const auto messages = chunks_of(f, per + kChunkHeaderBytes);
    EXPECT_EQ(messages.size(), (n + per - 1) / per);
    Reassembler r(1 << 20);
    for (size_t i = 0; i < messages.size(); ++i)
      EXPECT_EQ(r.add(messages[i]), i + 1 == messages.size());
    const ChunkedFrameSet got = r.done();
    EXPECT_EQ(got.sequence, 42u);
    EXPECT_EQ(got.capture_us, f.capture_us);
    EXPECT_TRUE(got.key);
    EXPECT_TRUE(std::equal(got.body.begin(), got.body.end(), body.begin(), body.end()));
    EXPECT_EQ(r.stats().complete, 1u);
    EXPECT_EQ(r.stats().malformed, 0u);
  }
  std::vector<uint8_t> scratch;
  const auto one = bytes_of(10, 1);
  EXPECT_NE(test::error_of([&] {
              chunk_frame_set({1, 0, false, one}, kChunkHeaderBytes, scratch, [](auto) {});
            }),
            "");
}

TEST(Chunks, ShuffledRepeatedStaleAndAbandonedFrameSetsAreCountedNotDelivered) {
  const auto a = bytes_of(5000, 1), b = bytes_of(2500, 2);
  auto ma = chunks_of({7, 0, false, a}, 536), mb = chunks_of({8, 0, false, b}, 536);
  ASSERT_EQ(ma.size(), 10u);
  Reassembler r(1 << 20);
  std::mt19937 rng(3);
  std::shuffle(ma.begin(), ma.end(), rng);
  int completed = 0;
  for (const auto& m : ma) {
    completed += r.add(m);
    EXPECT_FALSE(r.add(m)) << "a repeat adds nothing";
  }
  EXPECT_EQ(completed, 1);
  EXPECT_TRUE(std::equal(r.done().body.begin(), r.done().body.end(), a.begin(), a.end()));
  EXPECT_FALSE(r.add(ma[0]));  // of the frame set already delivered
  EXPECT_EQ(r.stats().stale, 2u) << "the completing chunk's repeat, then this one";
  // Frame set 8 half done, then 9 begins: 8 is abandoned; a late chunk of 8 is stale.
  const auto c = bytes_of(700, 4);
  const auto mc = chunks_of({9, 0, true, c}, 536);
  EXPECT_FALSE(r.add(mb[0]));
  EXPECT_FALSE(r.add(mc[0]));
  EXPECT_FALSE(r.add(mb[1]));
  EXPECT_TRUE(r.add(mc[1]));
  EXPECT_EQ(r.done().sequence, 9u);
  EXPECT_TRUE(r.done().key);
  EXPECT_EQ(r.stats().incomplete, 1u);
  EXPECT_EQ(r.stats().stale, 3u);
  EXPECT_EQ(r.stats().complete, 2u);
}

TEST(Chunks, HostileChunksAreRefusedBeforeAnythingIsAllocatedForThem) {
  const auto body = bytes_of(3000, 5);
  const auto good = chunks_of({1, 0, false, body}, 1036);  // 3 chunks of 1000
  ASSERT_EQ(good.size(), 3u);
  const auto patched = [&](size_t chunk, size_t at, std::vector<uint8_t> bytes) {
    auto m = good[chunk];
    std::copy(bytes.begin(), bytes.end(), m.begin() + static_cast<ptrdiff_t>(at));
    return m;
  };
  const auto le32 = [](uint32_t v) {
    return std::vector<uint8_t>{uint8_t(v), uint8_t(v >> 8), uint8_t(v >> 16), uint8_t(v >> 24)};
  };
  struct Case {
    const char* what;
    std::vector<uint8_t> message;
  };
  const std::vector<Case> cases = {
      {"bad magic", patched(0, 0, {'X'})},
      {"a body above the limit", patched(0, 20, le32(64u << 20))},
      {"a zero body", patched(0, 20, le32(0))},
      {"index beyond count", patched(0, 28, {5, 0})},
      {"zero count", patched(0, 30, {0, 0})},
      {"an offset that is not index x chunk size", patched(1, 24, le32(0))},
      {"a last chunk that does not end the body", patched(2, 24, le32(1500))},
      {"unknown flags", patched(0, 32, {2})},
      {"reserved bytes set", patched(0, 33, {1})},
      {"a header only", std::vector<uint8_t>(good[0].begin(), good[0].begin() + 36)},
  };
  for (const Case& c : cases) {
    SCOPED_TRACE(c.what);
    Reassembler r(16 << 20);
    EXPECT_FALSE(r.add(c.message));
    EXPECT_EQ(r.stats().malformed, 1u);
  }
  // A chunk that disagrees with its frame set's first (another total) is refused; the set then
  // completes from the right ones.
  Reassembler r(16 << 20);
  EXPECT_FALSE(r.add(good[0]));
  EXPECT_FALSE(r.add(patched(1, 20, le32(4000))));
  EXPECT_EQ(r.stats().malformed, 1u);
  EXPECT_FALSE(r.add(good[1]));
  EXPECT_TRUE(r.add(good[2]));
}

TEST(NatsSubjects, SiteAndCodecNamesMustBeSubjectTokens) {
  EXPECT_EQ(tier_subject("or1", "volcast-t", "jpeg", 80), "volcast.or1.tier.volcast-t.jpeg.80");
  EXPECT_EQ(welcome_subject("or1"), "volcast.or1.welcome");
  for (const char* bad : {"", "a.b", "a*", ">", "a b"})
    EXPECT_NE(test::error_of([&] { welcome_subject(bad); }).find("NATS subject token"),
              std::string::npos)
        << bad;
  EXPECT_EQ(parse_nats_urls("nats://a:1,nats://b:2").size(), 2u);
  EXPECT_NE(test::error_of([] { parse_nats_urls("nats://a:1,"); }), "");
}

// The real hands site's volcast/jpeg tier through nats-server (max_payload 64 KiB, so frame sets
// are chunked): every frame set a subscriber puts back together is byte for byte what the tier
// sent its viewers, and the Welcome names the camera.
TEST(NatsStream, ARealTierReachesASubscriberByteForByteInChunks) {
  const auto dir = test::temp_dir("nats_stream");
  test::NatsServer nats_server(dir, "max_payload: 65536\n");
  test::HandsSite site(30);
  std::mutex mutex;
  std::map<uint64_t, std::vector<uint8_t>> sent, received;
  std::vector<uint8_t> welcome;
  site.server.add_tier_tap("volcast", "jpeg", 0, [&](const TierFrameSet& f) {
    std::lock_guard lock(mutex);
    sent[f.sequence].assign(f.body.begin(), f.body.end());
  });
  NatsConnection subscriber(nats_at(nats_server.url()));
  Reassembler reassembler(64 << 20);
  bool first_key = false;
  auto tier = subscriber.subscribe(tier_subject("or", "volcast", "jpeg", 0),
                                   [&](const std::string&, auto data) {
                                     if (!reassembler.add(data)) return;
                                     std::lock_guard lock(mutex);
                                     const ChunkedFrameSet f = reassembler.done();
                                     if (received.empty()) first_key = f.key;
                                     received[f.sequence].assign(f.body.begin(), f.body.end());
                                   });
  auto hello = subscriber.subscribe(welcome_subject("or"), [&](const std::string&, auto data) {
    std::lock_guard lock(mutex);
    welcome.assign(data.begin(), data.end());
  });
  NatsConnection publisher_link(nats_at(nats_server.url()));
  EXPECT_EQ(publisher_link.max_payload(), 65536u);
  {
    TierPublisher publisher(publisher_link, "or", {site.player.cameras(), 0});
    publisher.publish_tier(site.server, "volcast", "jpeg", 0);
    ASSERT_TRUE(test::eventually(
        [&] {
          std::lock_guard lock(mutex);
          return received.size() >= 30 && !welcome.empty();
        },
        60s));
    site.player.stop();
    site.server.stop();  // no more taps
    const PublisherStats st = publisher.stats();
    EXPECT_EQ(st.errors, 0u) << st.last_error;
    EXPECT_GT(st.chunks, st.frame_sets) << "frame sets above 64 KiB were chunked";
  }
  std::lock_guard lock(mutex);
  EXPECT_TRUE(first_key) << "publishing begins at a key frame set";
  for (const auto& [sequence, body] : received) {
    ASSERT_TRUE(sent.count(sequence)) << sequence;
    EXPECT_EQ(body, sent[sequence]) << "frame set " << sequence;
  }
  EXPECT_EQ(reassembler.stats().malformed, 0u);
  EXPECT_EQ(tier->dropped(), 0);
  const protocol::Welcome w = protocol::parse_welcome(welcome);
  ASSERT_EQ(w.cameras.size(), 1u);
  EXPECT_EQ(w.cameras[0].calibration.depth.width, 640);
  EXPECT_EQ(w.cameras[0].calibration.depth.height, 360);
}

// NATS authorization: a student's account may not subscribe to the OR's subjects, and a wrong
// password does not connect; each is an error that names what was refused.
TEST(NatsStream, UnauthorisedClientsCannotSubscribeToTheSite) {
  const auto dir = test::temp_dir("nats_auth");
  test::NatsServer nats_server(dir, R"(authorization {
  users = [
    {user: "server", password: "s3rver-pw", permissions: {publish: "volcast.>", subscribe: "_INBOX.>"}}
    {user: "student", password: "stud-pw", permissions: {publish: "_INBOX.>", subscribe: "volcast.lecture.>"}}
  ]
}
)");
  NatsConnection student(nats_at(nats_server.url(), "student", "stud-pw"));
  EXPECT_NO_THROW(student.subscribe(tier_subject("lecture", "volcast", "jpeg", 0),
                                    [](const std::string&, auto) {}));
  const std::string refused = test::error_of([&] {
    student.subscribe(tier_subject("or", "volcast", "jpeg", 0), [](const std::string&, auto) {});
  });
  EXPECT_NE(refused.find("volcast.or.tier.volcast.jpeg.0"), std::string::npos) << refused;
  EXPECT_NE(refused.find("ermission"), std::string::npos) << refused;
  const std::string wrong =
      test::error_of([&] { NatsConnection c(nats_at(nats_server.url(), "student", "guess")); });
  EXPECT_NE(wrong.find("cannot connect"), std::string::npos) << wrong;
  EXPECT_NO_THROW(NatsConnection(nats_at(nats_server.url(), "server", "s3rver-pw")));
}

}  // namespace
}  // namespace volcast
