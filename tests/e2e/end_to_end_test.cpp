// Server and viewer on loopback with real recordings: exactness, statistics, several viewers,
// slow and hostile peers.
#include <gtest/gtest.h>

#include <fmt/format.h>
#include <asio.hpp>
#include <fstream>
#include <future>
#include <nlohmann/json.hpp>
#include <set>
#include <thread>

#include "support/hands_site.hpp"
#include "support/stepped_clock.hpp"
#include "support/test_data.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/sender.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;

using test::HandsSite;

// Frame set n carries hands frame (n - 1) % 207: compares every saved depth PNG with its source.
size_t expect_saved_depth_equals_source(const fs::path& dir) {
  size_t checked = 0;
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (name.find("depth") == std::string::npos) continue;
    const uint64_t sequence = std::stoull(name.substr(5, 8));  // cam0_SSSSSSSS_depth.png
    const fs::path source =
        test::hands_dir() / "depth" / fmt::format("{:05d}.png", (sequence - 1) % 207);
    EXPECT_EQ(read_depth_png(e.path()), read_depth_png(source)) << name << " vs " << source;
    ++checked;
  }
  return checked;
}

ViewerOptions viewer_options(const Server& server, const std::string& depth,
                             const std::string& color) {
  ViewerOptions opt;
  opt.client = client_config_from_link(server.join_link("127.0.0.1"));
  opt.client.tier.depth_codec = depth;
  opt.client.tier.color_codec = color;
  opt.render = false;
  return opt;
}

TEST(EndToEnd, EverySavedDepthFrameEqualsItsSourceAndStatsAreSane) {
  HandsSite site(15);
  const fs::path dir = test::temp_dir("e2e_exact");
  ViewerOptions opt = viewer_options(site.server, "trvl", "jpeg");
  opt.frames = 40;
  opt.save_frames_dir = dir / "frames";
  opt.stats_json = dir / "stats.json";
  const ViewerResult r = run_viewer(opt);
  EXPECT_EQ(expect_saved_depth_equals_source(opt.save_frames_dir), 40u);

  std::ifstream in(opt.stats_json);
  const auto j = nlohmann::json::parse(in);
  ASSERT_EQ(j["cameras"].size(), 1u);
  const auto& c = j["cameras"][0];
  EXPECT_EQ(c["frames_received"], 40);
  EXPECT_GT(c["depth_compression_ratio"].get<double>(), 1.5);  // trvl on real depth
  EXPECT_LT(c["depth_compression_ratio"].get<double>(), 50.0);
  EXPECT_GT(c["mean_depth_bytes"].get<double>(), 1000.0);
  EXPECT_GT(c["mean_color_bytes"].get<double>(), 1000.0);
  EXPECT_GT(c["mbit_per_s"].get<double>(), 0.1);
  EXPECT_GT(c["received_fps"].get<double>(), 0.5);
  EXPECT_GT(c["latency_ms_p50"].get<double>(), 0.0);
  EXPECT_GE(c["latency_ms_p99"].get<double>(), c["latency_ms_p50"].get<double>());
  EXPECT_LT(c["latency_ms_p50"].get<double>(), 10000.0);
  EXPECT_EQ(r.cameras[0].width, 640);
}

