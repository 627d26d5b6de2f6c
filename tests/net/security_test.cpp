// TLS, join tokens, certificate pinning and the server's door policy, on loopback with the real
// hands sequence: who gets in, who does not, and that those who do not cost the others nothing.
#include <gtest/gtest.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <asio.hpp>
#include <fstream>
#include <sstream>
#include <thread>

#include "support/hands_site.hpp"
#include "support/test_data.hpp"
#include "support/web_peer.hpp"
#include "volcast/codec_video/video_codecs.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/protocol/join.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/net/transport/tls.hpp"
#include "volcast/net/transport/trust.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;
using test::HandsSite;

// Receives `n` frame sets as the viewer of `config`; returns how many arrived.
int receive(const ClientConfig& config, int n) {
  Client client(config);
  ReceivedFrameSet rx;
  int got = 0;
  while (got < n && client.receive(rx)) ++got;
  return got;
}

ClientConfig joining(const Server& server) {
  return client_config_from_link(server.join_link("127.0.0.1"));
}

using test::error_of;

// A TCP socket from loopback address `source` (127.0.0.x) to the server, saying nothing.
asio::ip::tcp::socket idle_socket(asio::io_context& io, const std::string& source, uint16_t port) {
  asio::ip::tcp::socket s(io);
  s.open(asio::ip::tcp::v4());
  s.bind({asio::ip::make_address(source), 0});
  s.connect({asio::ip::make_address("127.0.0.1"), port});
  return s;
}

int threads_in_process() {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind("Threads:", 0) == 0) return std::stoi(line.substr(8));
  return -1;
}

// Waits (bounded) until `done` holds.
bool eventually(const std::function<bool()>& done) {
  return test::eventually(done, std::chrono::seconds(10));
}

TEST(JoinLink, RoundTripsAndRefusesMalformedLinksWithoutEchoingTheToken) {
  JoinLink link;
  link.host = "192.168.1.20";
  link.port = 7300;
  link.token = random_join_token();
  link.fingerprint = std::string(64, 'a');
  const std::string text = format_join_link(link);
  EXPECT_EQ(text.rfind("volcast://192.168.1.20:7300/?token=", 0), 0u);
  const JoinLink back = parse_join_link(text);
  EXPECT_EQ(back.host, link.host);
  EXPECT_EQ(back.port, 7300);
  EXPECT_EQ(back.token, link.token);
  EXPECT_EQ(back.fingerprint, link.fingerprint);

  link.host = "::1";
  EXPECT_EQ(parse_join_link(format_join_link(link)).host, "::1");

  const std::string token = to_hex(link.token);
  for (const std::string& bad :
       {"http://h:1/?token=" + token + "&fp=" + std::string(64, 'a'),
        "volcast://h/?token=" + token + "&fp=" + std::string(64, 'a'),
        "volcast://h:0/?token=" + token + "&fp=" + std::string(64, 'a'),
        "volcast://h:70000/?token=" + token + "&fp=" + std::string(64, 'a'),
        "volcast://h:1/?fp=" + std::string(64, 'a'),
        "volcast://h:1/?token=" + token.substr(1) + "x&fp=" + std::string(64, 'a'),
        "volcast://h:1/?token=" + token, "volcast://h:1/?token=" + token + "&fp=abc",
        "volcast://h:1/?token=" + token + "&insecure=1&fp=" + std::string(64, 'a'),
        "volcast://h\n:1/?token=" + token + "&insecure=1",
        "volcast://h:1/?token=" + token + "&insecure=1&debug=1"}) {
    const std::string why = error_of([&] { parse_join_link(bad); });
    EXPECT_FALSE(why.empty()) << bad;
    EXPECT_EQ(why.find(token.substr(4, 20)), std::string::npos) << why;
  }
  EXPECT_TRUE(tokens_equal(link.token, link.token));
  JoinToken other = link.token;
  other[15] ^= 1;
  EXPECT_FALSE(tokens_equal(link.token, other));
}

