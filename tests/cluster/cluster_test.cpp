// The stream over NATS (issue 17, part 1): chunks (exact behaviour, synthetic bytes), and the real
// hands site's tier published through a nats-server the test starts.
#include <gtest/gtest.h>

#include <algorithm>
#include <atomic>
#include <fstream>
#include <map>
#include <mutex>
#include <nlohmann/json.hpp>
#include <random>

#include "support/hands_site.hpp"
#include "support/test_data.hpp"
#include "support/test_paths.hpp"
#include "volcast/cluster/chunks.hpp"
#include "volcast/cluster/local_cluster.hpp"
#include "volcast/cluster/nats.hpp"
#include "volcast/cluster/relay.hpp"
#include "volcast/cluster/remote_site.hpp"
#include "volcast/cluster/tier_publisher.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/protocol/frame_set.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/net/transport/tls.hpp"

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
  // The publisher restarts and counts from 1: a delta below the sequence is stale, the first
  // chunk of a key frame set starts over.
  EXPECT_FALSE(r.add(chunks_of({2, 0, false, c}, 536)[0]));
  EXPECT_EQ(r.stats().stale, 4u);
  const auto restarted = chunks_of({1, 5, true, c}, 536);
  EXPECT_FALSE(r.add(restarted[1])) << "not its first chunk: stale";
  EXPECT_FALSE(r.add(restarted[0]));
  EXPECT_TRUE(r.add(restarted[1]));
  EXPECT_EQ(r.done().sequence, 1u);
  EXPECT_EQ(r.stats().restarts, 1u);
  EXPECT_TRUE(r.add(chunks_of({2, 6, false, c}, 1000)[0])) << "and goes on from there";
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
  EXPECT_EQ(tier_subject("or1", Tier{"volcast-t", "jpeg", 80}),
            "volcast.or1.tier.volcast-t.jpeg.80");
  EXPECT_EQ(welcome_subject("or1"), "volcast.or1.welcome");
  for (const char* bad : {"", "a.b", "a*", ">", "a b"})
    EXPECT_NE(test::error_of([&] { welcome_subject(bad); }).find("NATS subject token"),
              std::string::npos)
        << bad;
  // A tier on NATS carries every frame set: a divided one has no subject.
  EXPECT_NE(test::error_of([] {
              tier_subject("or1", Tier{"volcast", "jpeg", 0, 2});
            }).find("no @N"),
            std::string::npos);
  EXPECT_EQ(want_subject("or1", Tier{"volcast-t", "jpeg", 80}),
            "volcast.or1.want.volcast-t.jpeg.80");
  EXPECT_EQ(parse_nats_urls("nats://a:1,nats://b:2").size(), 2u);
  EXPECT_NE(test::error_of([] { parse_nats_urls("nats://a:1,"); }), "");
}