TEST(EndToEnd, SeveralViewersWithDifferentCodecsAtOnce) {
  HandsSite site(15);
  const fs::path dir = test::temp_dir("e2e_two");
  ViewerOptions a = viewer_options(site.server, "rvl", "jpeg");
  ViewerOptions b = viewer_options(site.server, "trvl", "raw");
  ViewerOptions c = viewer_options(site.server, "zstd", "none");
  a.frames = b.frames = c.frames = 25;
  a.save_frames_dir = dir / "a";
  b.save_frames_dir = dir / "b";
  c.save_frames_dir = dir / "c";
  auto fa = std::async(std::launch::async, [&] { return run_viewer(a); });
  auto fb = std::async(std::launch::async, [&] { return run_viewer(b); });
  auto fc = std::async(std::launch::async, [&] { return run_viewer(c); });
  const ViewerResult ra = fa.get(), rb = fb.get(), rc = fc.get();
  EXPECT_EQ(expect_saved_depth_equals_source(a.save_frames_dir), 25u);
  EXPECT_EQ(expect_saved_depth_equals_source(b.save_frames_dir), 25u);
  EXPECT_EQ(expect_saved_depth_equals_source(c.save_frames_dir), 25u);
  EXPECT_EQ(rc.cameras[0].mean_color_bytes, 0.0);
  // Raw color is 640x360x4 plus a header; JPEG is far smaller.
  EXPECT_EQ(rb.cameras[0].mean_color_bytes, 640.0 * 360 * 4 + 12);
  EXPECT_LT(ra.cameras[0].mean_color_bytes, rb.cameras[0].mean_color_bytes / 5);
  std::set<std::string> codecs;
  for (const auto& v : site.server.viewers())
    codecs.insert(v.tier.depth_codec + "/" + v.tier.color_codec);
  EXPECT_TRUE(codecs.count("rvl/jpeg") && codecs.count("trvl/raw") && codecs.count("zstd/none"));
}

// Connects a raw TCP socket to the server.
asio::ip::tcp::socket raw_connect(asio::io_context& io, uint16_t port) {
  asio::ip::tcp::socket s(io);
  s.connect({asio::ip::make_address("127.0.0.1"), port});
  return s;
}

// Sends a Hello with the server's token (the server must be insecure: plain TCP on loopback).
void send_hello(asio::ip::tcp::socket& s, const Server& server, const std::string& depth,
                const std::string& color) {
  protocol::Hello hello;
  hello.token = server.token();
  hello.tier.depth_codec = depth;
  hello.tier.color_codec = color;
  const auto msg = protocol::message(protocol::MessageType::kHello, protocol::serialize(hello));
  asio::write(s, asio::buffer(msg));
}

// Reads the server's answer, which must be a Reject, and returns its reason.
std::string read_reject(asio::ip::tcp::socket& s) {
  uint8_t bytes[protocol::kHeaderBytes];
  asio::read(s, asio::buffer(bytes));
  const protocol::Header h = protocol::parse_header(bytes);
  EXPECT_EQ(h.type, protocol::MessageType::kReject);
  std::vector<uint8_t> reason(h.payload_bytes);
  asio::read(s, asio::buffer(reason));
  return protocol::parse_reject(reason);
}