TEST(Tls, ViewerWithTheLinkStreamsOverTls13) {
  HandsSite site(30);
  EXPECT_EQ(site.server.fingerprint().size(), 64u);
  EXPECT_EQ(receive(joining(site.server), 10), 10);
  EXPECT_EQ(site.server.door().admitted, 1u);
}

TEST(Tls, WrongTokenIsRefusedAndCostsNoViewerSlot) {
  HandsSite site(30);
  ClientConfig c = joining(site.server);
  c.token[0] ^= 0xff;
  const std::string why = error_of([&] { Client{c}; });
  EXPECT_NE(why.find("wrong join token"), std::string::npos) << why;
  EXPECT_EQ(site.server.door().wrong_token, 1u);
  EXPECT_EQ(site.server.door().admitted, 0u);
  EXPECT_TRUE(site.server.viewers().empty());  // never a viewer, never a tier
  EXPECT_TRUE(site.server.tiers().empty());
  EXPECT_EQ(receive(joining(site.server), 5), 5);  // the right token still gets in
}

// Wrong tokens back the address off (further wrong ones are turned away, each doubling the
// wait), but a right token is always accepted -- everyone behind one NAT is not locked out by one
// mistyped link -- and lifts nothing for the wrong ones.
TEST(Door, ARightTokenIsAcceptedDuringTheBackOff) {
  HandsSite site(30);
  ClientConfig wrong = joining(site.server);
  wrong.token[3] ^= 1;
  for (int i = 0; i < kFreeWrongTokens; ++i) {
    const std::string why = error_of([&] { Client{wrong}; });
    EXPECT_NE(why.find("wrong join token"), std::string::npos) << why;
  }
  for (int i = 0; i < 2; ++i) {  // backed off: 1 s, then 2 s, now 4 s
    const std::string why = error_of([&] { Client{wrong}; });
    EXPECT_NE(why.find("try again in"), std::string::npos) << why;
  }
  EXPECT_EQ(receive(joining(site.server), 3), 3);
  const std::string why = error_of([&] { Client{wrong}; });
  EXPECT_NE(why.find("try again in"), std::string::npos) << why;
  EXPECT_EQ(site.server.door().wrong_token, static_cast<uint64_t>(kFreeWrongTokens));
  EXPECT_EQ(site.server.door().backed_off, 3u);
  EXPECT_EQ(site.server.door().admitted, 1u);
}

TEST(Tls, AChangedFingerprintIsRefusedBeforeTheTokenIsSent) {
  HandsSite site(30);
  const fs::path known = test::temp_dir("tls_pins") / "known_servers";
  fs::remove(known);
  const std::string where = "127.0.0.1:" + std::to_string(site.server.port());

  // The link's fingerprint is not the server's.
  ClientConfig c = joining(site.server);
  c.fingerprint = std::string(64, '0');
  std::string why = error_of([&] { Client{c}; });
  EXPECT_NE(why.find("join link says"), std::string::npos) << why;

  // First use of HOST:PORT without a fingerprint pins it; later connections must match it.
  c.fingerprint.clear();
  c.known_servers = known.string();
  EXPECT_EQ(receive(c, 2), 2);
  std::ifstream in(known);
  std::stringstream text;
  text << in.rdbuf();
  EXPECT_NE(text.str().find(where + " " + site.server.fingerprint()), std::string::npos);
  EXPECT_EQ(receive(c, 2), 2);

  // Another certificate at the same HOST:PORT (as after a server's key was replaced).
  {
    std::ofstream out(known, std::ios::trunc);
    out << where << " " << std::string(64, 'b') << "\n";
  }
  why = error_of([&] { Client{c}; });
  EXPECT_NE(why.find("not the one pinned"), std::string::npos) << why;
  EXPECT_NE(why.find(known.string() + " line 1"), std::string::npos) << why;
  // Refused before the Hello: the door saw no token at all (2 viewers admitted above, no more).
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_EQ(site.server.door().admitted, 2u);
  EXPECT_EQ(site.server.door().wrong_token, 0u);
}