// The real hands site's volcast/jpeg tier through nats-server (max_payload 64 KiB, so frame sets
// are chunked): every frame set a subscriber puts back together is byte for byte what the tier
// sent its viewers, and the Welcome names the camera.
TEST(NatsStream, ARealTierReachesASubscriberByteForByteInChunks) {
  const auto dir = test::temp_dir("nats_stream");
  LocalNatsCluster nats_server(dir, 1, "max_payload: 65536");
  test::HandsSite site(30);
  std::mutex mutex;
  std::map<uint64_t, std::vector<uint8_t>> sent, received;
  std::vector<uint8_t> welcome;
  site.server.add_tier_tap({"volcast", "jpeg"}, [&](const TierFrameSet& f) {
    std::lock_guard lock(mutex);
    sent[f.index].assign(f.body.begin(), f.body.end());
  });
  NatsConnection subscriber(nats_at(nats_server.url(0)));
  Reassembler reassembler(64 << 20);
  bool first_key = false;
  auto tier = subscriber.subscribe(tier_subject("or", Tier{"volcast", "jpeg", 0}),
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
  NatsConnection publisher_link(nats_at(nats_server.url(0)));
  EXPECT_EQ(publisher_link.max_payload(), 65536u);
  {
    TierPublisher publisher(publisher_link, "or", {site.player.cameras(), 0});
    publisher.publish_tier(site.server, Tier{"volcast", "jpeg", 0});
    TierInterest want(subscriber, "or", Tier{"volcast", "jpeg", 0});  // published while wanted
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

// Publishing on demand: a tier nobody wants is not encoded at all; a subscriber's want starts it
// (from a key frame set), and when the wants stop, so does the tier.
TEST(NatsStream, ATierIsEncodedAndPublishedOnlyWhileSomebodyWantsIt) {
  const auto dir = test::temp_dir("nats_demand");
  LocalNatsCluster nats_server(dir, 1, "max_payload: 65536");
  test::HandsSite site(30);
  NatsConnection link(nats_at(nats_server.url(0)));
  TierPublisher publisher(link, "or", {site.player.cameras(), 0}, 1000, 1000);
  publisher.publish_tier(site.server, Tier{"trvl", "jpeg", 0});
  std::this_thread::sleep_for(1500ms);
  EXPECT_TRUE(site.server.tiers().empty()) << "nobody wants it: nothing is encoded";
  EXPECT_EQ(publisher.stats().frame_sets, 0u);
  NatsConnection subscriber(nats_at(nats_server.url(0)));
  Reassembler reassembler(64 << 20);
  std::atomic<int> complete{0};
  std::atomic<bool> first_key{false};
  auto tier = subscriber.subscribe(tier_subject("or", Tier{"trvl", "jpeg", 0}),
                                   [&](const std::string&, auto data) {
                                     if (!reassembler.add(data)) return;
                                     if (complete++ == 0) first_key = reassembler.done().key;
                                   });
  {
    TierInterest want(subscriber, "or", Tier{"trvl", "jpeg", 0}, 200);
    ASSERT_TRUE(test::eventually([&] { return complete >= 20; }, 60s));
    EXPECT_TRUE(first_key) << "a subscriber starts at a key frame set";
    ASSERT_EQ(site.server.tiers().size(), 1u);
    EXPECT_EQ(site.server.tiers()[0].tier.depth_codec, "trvl");
    const uint64_t keys = site.server.tiers()[0].key_frames;
    want.request_key();  // a relay that lost a delta
    EXPECT_TRUE(test::eventually(
        [&] {
          const auto t = site.server.tiers();
          return !t.empty() && t[0].key_frames > keys;
        },
        60s))
        << "a key frame set on request, before the interval's (60)";
  }
  // The stop is counted just after the tap is removed: wait for both.
  EXPECT_TRUE(test::eventually(
      [&] { return site.server.tiers().empty() && publisher.stats().stops > 0; }, 60s))
      << "nobody wants it any more: the tier stopped";
  const PublisherStats st = publisher.stats();
  EXPECT_EQ(st.starts, 1u);
  EXPECT_EQ(st.stops, 1u);
  EXPECT_GE(st.key_requests, 1u);
  EXPECT_EQ(st.errors, 0u) << st.last_error;
}

// libnats hands an async subscription's messages over on a thread of its own, which may still be
// between two messages when the subscription and then its connection are gone (a CI run's ASan: a
// heap-use-after-free in the message callback, NatsConnection's subscription freed with the
// connection). Now the connection waits for each subscription's last delivery. Here a publisher
// keeps a subject busy while a subscriber connects, takes some of it, and goes -- subscription,
// then connection, at once -- many times over; synthetic bytes.
TEST(NatsStream, ASubscriptionAndItsConnectionGoWhileMessagesAreStillArriving) {
  const auto dir = test::temp_dir("nats_teardown");
  LocalNatsCluster nats_server(dir, 1);
  NatsConnection publisher(nats_at(nats_server.url(0)));
  std::atomic<bool> stop{false};
  std::thread publishing([&] {
    const std::vector<uint8_t> message = bytes_of(256, 1);
    while (!stop) {
      for (int i = 0; i < 200; ++i) publisher.publish("busy", message);
      publisher.flush();
    }
  });
  for (int round = 0; round < 40; ++round) {
    SCOPED_TRACE(round);
    auto subscriber = std::make_unique<NatsConnection>(nats_at(nats_server.url(0)));
    std::atomic<int> delivered{0};
    auto subscription = subscriber->subscribe("busy", [&](const std::string&, auto data) {
      if (data.size() == 256) ++delivered;
    });
    ASSERT_TRUE(test::eventually([&] { return delivered >= 50; }));
    subscription.reset();  // while messages keep arriving
    subscriber.reset();
  }
  stop = true;
  publishing.join();
}

// NATS authorization: a student's account may not subscribe to the OR's subjects, and a wrong
// password does not connect; each is an error that names what was refused.
TEST(NatsStream, UnauthorisedClientsCannotSubscribeToTheSite) {
  const auto dir = test::temp_dir("nats_auth");
  LocalNatsCluster nats_server(dir, 1, R"(authorization {
  users = [
    {user: "server", password: "s3rver-pw", permissions: {publish: "volcast.>", subscribe: "_INBOX.>"}}
    {user: "student", password: "stud-pw", permissions: {publish: "_INBOX.>", subscribe: "volcast.lecture.>"}}
  ]
}
)");
  NatsConnection student(nats_at(nats_server.url(0), "student", "stud-pw"));
  EXPECT_NO_THROW(student.subscribe(tier_subject("lecture", Tier{"volcast", "jpeg", 0}),
                                    [](const std::string&, auto) {}));
  const std::string refused = test::error_of([&] {
    student.subscribe(tier_subject("or", Tier{"volcast", "jpeg", 0}),
                      [](const std::string&, auto) {});
  });
  EXPECT_NE(refused.find("volcast.or.tier.volcast.jpeg.0"), std::string::npos) << refused;
  EXPECT_NE(refused.find("ermission"), std::string::npos) << refused;
  const std::string wrong =
      test::error_of([&] { NatsConnection c(nats_at(nats_server.url(0), "student", "guess")); });
  EXPECT_NE(wrong.find("cannot connect"), std::string::npos) << wrong;
  EXPECT_NO_THROW(NatsConnection(nats_at(nats_server.url(0), "server", "s3rver-pw")));
}

// TLS to the cluster: a node that presents a certificate named "localhost" and verifies its
// clients' certificates. The certificates are self-signed, each its own CA.
TEST(NatsStream, TlsToTheClusterChecksTheNodesCertificateAndTheClients) {
  const auto dir = test::temp_dir("nats_tls");
  const auto write = [&](const std::string& name, const TlsIdentity& id) {
    std::ofstream(dir / (name + ".pem")) << id.certificate_pem;
    std::ofstream(dir / (name + ".key")) << id.private_key_pem;
    return (dir / name).string();
  };
  const std::string node = write("node", make_self_signed_identity("localhost"));
  const std::string relay = write("relay", make_self_signed_identity("volcast-relay"));
  const std::string stranger = write("stranger", make_self_signed_identity("localhost"));
  LocalNatsCluster nats_server(dir, 1,
                               "tls {\n  cert_file: \"" + node + ".pem\"\n  key_file: \"" + node +
                                   ".key\"\n  ca_file: \"" + relay +
                                   ".pem\"\n  verify: true\n  timeout: 5\n}\n");
  const auto tls = [&](const std::string& ca, const std::string& name, bool client_cert) {
    NatsOptions o = nats_at(nats_server.url(0));
    o.ca_file = ca + ".pem";
    o.tls_name = name;
    if (client_cert) o.cert_file = relay + ".pem", o.key_file = relay + ".key";
    return o;
  };
  // Everything right: a message goes through.
  NatsConnection a(tls(node, "localhost", true)), b(tls(node, "localhost", true));
  std::atomic<int> got{0};
  auto sub = b.subscribe(welcome_subject("or"), [&](const std::string&, auto data) {
    if (data.size() == 3 && data[2] == 7) ++got;
  });
  const std::vector<uint8_t> message{1, 2, 7};
  for (int i = 0; i < 200 && got == 0; ++i) {
    a.publish(welcome_subject("or"), message);
    a.flush();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  EXPECT_GT(got.load(), 0);
  // Each wrong thing is refused, with a reason.
  const std::string plain = test::error_of([&] { NatsConnection c(nats_at(nats_server.url(0))); });
  EXPECT_NE(plain.find("cannot connect"), std::string::npos) << plain;
  const std::string other_ca =
      test::error_of([&] { NatsConnection c(tls(stranger, "localhost", true)); });
  EXPECT_NE(other_ca.find("SSL"), std::string::npos) << other_ca;
  const std::string other_name =
      test::error_of([&] { NatsConnection c(tls(node, "nats.elsewhere", true)); });
  EXPECT_NE(other_name.find("hostname mismatch"), std::string::npos) << other_name;
  const std::string no_cert =
      test::error_of([&] { NatsConnection c(tls(node, "localhost", false)); });
  EXPECT_NE(no_cert.find("--nats-cert"), std::string::npos) << no_cert;
  const std::string missing =
      test::error_of([&] { NatsConnection c(tls((dir / "absent").string(), "", false)); });
  EXPECT_NE(missing.find("absent.pem"), std::string::npos) << missing;
  NatsOptions tls_url = nats_at("tls://127.0.0.1:4222");
  const std::string no_ca = test::error_of([&] { NatsConnection c(tls_url); });
  EXPECT_NE(no_ca.find("--nats-ca"), std::string::npos) << no_ca;
}

// The origin: the real hands site (one camera) publishing a tier on a nats-server (64 KiB
// messages, so frame sets are chunked), and every frame set the tier encoded, by capture time.
struct PublishedSite {
  std::filesystem::path dir;
  LocalNatsCluster nats_server;
  test::HandsSite site;
  std::optional<NatsConnection> link;
  std::optional<TierPublisher> publisher;
  std::mutex mutex;
  std::map<int64_t, std::vector<uint8_t>> sent;  // by capture time (us)

  PublishedSite(const std::string& name, const std::string& depth, const std::string& color,
                ServerConfig config = {})
      : dir(test::temp_dir(name)), nats_server(dir, 1, "max_payload: 65536"), site(30, config) {
    site.server.add_tier_tap({depth, color}, [this](const TierFrameSet& f) {
      std::lock_guard lock(mutex);
      sent[f.capture_us].assign(f.body.begin(), f.body.end());
    });
    link.emplace(nats_at(nats_server.url(0)));
    publisher.emplace(*link, "or", protocol::Welcome{site.player.cameras(), 0});
    publisher->publish_tier(site.server, Tier{depth, color, 0});
  }
  ~PublishedSite() {
    site.player.stop();
    site.server.stop();
  }
  std::optional<std::vector<uint8_t>> body_at(int64_t capture_us) {
    std::lock_guard lock(mutex);
    const auto it = sent.find(capture_us);
    if (it == sent.end()) return std::nullopt;
    return it->second;
  }
};

// A relay on a free port. Its latency budget counts from the site's capture; a loaded test box
// may take longer than the default 150 ms through NATS, and these tests check what arrives.
RelayOptions relay_options() {
  RelayOptions o;
  o.server.port = 0;
  o.server.latency_budget_ms = 5000;
  return o;
}

ClientConfig viewer_of(Relay& relay, const std::string& depth, const std::string& color) {
  ClientConfig c = client_config_from_link(relay.server().join_link("127.0.0.1"));
  c.tier.depth_codec = depth;
  c.tier.color_codec = color;
  c.keep_encoded = true;
  c.receive_timeout_ms = 30000;
  return c;
}

// The payload parse_frame_set expects: 8 bytes of send time, then the body.
std::vector<uint8_t> as_message(std::span<const uint8_t> body) {
  std::vector<uint8_t> m(8, 0);
  m.insert(m.end(), body.begin(), body.end());
  return m;
}

// A viewer of the published tier on a relay is sent the publisher's own bytes for every camera
// (the relay does not encode again), with the site's capture time; a viewer of another tier
// (rvl, lossless, encoded by the relay) decodes the same depth, pixel for pixel, from its first
// frame set on.
TEST(Relay, ViewersOfARelayGetThePublishersBytesAndLosslessDepthBitExact) {
  PublishedSite origin("relay_exact", "volcast", "jpeg");
  NatsConnection relay_link(nats_at(origin.nats_server.url(0)));
  RelayOptions o = relay_options();
  Relay relay(relay_link, o);
  ASSERT_EQ(relay.cameras().size(), 1u);
  EXPECT_EQ(relay.cameras()[0].calibration.depth.width, 640);
  Client same(viewer_of(relay, "volcast", "jpeg"));
  FrameSetDecoder reference("volcast", "jpeg", relay.cameras());
  FrameSet expected;
  int compared = 0;
  ReceivedFrameSet rx, rx_other;
  bool first = true;
  while (compared < 30) {
    ASSERT_TRUE(same.receive(rx)) << "the relay's viewer lost its stream";
    EXPECT_TRUE(!first || rx.key) << "a viewer starts at a key frame set";
    first = false;
    const auto body = origin.body_at(rx.times.capture_us);
    ASSERT_TRUE(body) << "a frame set the site never encoded (capture " << rx.times.capture_us
                      << ")";
    protocol::FrameSetView got, want;
    const auto got_message = as_message(rx.encoded_body), want_message = as_message(*body);
    protocol::parse_frame_set(got_message, got);
    protocol::parse_frame_set(want_message, want);
    ASSERT_EQ(got.cameras.size(), 1u);
    EXPECT_TRUE(std::ranges::equal(got.cameras[0].depth, want.cameras[0].depth));
    EXPECT_TRUE(std::ranges::equal(got.cameras[0].color, want.cameras[0].color));
    EXPECT_EQ(got.cameras[0].device_timestamp_us, want.cameras[0].device_timestamp_us);
    ++compared;
  }
  // The rvl viewer comes 30 frame sets later: the relay has not decoded those (its one tier
  // passed them through), and the images standing in are its first's. The rvl tier must wait
  // for a frame set decoded for it, not encode those with a later capture time.
  Client other(viewer_of(relay, "rvl", "none"));
  for (int n = 0; n < 15; ++n) {
    ASSERT_TRUE(other.receive(rx_other));
    const auto body = origin.body_at(rx_other.times.capture_us);
    ASSERT_TRUE(body);
    reference.decode(as_message(*body), expected);
    EXPECT_EQ(rx_other.frames.cameras[0].depth.pixels, expected.cameras[0].depth.pixels)
        << "rvl is lossless: the relay re-encoded what the site sent";
    EXPECT_TRUE(rx_other.frames.cameras[0].color.bgra.empty());
  }
  const RelayStats st = relay.stats();
  EXPECT_GE(st.frame_sets, 30u);
  EXPECT_GE(st.decoded, 15u) << "the rvl tier is encoded here, from decoded images";
  EXPECT_EQ(st.undecodable, 0u) << st.last_error;
  EXPECT_EQ(st.chunks.malformed, 0u);
  EXPECT_GT(st.chunks.complete, 0u);
}

// A temporal tier (tRVL deltas): a viewer that comes to the relay late starts at a key frame set
// and decodes every frame set after it.
TEST(Relay, ALateViewerOfATemporalTierStartsAtAKeyFrameSet) {
  ServerConfig site_config;
  site_config.key_frame_interval = 20;
  PublishedSite origin("relay_late", "trvl", "jpeg", site_config);
  NatsConnection relay_link(nats_at(origin.nats_server.url(0)));
  RelayOptions o = relay_options();
  o.tier.depth_codec = "trvl";
  Relay relay(relay_link, o);
  // The relay came in mid-stream: deltas before the site's next key frame set are dropped.
  ASSERT_TRUE(test::eventually([&] { return relay.stats().frame_sets >= 30; }, 60s));
  const uint64_t waited = relay.stats().undecodable;
  EXPECT_LE(waited, 20u) << "at most one key frame interval";
  Client late(viewer_of(relay, "trvl", "jpeg"));
  ReceivedFrameSet rx;
  for (int n = 0; n < 30; ++n) {
    ASSERT_TRUE(late.receive(rx)) << "frame set " << n;
    if (n == 0) {
      EXPECT_TRUE(rx.key);
    }
    ASSERT_EQ(rx.frames.cameras.size(), 1u);
    EXPECT_EQ(rx.frames.cameras[0].depth.width, 640);
    EXPECT_GT(
        std::ranges::count_if(rx.frames.cameras[0].depth.pixels, [](uint16_t d) { return d; }),
        1000)
        << "frame set " << n << " decoded to depth";
  }
  EXPECT_EQ(relay.stats().undecodable, waited) << relay.stats().last_error;
}

// The NATS server goes away for a second and comes back on the same port: the relay's viewer
// stays connected and the stream resumes (libnats reconnects the site and the relay).
TEST(Relay, AViewerOfARelayOutlivesANatsRestart) {
  PublishedSite origin("relay_restart", "volcast", "jpeg");
  NatsConnection relay_link(nats_at(origin.nats_server.url(0)));
  RelayOptions o = relay_options();
  Relay relay(relay_link, o);
  Client viewer(viewer_of(relay, "volcast", "jpeg"));
  ReceivedFrameSet rx;
  for (int n = 0; n < 10; ++n) ASSERT_TRUE(viewer.receive(rx));
  origin.nats_server.kill(0);
  std::this_thread::sleep_for(1s);
  origin.nats_server.restart(0);
  const int64_t back = wall_clock_us();
  int after = 0;
  while (after < 10) {
    ASSERT_TRUE(viewer.receive(rx)) << "the viewer was dropped";
    if (rx.times.capture_us > back) ++after;
  }
  const RelayStats st = relay.stats();
  EXPECT_EQ(st.undecodable, 0u) << st.last_error;
  EXPECT_EQ(st.decoded, 1u) << "every viewer takes the published stateless tier: only the first "
                               "frame set was decoded (images in reserve), of "
                            << st.frame_sets;
}

TEST(Relay, WithoutTheSitesWelcomeItSaysWhatItWaitedFor) {
  const auto dir = test::temp_dir("relay_nobody");
  LocalNatsCluster nats_server(dir, 1);
  NatsConnection link(nats_at(nats_server.url(0)));
  RelayOptions o;
  o.site = "theatre2";
  o.welcome_timeout_ms = 300;
  o.server.port = 0;
  const std::string e = test::error_of([&] { Relay r(link, o); });
  EXPECT_NE(e.find("volcast.theatre2.welcome"), std::string::npos) << e;
  EXPECT_NE(e.find("theatre2"), std::string::npos) << e;
}

// A 3-node cluster (nats-server processes routed to each other): the site publishes on node 0,
// the relay takes the stream from node 1; node 1 is killed, the relay's link moves to another
// node and its viewer goes on without being dropped.
TEST(Relay, ARelayOutlivesTheKillOfItsNatsNodeInAThreeNodeCluster) {
  const auto dir = test::temp_dir("relay_cluster");
  LocalNatsCluster nats(dir, 3, "max_payload: 65536");
  test::HandsSite site(30);
  NatsOptions site_link;
  site_link.urls = nats.urls(0);
  site_link.in_order = true;
  NatsConnection site_nats(site_link);
  EXPECT_EQ(site_nats.connected_url(), nats.url(0));
  TierPublisher publisher(site_nats, "or", {site.player.cameras(), 0});
  publisher.publish_tier(site.server, Tier{"volcast", "jpeg", 0});
  NatsOptions relay_link;
  relay_link.urls = nats.urls(1);
  relay_link.in_order = true;
  NatsConnection relay_nats(relay_link);
  ASSERT_EQ(relay_nats.connected_url(), nats.url(1));
  Relay relay(relay_nats, relay_options());
  Client viewer(viewer_of(relay, "volcast", "jpeg"));
  ReceivedFrameSet rx;
  for (int n = 0; n < 10; ++n) ASSERT_TRUE(viewer.receive(rx)) << "through node 0 to node 1";
  nats.kill(1);
  const int64_t killed = wall_clock_us();
  int after = 0;
  while (after < 10) {
    ASSERT_TRUE(viewer.receive(rx)) << "the viewer was dropped";
    if (rx.times.capture_us > killed) ++after;
  }
  const std::string now = relay_nats.connected_url();
  EXPECT_TRUE(now == nats.url(0) || now == nats.url(2)) << now;
  EXPECT_EQ(relay.stats().undecodable, 0u) << relay.stats().last_error;
  site.player.stop();
  site.server.stop();
}

// Capture nodes: the hands camera of a node (its own site, publishing volcast/jpeg on NATS)
// joined to a site that reads the hands sequence itself: one two-camera site in which the node's
// depth is the frame it read, exactly. When the node stops sending, its camera is marked failed
// and the site goes on.
TEST(CaptureNode, ANodesCameraJoinsTheSiteExactlyAndAStoppedNodeIsMarkedFailed) {
  PublishedSite node("nats_capture_node", "volcast", "jpeg");
  NatsConnection link(nats_at(node.nats_server.url(0)));
  RemoteSiteOptions o;
  o.site = "or";
  o.fps = 15;
  o.stale_ms = 500;
  RemoteSite remote(link, o);
  ASSERT_EQ(remote.cameras().size(), 1u);
  EXPECT_EQ(remote.cameras()[0].calibration.depth.width, 640);
  auto sources = test::HandsSite::sources();
  const double hands_fps = sources[0]->fps();
  for (auto& s : remote.sources()) sources.push_back(std::move(s));
  EXPECT_NE(sources[1]->description().find("capture node 'or'"), std::string::npos);
  SiteOptions options;
  options.max_read_failures = 5;
  SitePlayer site(std::move(sources), 15, {}, options);
  std::mutex mutex;
  std::vector<std::shared_ptr<const CapturedFrameSet>> got;
  site.start([&](std::shared_ptr<const CapturedFrameSet> f) {
    std::lock_guard lock(mutex);
    if (got.size() < 400) got.push_back(std::move(f));
  });
  ASSERT_TRUE(test::eventually(
      [&] { return remote.stats().frame_sets >= 20 && site.frame_sets_published() >= 30; }, 60s));
  {
    std::lock_guard lock(mutex);
    int checked = 0;
    for (const auto& f : got) {
      ASSERT_EQ(f->cameras.size(), 2u);
      const CameraFrame& c = *f->cameras[1];
      if (std::all_of(c.depth.pixels.begin(), c.depth.pixels.end(), [](uint16_t d) { return !d; }))
        continue;  // before the node's first frame set: an empty frame
      if (checked >= 5) break;
      const auto n = std::llround(static_cast<double>(c.device_timestamp_us) * hands_fps / 1e6);
      EXPECT_EQ(c.depth, test::hands_source_frame(static_cast<uint64_t>(n % 207) + 1))
          << "the node's frame " << n << ", lossless";
      EXPECT_FALSE(c.color.bgra.empty()) << "with its color";
      ++checked;
    }
    EXPECT_EQ(checked, 5);
  }
  EXPECT_FALSE(site.camera_status()[1].failed);
  node.site.player.stop();  // the node stops sending; NATS and the site go on
  ASSERT_TRUE(test::eventually([&] { return site.camera_status()[1].failed; }, 60s));
  EXPECT_FALSE(site.camera_status()[0].failed);
  EXPECT_NE(site.camera_status()[1].last_error.find("nothing from the node"), std::string::npos)
      << site.camera_status()[1].last_error;
  const uint64_t at_failure = site.frame_sets_published();
  EXPECT_TRUE(test::eventually([&] { return site.frame_sets_published() >= at_failure + 10; }, 60s))
      << "the site goes on without the node";
  site.stop();
}

TEST(LocalNatsCluster, ANodeThatCannotStartNamesItsLog) {
  const auto dir = test::temp_dir("cluster_bad");
  const std::string e = test::error_of([&] { LocalNatsCluster c(dir, 2, "this is { not config"); });
  EXPECT_NE(e.find("node-0.log"), std::string::npos) << e;
}

// The link printed in `log` (a volcast:// join link), waiting up to 20 s for it.
std::string join_link_in(const std::filesystem::path& log) {
  for (int attempt = 0; attempt < 100; ++attempt) {
    std::ifstream in(log);
    for (std::string line; std::getline(in, line);)
      if (line.find("volcast://") != std::string::npos) return line.substr(line.find("volcast://"));
    std::this_thread::sleep_for(200ms);
  }
  return "";
}

// What a user runs: `volcast serve --nats`, `volcast relay` on the same cluster, and `volcast
// view` with the relay's link.
TEST(RelayCommand, ServeRelayAndViewThroughNats) {
  const auto dir = test::temp_dir("relay_cli");
  LocalNatsCluster nats_server(dir, 1);
  const std::string volcast =
      std::string("XDG_CONFIG_HOME=") + (dir / "config").string() + " " + test::paths::volcast();
  std::string out;
  ASSERT_EQ(test::run_command(volcast + " serve --source " + test::hands_dir().string() +
                                  " --intrinsics 460,460,320,180 --fps 15 --seconds 90 --port 0 "
                                  "--nats " +
                                  nats_server.url(0) + " --nats-site theatre1 > " +
                                  (dir / "serve.log").string() + " 2>&1 & echo $!",
                              out),
            0);
  const std::string serve_pid = out.substr(0, out.find('\n'));
  ASSERT_FALSE(join_link_in(dir / "serve.log").empty());
  ASSERT_EQ(test::run_command(volcast + " relay --nats " + nats_server.url(0) +
                                  " --site theatre1 --relay-name hall-1 --seconds 90 --port 0 > " +
                                  (dir / "relay.log").string() + " 2>&1 & echo $!",
                              out),
            0);
  const std::string relay_pid = out.substr(0, out.find('\n'));
  const std::string link = join_link_in(dir / "relay.log");
  // Two participants of session OR: one through the relay, one on the site's own server (in the
  // background, a little longer). Each must see the other.
  const std::string join = " --join OR --name ";
  ASSERT_EQ(test::run_command(volcast + " view --no-render --connect '" +
                                  join_link_in(dir / "serve.log") + "' --frames 150" + join +
                                  "Direct --stats-json " + (dir / "direct.json").string() + " > " +
                                  (dir / "direct.log").string() + " 2>&1 & echo $!",
                              out),
            0);
  const std::string direct_pid = out.substr(0, out.find('\n'));
  std::string view_out;
  const int rc = link.empty()
                     ? -1
                     : test::run_command(volcast + " view --no-render --connect '" + link +
                                             "' --frames 60" + join + "Relayed" + " --stats-json " +
                                             (dir / "view.json").string(),
                                         view_out);
  test::run_command("while kill -0 " + direct_pid + " 2>/dev/null; do sleep 0.2; done", out);
  test::run_command("kill " + relay_pid + " " + serve_pid, out);
  std::this_thread::sleep_for(500ms);
  std::ifstream relay_log(dir / "relay.log");
  const std::string relay_text((std::istreambuf_iterator<char>(relay_log)),
                               std::istreambuf_iterator<char>());
  ASSERT_FALSE(link.empty()) << relay_text;
  ASSERT_EQ(rc, 0) << view_out << relay_text;
  EXPECT_NE(relay_text.find("site 'theatre1' (1 camera(s))"), std::string::npos) << relay_text;
  std::ifstream in(dir / "view.json");
  const auto stats = nlohmann::json::parse(in);
  EXPECT_EQ(stats["cameras"][0]["frames_received"], 60);
  EXPECT_EQ(stats["cameras"][0]["description"], "camera 0") << "the site's name for it";
  // The relayed participant and the direct one saw each other's poses (the session's hub is the
  // site's; the relay carried the relayed one's messages over NATS).
  std::ifstream direct_in(dir / "direct.json");
  const auto direct = nlohmann::json::parse(direct_in);
  const auto poses_from = [](const nlohmann::json& j, const std::string& name) {
    for (const auto& o : j["others"])
      if (o["name"] == name) return o["poses_received"].get<uint64_t>();
    return uint64_t{0};
  };
  EXPECT_EQ(stats["session"], "OR");
  EXPECT_GT(poses_from(stats, "Direct"), 0u) << stats.dump();
  EXPECT_GT(poses_from(direct, "Relayed"), 0u) << direct.dump();
  EXPECT_NE(relay_text.find("sessions through this relay (as hall-1)"), std::string::npos)
      << relay_text;
  // Nobody publishing that site: one line that says what the relay waited for.
  EXPECT_NE(test::run_command(volcast + " relay --nats " + nats_server.url(0) +
                                  " --site theatre9 --welcome-timeout 300 --port 0",
                              out),
            0);
  EXPECT_NE(out.find("volcast.theatre9.welcome"), std::string::npos) << out;
}

}  // namespace
}  // namespace volcast