TEST(EndToEnd, ViewerThatStopsReadingDoesNotDelayTheOther) {
  ServerConfig config;
  config.stall_timeout_ms = 1500;
  config.insecure = true;  // the stalled peer speaks plain TCP
  HandsSite site(10, config);
  asio::io_context io;
  auto stalled = raw_connect(io, site.server.port());
  send_hello(stalled, site.server, "trvl", "raw");  // then never reads nor acknowledges

  ViewerOptions opt = viewer_options(site.server, "trvl", "jpeg");
  opt.frames = 30;
  const ViewerResult r = run_viewer(opt);
  EXPECT_EQ(r.cameras[0].frames_received, 30u);
  EXPECT_LE(r.cameras[0].frames_dropped, 15u);  // it kept up with the 10 fps site

  // The stalled viewer was never sent more than the first window (2 frame sets before any Ack),
  // and is dropped after the stall timeout.
  bool disconnected = false;
  for (int i = 0; i < 100 && !disconnected; ++i) {
    for (const auto& v : site.server.viewers())
      if (v.tier.depth_codec == "trvl" && v.tier.color_codec == "raw") {
        EXPECT_LE(v.frames_sent, 2u);
        disconnected = !v.connected && v.error.find("stalled") != std::string::npos;
      }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  EXPECT_TRUE(disconnected);
}

TEST(EndToEnd, HostilePeersGetClearErrorsAndTheServerKeepsServing) {
  ServerConfig config;
  config.handshake_timeout_ms = 300;
  config.insecure = true;  // the hostile peers speak plain TCP: their bytes reach the parser
  HandsSite site(15, config);
  const uint16_t port = site.server.port();
  asio::io_context io;

  // Garbage instead of a handshake.
  auto garbage = raw_connect(io, port);
  asio::write(garbage, asio::buffer(std::string("GET / HTTP/1.1\r\nHost: x\r\n\r\n")));
  // A header announcing a gigabyte-long Hello.
  auto huge = raw_connect(io, port);
  uint8_t header[protocol::kHeaderBytes];
  protocol::write_header(protocol::MessageType::kHello, 1u << 30, header);
  asio::write(huge, asio::buffer(header));
  // A peer that connects and says nothing.
  auto silent = raw_connect(io, port);
  // A peer speaking another protocol version: it is told why.
  auto old = raw_connect(io, port);
  protocol::write_header(protocol::MessageType::kHello, 0, header);
  header[4] = 9;
  asio::write(old, asio::buffer(header));
  EXPECT_NE(read_reject(old).find("version"), std::string::npos);

  // Unknown codec: the viewer is told which codecs exist.
  auto raw = raw_connect(io, port);
  send_hello(raw, site.server, "zdepth", "jpeg");
  EXPECT_NE(read_reject(raw).find("unknown depth codec 'zdepth'"), std::string::npos);

  // Meanwhile a proper viewer is served normally.
  ViewerOptions opt = viewer_options(site.server, "trvl", "jpeg");
  opt.frames = 10;
  EXPECT_EQ(run_viewer(opt).cameras[0].frames_received, 10u);
  std::this_thread::sleep_for(std::chrono::milliseconds(500));
  // Garbage, huge, silent (timeout) and old version failed at the door, as no viewer; the unknown
  // codec came with the right token and is reported as a viewer that was rejected.
  EXPECT_EQ(site.server.door().failed, 4u);
  size_t rejected = 0;
  for (const auto& v : site.server.viewers())
    rejected += v.error.find("unknown depth codec") != std::string::npos;
  EXPECT_EQ(rejected, 1u);
}

TEST(EndToEnd, ClientRejectsUnknownCodecsAndUnreachableServers) {
  ClientConfig c;
  c.port = 1;
  c.fingerprint = std::string(64, 'a');
  c.tier.depth_codec = "bogus";
  EXPECT_THROW(Client{c}, Error);
  c.tier.depth_codec = "rvl";
  try {
    Client client(c);
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("cannot connect"), std::string::npos);
  }
}

TEST(EndToEnd, ServerAppliesEachCamerasFilterChain) {
  // Camera 0: hands, unfiltered. Camera 1: the Azure Kinect recording with lens correction, the
  // NFOV crop, thresholds and hole filling.
  std::vector<std::unique_ptr<FrameSource>> sources = HandsSite::sources();
  sources.push_back(open_source(test::kinect_mkv()));
  FilterConfig kinect = paper_chain_config(640, 576);
  kinect.kalman.reset();  // stateless, so the viewer's frames can be compared with one local pass
  const Intrinsics raw_intrinsics = sources[1]->calibration().depth;
  SitePlayer player(std::move(sources), 15, {FilterConfig{}, kinect});
  ServerConfig config;
  config.port = 0;
  Server server(player.cameras(), config);
  player.start(server);

  const fs::path dir = test::temp_dir("e2e_filtered");
  ViewerOptions opt = viewer_options(server, "rvl", "jpeg");
  opt.frames = 5;
  opt.save_frames_dir = dir;
  const ViewerResult r = run_viewer(opt);
  player.stop();
  server.stop();
  EXPECT_EQ(r.cameras[0].width, 640);
  EXPECT_EQ(r.cameras[1].width, 540);
  EXPECT_EQ(r.cameras[1].height, 476);
  // What the viewer decoded is exactly the chain's output on the recording's frame.
  FilterChain chain(raw_intrinsics, kinect);
  CameraFrame expected;
  chain.apply(open_source(test::kinect_mkv())->next(), expected);
  size_t compared = 0;
  for (const auto& e : fs::directory_iterator(dir))
    if (e.path().filename().string().rfind("cam1_", 0) == 0 &&
        e.path().string().find("depth") != std::string::npos) {
      EXPECT_EQ(read_depth_png(e.path()), expected.depth);
      ++compared;
    }
  EXPECT_EQ(compared, 5u);
}