// Several viewers of one user started at once (as a participant joining a site and its relay)
// each pin a server: every pin is kept and none of them fails to write the file.
TEST(Tls, PinsStoredAtOnceAreAllKept) {
  const fs::path known = test::temp_dir("tls_pins_at_once") / "config" / "known_servers";
  fs::remove_all(known.parent_path());
  constexpr int kViewers = 8, kServersEach = 12;
  std::vector<std::string> errors(kViewers);
  std::vector<std::thread> viewers;
  for (int v = 0; v < kViewers; ++v)
    viewers.emplace_back([&, v] {
      errors[v] = error_of([&] {
        for (int s = 0; s < kServersEach; ++s)
          check_server_fingerprint(known,
                                   "10.0." + std::to_string(v) + "." + std::to_string(s) + ":7000",
                                   std::string(64, static_cast<char>('a' + v % 6)), "");
      });
    });
  for (auto& t : viewers) t.join();
  for (const auto& e : errors) EXPECT_EQ(e, "");
  std::ifstream in(known);
  int pins = 0;
  for (std::string line; std::getline(in, line);) pins += line.rfind("10.0.", 0) == 0;
  EXPECT_EQ(pins, kViewers * kServersEach);
  // Each is now pinned: the same fingerprint is accepted, another refused.
  EXPECT_EQ(check_server_fingerprint(known, "10.0.3.5:7000", std::string(64, 'd'), ""),
            TrustDecision::kPinned);
  EXPECT_NE(error_of([&] {
              check_server_fingerprint(known, "10.0.3.5:7000", std::string(64, 'e'), "");
            }).find("not the one pinned"),
            std::string::npos);
}

TEST(Tls, APlainTcpClientGetsNothingButATlsAlert) {
  HandsSite site(30);
  asio::io_context io;
  auto s = idle_socket(io, "127.0.0.1", site.server.port());
  protocol::Hello hello;
  hello.token = site.server.token();  // even with the right token, in the clear
  hello.tier.depth_codec = "volcast";
  hello.tier.color_codec = "jpeg";
  asio::write(s, asio::buffer(
                     protocol::message(protocol::MessageType::kHello, protocol::serialize(hello))));
  std::vector<uint8_t> answer;
  asio::error_code ec;
  uint8_t buf[4096];
  while (!ec) {
    const size_t n = s.read_some(asio::buffer(buf), ec);
    answer.insert(answer.end(), buf, buf + n);
  }
  ASSERT_FALSE(answer.empty());
  EXPECT_EQ(answer[0], 0x15);  // a TLS record of type alert, and nothing of the stream
  EXPECT_LE(answer.size(), 16u);
  EXPECT_EQ(site.server.door().admitted, 0u);
}

TEST(Tls, InsecureIsRefusedBeyondLoopback) {
  ServerConfig config;
  config.port = 0;
  config.insecure = true;
  config.bind_address = "0.0.0.0";
  std::vector<protocol::CameraInfo> cameras(1);
  cameras[0].calibration.depth = Intrinsics{64, 48, 50, 50, 32, 24};
  const std::string why = error_of([&] { Server(cameras, config); });
  EXPECT_NE(why.find("only on a loopback"), std::string::npos) << why;
  config.bind_address = "localhost";  // a name resolving to loopback is fine
  Server server(cameras, config);
  EXPECT_NE(server.join_link("localhost").find("insecure=1"), std::string::npos);

  ClientConfig c;
  c.host = "192.0.2.1";  // TEST-NET-1: never reached, refused before connecting
  c.insecure = true;
  EXPECT_NE(error_of([&] { Client{c}; }).find("only to a loopback"), std::string::npos);
}