TEST(EndToEnd, EachRecordingIsPacedAtItsOwnRate) {
  // The hands sequence plays at 30 fps, the Azure Kinect recording was made at 5 fps: the site
  // runs at 30 fps and repeats the Kinect frame until its next one is due. The site runs on a
  // clock the test steps (one tick per frame set), so what each frame set shows is exact: a new
  // hands frame in every one, Kinect frame k in frame sets 6k + 1 .. 6k + 6.
  std::vector<std::unique_ptr<FrameSource>> sources = HandsSite::sources();
  sources.push_back(open_source(test::kinect_mkv()));
  EXPECT_DOUBLE_EQ(sources[1]->fps(), 5.0);
  std::vector<int64_t> kinect_frame_stamps;  // the recording's own frames, in order
  {
    auto reference = open_source(test::kinect_mkv());
    for (int k = 0; k < 7; ++k)
      kinect_frame_stamps.push_back(reference->next().device_timestamp_us);
  }
  test::SteppedClock clock;
  SitePlayer player(std::move(sources), 0, {}, clock.options());
  const test::ReleaseOnExit release{clock};
  EXPECT_DOUBLE_EQ(player.fps(), 30.0);
  ServerConfig config;
  config.port = 0;
  // Frame set n waits for the test to receive n - 1: never skipped as stale, however long a loaded
  // machine takes (a stale frame set waits for a fresher one, which here never comes).
  config.latency_budget_ms = 60'000;
  Server server(player.cameras(), config);
  player.start(server);
  ClientConfig c = client_config_from_link(server.join_link("127.0.0.1"));
  c.tier.depth_codec = "rvl";
  Client client(c);
  ReceivedFrameSet rx;
  std::vector<int64_t> hands_stamps, kinect_stamps;  // per frame set, 1 .. 40
  for (uint64_t n = 1; n <= 40; ++n) {
    clock.allow(1);  // the site's tick n publishes frame set n; nothing newer until it arrives
    do {
      ASSERT_TRUE(client.receive(rx));
    } while (rx.frames.sequence < n);
    ASSERT_EQ(rx.frames.sequence, n);
    hands_stamps.push_back(rx.frames.cameras[0].device_timestamp_us);
    kinect_stamps.push_back(rx.frames.cameras[1].device_timestamp_us);
  }
  clock.release();
  player.stop();
  server.stop();
  for (size_t i = 1; i < hands_stamps.size(); ++i)
    EXPECT_GT(hands_stamps[i], hands_stamps[i - 1]) << "frame set " << i + 1;
  for (size_t i = 0; i < kinect_stamps.size(); ++i)
    EXPECT_EQ(kinect_stamps[i], kinect_frame_stamps[i / 6]) << "frame set " << i + 1;
  EXPECT_EQ(std::set<int64_t>(kinect_stamps.begin(), kinect_stamps.end()).size(), 7u);
}