TEST(Door, IdleSocketsFromManyAddressesCostNoThreadAndKeepNoViewerOut) {
  ServerConfig config;
  config.max_viewers = 1;  // pending handshakes must not count as viewers
  HandsSite site(30, config);
  const int threads_before = threads_in_process();
  asio::io_context io;
  std::vector<asio::ip::tcp::socket> idle;
  for (int i = 0; i < 30; ++i)
    idle.push_back(idle_socket(io, "127.0.0." + std::to_string(2 + i), site.server.port()));
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  EXPECT_LE(threads_in_process(), threads_before + 1);  // no thread per pending handshake
  EXPECT_EQ(receive(joining(site.server), 10), 10);
  EXPECT_EQ(site.server.door().over_limit, 0u);
}

TEST(Door, PendingHandshakesAreLimitedPerAddressAndInTotalAndTimeOut) {
  ServerConfig config;
  config.max_pending = 16;
  config.max_pending_per_address = 4;
  config.handshake_timeout_ms = 3000;
  HandsSite site(30, config);
  asio::io_context io;
  std::vector<asio::ip::tcp::socket> idle;
  for (int i = 0; i < 10; ++i) idle.push_back(idle_socket(io, "127.0.0.2", site.server.port()));
  EXPECT_TRUE(eventually([&] { return site.server.door().over_limit == 6u; }));
  for (int i = 0; i < 20; ++i)
    idle.push_back(idle_socket(io, "127.0.0." + std::to_string(3 + i), site.server.port()));
  // 4 + 20 > 16: the oldest are dropped for newcomers; a real viewer still gets in.
  EXPECT_TRUE(eventually([&] { return site.server.door().over_limit == 6u + 8u; }));
  EXPECT_EQ(receive(joining(site.server), 5), 5);  // it displaced one more idle socket
  EXPECT_EQ(site.server.door().over_limit, 6u + 8u + 1u);
  // The other 15 time out.
  EXPECT_TRUE(eventually([&] { return site.server.door().failed == 15u; }));
}

// A viewer the door turns away (its address has the most pending handshakes) retries with
// back-off, one warning line per retry, and gets in once the idle handshakes time out; with a
// shorter budget it gives up naming the busy server.
TEST(Door, AViewerTurnedAwayAsBusyRetriesUntilASlotFrees) {
  auto stream = std::make_shared<std::ostringstream>();
  auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(*stream);
  auto previous = spdlog::default_logger();
  spdlog::set_default_logger(std::make_shared<spdlog::logger>("capture", sink));
  ServerConfig config;
  config.max_pending_per_address = 2;
  config.handshake_timeout_ms = 1500;
  HandsSite site(30, config);
  asio::io_context io;
  std::vector<asio::ip::tcp::socket> idle;
  // The door accepts in connection order: these two are pending before the viewer arrives.
  for (int i = 0; i < 2; ++i) idle.push_back(idle_socket(io, "127.0.0.1", site.server.port()));
  ClientConfig c = joining(site.server);
  c.connect_timeout_ms = 120'000;  // bounds a broken door; the slot frees after 1.5 s
  EXPECT_EQ(receive(c, 3), 3);
  EXPECT_GE(site.server.door().over_limit, 1u);  // it was turned away at least once
  EXPECT_EQ(site.server.door().failed, 2u);      // the two idle handshakes timed out

  // Idle handshakes that outlive the viewer's budget: it gives up, saying why.
  for (int i = 0; i < 2; ++i) idle.push_back(idle_socket(io, "127.0.0.1", site.server.port()));
  c.connect_timeout_ms = 400;
  const std::string why = error_of([&] { Client{c}; });
  spdlog::set_default_logger(previous);
  EXPECT_NE(why.find("may be busy"), std::string::npos) << why;
  const std::string log = stream->str();
  size_t retries = 0;
  std::istringstream in(log);
  for (std::string line; std::getline(in, line);)
    retries += line.find("dropped the TLS handshake (busy with others?): retry ") != line.npos;
  EXPECT_GE(retries, 2u) << log;  // at least one per attempt
  EXPECT_NE(log.find("retry 1 in 100 ms"), std::string::npos) << log;
}