TEST(EndToEnd, ViewerRendersWhatItReceives) {
  HandsSite site(15);
  const fs::path dir = test::temp_dir("e2e_render");
  ViewerOptions opt = viewer_options(site.server, "trvl", "jpeg");
  opt.render = true;
  opt.width = 320;
  opt.height = 180;
  opt.frames = 10;
  opt.screenshot = dir / "shot.png";
  const ViewerResult r = run_viewer(opt);
  EXPECT_GE(r.frames_rendered, 1u);
  EXPECT_FALSE(r.renderer.empty());
  const ColorImage shot = read_color_png(opt.screenshot);
  size_t covered = 0;
  for (size_t i = 0; i < shot.bgra.size(); i += 4)
    covered += shot.bgra[i] + shot.bgra[i + 1] + shot.bgra[i + 2] > 90;
  EXPECT_GT(covered,
            shot.bgra.size() / 4 / 10);  // the table and hands fill a good part of the view

  // The same stream through an avatar filter that keeps only a small sphere far from the scene:
  // nothing is drawn.
  opt.avatar_filter.keep = KeepSphere{{50, 50, 50}, 0.1f};
  opt.screenshot = dir / "filtered.png";
  const ViewerResult f = run_viewer(opt);
  EXPECT_GE(f.frames_rendered, 1u);
  const ColorImage filtered = read_color_png(opt.screenshot);
  size_t drawn = 0;
  for (size_t i = 0; i < filtered.bgra.size(); i += 4)
    drawn += filtered.bgra[i] + filtered.bgra[i + 1] + filtered.bgra[i + 2] > 90;
  EXPECT_EQ(drawn, 0u);
}

// The render thread is pluggable (a window, a headset): a presenter sees every camera, takes the
// newest frames, reads the live figures, and ends the session by closing the feed.
TEST(EndToEnd, APresenterTakesFramesReadsLiveFiguresAndClosesTheSession) {
  HandsSite site(15);
  ViewerOptions opt = viewer_options(site.server, "trvl", "jpeg");
  opt.render = true;
  opt.seconds = 60;  // a bound in case closing did not work; the presenter ends it long before
  size_t cameras = 0, taken = 0;
  LiveStats live;
  opt.presenter = [&](FrameFeed& feed, ViewerResult& result) {
    cameras = feed.cameras().size();
    std::vector<std::shared_ptr<const CameraFrame>> frames;
    while (!feed.finished()) {
      if (!feed.next(frames, std::chrono::milliseconds(200))) continue;
      EXPECT_EQ(frames.size(), cameras);
      ASSERT_TRUE(frames[0]);
      EXPECT_EQ(frames[0]->depth.width, feed.cameras()[0].depth.width);
      ++taken;
      ++result.frames_rendered;
      live = feed.live();
      if (live.frame_sets_received >= 20 && live.cameras[0].received_fps > 0) feed.close();
    }
  };
  const ViewerResult r = run_viewer(opt);
  EXPECT_EQ(r.ended, ViewerEnd::kClosed);
  EXPECT_STREQ(to_string(r.ended), "closed");
  EXPECT_EQ(cameras, 1u);
  EXPECT_GE(taken, 2u);
  EXPECT_EQ(r.frames_rendered, taken);
  EXPECT_GE(live.frame_sets_received, 20u);
  ASSERT_EQ(live.cameras.size(), 1u);
  EXPECT_GT(live.cameras[0].received_fps, 0);
  EXPECT_GT(live.cameras[0].mbit_per_s, 0);
  EXPECT_GT(live.cameras[0].frames_received, 0u);
  EXPECT_EQ(live.tier.depth_codec, "trvl");
  EXPECT_FALSE(live.stages.empty());
  EXPECT_LT(r.frame_sets_received, 15u * 50);  // closed, not run out the 60 s

  // A presenter that fails ends the session as an error naming the renderer.
  opt.presenter = [](FrameFeed&, ViewerResult&) { throw Error("no window"); };
  try {
    run_viewer(opt);
    ADD_FAILURE() << "a failed presenter did not end the session as an error";
  } catch (const ViewerError& e) {
    EXPECT_EQ(e.result().ended, ViewerEnd::kError);
    EXPECT_NE(std::string(e.what()).find("renderer: no window"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace volcast