TEST(Door, OnlyOfferedTiersAreServedAndTheRejectNamesThem) {
  ServerConfig config;
  config.offered_tiers = {"volcast/jpeg", "rvl/none/0"};
  HandsSite site(30, config);
  ClientConfig c = joining(site.server);
  c.tier.depth_codec = "trvl";
  const std::string why = error_of([&] { Client{c}; });
  EXPECT_NE(why.find("offers volcast/jpeg, rvl/none/0"), std::string::npos) << why;
  c.tier.depth_codec = "rvl";
  c.tier.color_codec = "none";
  EXPECT_EQ(receive(c, 3), 3);

  config.offered_tiers = {"volcast/bogus"};
  EXPECT_THROW(HandsSite(30, config), Error);
}

// One token holder asking for the costliest tiers (HEVC depth, H.264 color, at eight qualities)
// is refused each past the server's tier CPU budget, the reject naming the tier's cost and the
// budget; the tier already served and its viewer, and a cheap new tier, keep being served. An
// address also holds at most max_tiers_per_address tiers nobody else watches.
TEST(Door, CostliestTiersPastTheCpuBudgetAreRefusedAndTheCheapOnesStillServed) {
  register_video_codecs();  // h264 and hevc, as the volcast CLI offers them
  ServerConfig config;
  // Cores. Charged at 30 fps for the hands site: volcast/jpeg ~0.08, raw/none ~0.002, and
  // hevc/h264 ~1.6 (it fits only below 6 fps).
  config.tier_cpu_budget = 0.3;
  config.max_tiers_per_address = 2;
  HandsSite site(30, config);
  Client honest(joining(site.server));  // volcast/jpeg
  ReceivedFrameSet rx;
  ASSERT_TRUE(honest.receive(rx));
  ClientConfig greedy = joining(site.server);
  greedy.tier.depth_codec = "hevc";
  greedy.tier.color_codec = "h264";
  for (int quality = 10; quality <= 80; quality += 10) {
    greedy.tier.color_quality = quality;
    const std::string why = error_of([&] { Client{greedy}; });
    EXPECT_NE(why.find("tier hevc/h264/" + std::to_string(quality) + " would cost about"),
              std::string::npos)
        << why;
    EXPECT_NE(why.find("budget is 0.30 cores"), std::string::npos) << why;
  }
  greedy.tier.depth_codec = "raw";
  greedy.tier.color_codec = "none";
  greedy.tier.color_quality = 0;
  {
    Client cheap(greedy);
    EXPECT_TRUE(cheap.receive(rx));
    // A third tier held by this address alone (both others are its own, on loopback) is one
    // too many.
    greedy.tier.depth_codec = "lz4";
    const std::string why = error_of([&] { Client{greedy}; });
    EXPECT_NE(why.find("holds 2 tiers nobody else watches"), std::string::npos) << why;
    EXPECT_TRUE(cheap.receive(rx));
  }
  int frames = 0;
  while (frames < 5 && honest.receive(rx)) ++frames;
  EXPECT_EQ(frames, 5);
  for (const TierReport& t : site.server.tiers()) EXPECT_NE(t.tier.depth_codec, "hevc");
}

TEST(Door, FailedHandshakesAreLoggedRateLimitedWithACount) {
  auto stream = std::make_shared<std::ostringstream>();
  auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(*stream);
  auto previous = spdlog::default_logger();
  spdlog::set_default_logger(std::make_shared<spdlog::logger>("capture", sink));
  {
    ServerConfig config;
    config.insecure = true;
    config.max_pending_per_address = 1000;
    HandsSite site(30, config);
    asio::io_context io;
    for (int i = 0; i < 200; ++i) {
      auto s = idle_socket(io, "127.0.0.1", site.server.port());
      asio::write(s, asio::buffer(std::string("GET / HTTP/1.1\r\n\r\n")));
    }
    EXPECT_TRUE(eventually([&] { return site.server.door().failed == 200u; }));
  }
  spdlog::set_default_logger(previous);
  const std::string log = stream->str();
  size_t lines = 0;
  std::istringstream in(log);
  for (std::string line; std::getline(in, line);) lines += line.find("handshake") != line.npos;
  EXPECT_GE(lines, 1u);
  EXPECT_LE(lines, 3u) << log;
  EXPECT_NE(log.find("more failed handshakes not logged"), std::string::npos) << log;
  EXPECT_EQ(log.find("GET /"), std::string::npos);  // the peer's bytes never reach the log
}

// --- the web door (ServerConfig::web_root) before any token, spoken by hand over TLS ------------

// A page root holding only an index.html: enough for the server's web door.
fs::path tiny_web_root() {
  const fs::path dir = test::temp_dir("security_web_root");
  std::ofstream(dir / "index.html") << "<!doctype html><title>Volcast</title>\n";
  return dir;
}

std::unique_ptr<Connection> tls_to(const Server& server) {
  return connect_tls("127.0.0.1", server.port(), TlsContext::client(), 5000).connection;
}

// The page server serves files: GET, HEAD (GET's head alone), 405 naming them for any other
// method; a request announcing a body is answered 413 and closed at its head, its body neither
// read nor waited for (it is never sent here).
TEST(Door, ThePageServerAnswersOnlyGetAndHeadAndRefusesABodyUnread) {
  ServerConfig config;
  config.web_root = tiny_web_root();
  HandsSite site(30, config);
  const auto ask = [&](const std::string& request) {
    auto c = tls_to(site.server);
    test::write_text(*c, request);
    return test::read_to_close(*c);
  };
  const std::string get = ask("GET / HTTP/1.1\r\nHost: x\r\n\r\n");
  const std::string head = ask("HEAD / HTTP/1.1\r\nHost: x\r\n\r\n");
  EXPECT_EQ(head.substr(0, 15), "HTTP/1.1 200 OK") << head;
  EXPECT_EQ(head.size(), get.find("\r\n\r\n") + 4) << head;
  EXPECT_EQ(head, get.substr(0, head.size()));
  for (const char* method : {"POST", "PUT", "DELETE", "OPTIONS"}) {
    const std::string answer = ask(std::string(method) + " / HTTP/1.1\r\nHost: x\r\n\r\n");
    EXPECT_EQ(answer.substr(0, 12), "HTTP/1.1 405") << method;
    EXPECT_NE(answer.find("Allow: GET, HEAD\r\n"), std::string::npos) << answer;
  }
  for (const char* request : {"POST / HTTP/1.1\r\nHost: x\r\nContent-Length: 16000000\r\n\r\n",
                              "GET / HTTP/1.1\r\nHost: x\r\nContent-Length: 1\r\n\r\n",
                              "POST / HTTP/1.1\r\nHost: x\r\nTransfer-Encoding: chunked\r\n\r\n"})
    EXPECT_EQ(ask(request).substr(0, 12), "HTTP/1.1 413") << request;
  const std::string upgrade =
      "GET /stream HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
      "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n";
  for (const char* body : {"Content-Length: 1000\r\n\r\n", "Transfer-Encoding: chunked\r\n\r\n"})
    EXPECT_EQ(ask(upgrade + body).substr(0, 12), "HTTP/1.1 413") << body;
  EXPECT_EQ(receive(joining(site.server), 3), 3);
}

// Before its Hello a WebSocket peer gets no pong (nothing is buffered for it), and one that
// floods pings is closed once it has sent its connection's byte budget, the log naming the limit;
// flooders reconnecting all along keep no native viewer out.
// A relay's server passes its upstream tier's bytes through without encoding
// (ServerConfig::passed_through_tier): that tier costs nothing, also before the first frame set
// (when a tier is priced at 30 fps), so its viewers are admitted under any budget; another tier,
// which it would encode, is still priced and refused past the budget. Nothing is published here.
TEST(Door, ThePassedThroughTierIsFreeBeforeItsFirstFrameSet) {
  std::vector<protocol::CameraInfo> cameras;
  for (const auto& source : HandsSite::sources())
    cameras.push_back({source->calibration(), source->description()});
  ServerConfig config;
  config.port = 0;
  config.tier_cpu_budget = 0.001;  // less than any tier that encodes
  config.passed_through_tier = "volcast/jpeg";
  Server server(cameras, config);
  ClientConfig relayed = joining(server);  // volcast/jpeg
  Client first(relayed), second(relayed);
  ASSERT_EQ(server.tiers().size(), 1u);
  EXPECT_EQ(server.tiers()[0].cost_cores, 0);
  relayed.tier.depth_codec = "rvl";
  const std::string why = error_of([&] { Client{relayed}; });
  EXPECT_NE(why.find("tier rvl/jpeg would cost about"), std::string::npos) << why;
  EXPECT_EQ(server.tiers().size(), 1u);
  server.stop();
  config.passed_through_tier = "volcast/jpeg@2";
  EXPECT_NE(error_of([&] { Server{cameras, config}; }).find("no @N"), std::string::npos);
  config.passed_through_tier.clear();  // an offered tier carries every frame set too
  config.offered_tiers = {"volcast/jpeg", "trvl/none@2"};
  EXPECT_EQ(error_of([&] {
              Server{cameras, config};
            }).rfind("server: offered tier 'trvl/none@2'", 0),
            0u);
}

TEST(Door, PingsBeforeTheHelloGetNoPongAndAFloodIsClosedAtItsByteBudget) {
  auto stream = std::make_shared<std::ostringstream>();
  auto sink = std::make_shared<spdlog::sinks::ostream_sink_mt>(*stream);
  auto previous = spdlog::default_logger();
  spdlog::set_default_logger(std::make_shared<spdlog::logger>("capture", sink));
  ServerConfig config;
  config.web_root = tiny_web_root();
  HandsSite site(30, config);
  // 2048 pings of 125 bytes: 268 KB, four times the budget.
  const std::vector<uint8_t> payload(125, 'p');
  const std::vector<uint8_t> ping = test::client_frame(0x9, payload);
  std::vector<uint8_t> flood;
  for (int i = 0; i < 2048; ++i) flood.insert(flood.end(), ping.begin(), ping.end());
  std::atomic<bool> stop{false};
  std::atomic<int> floods{0}, opened{0}, pongs{0};
  std::thread flooder([&] {
    while (!stop) {
      try {
        auto c = tls_to(site.server);
        opened += test::upgrade_to_websocket(*c).rfind("HTTP/1.1 101", 0) == 0;
        error_of([&] { c->write_all(flood, 5000); });  // cut off midway: fine
        while (true) pongs += test::server_frame(*c).first == 0xA;
      } catch (const Error&) {  // closed
      }
      ++floods;
    }
  });
  EXPECT_EQ(receive(joining(site.server), 10), 10);
  EXPECT_TRUE(eventually([&] { return floods >= 2; }));
  stop = true;
  flooder.join();
  spdlog::set_default_logger(previous);
  EXPECT_GE(opened, 2);
  EXPECT_EQ(pongs, 0);
  EXPECT_GE(site.server.door().failed, 2u);
  const std::string log = stream->str();
  EXPECT_NE(log.find("over the limit of 65536 bytes"), std::string::npos) << log;
}

}  // namespace
}  // namespace volcast
