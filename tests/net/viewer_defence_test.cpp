// The viewer against a hostile server: a fake server in the test (a TcpListener on loopback)
// writes hand-crafted bytes, and the viewer must refuse what exceeds its limits before allocating
// for it, time out on silence, sanitise the server's strings, and report how it ended.
#include <fcntl.h>
#include <gtest/gtest.h>
#include <poll.h>
#include <signal.h>
#include <spawn.h>
#include <sys/resource.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <condition_variable>
#include <cstring>
#include <fstream>
#include <functional>
#include <mutex>
#include <nlohmann/json.hpp>
#include <sstream>
#include <thread>

#include "support/test_data.hpp"
#include "support/test_paths.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/net/protocol/frame_set.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/net/transport/connection.hpp"
#include "volcast/pipeline/receiver.hpp"

extern char** environ;

namespace volcast {
namespace {

using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using Kind = ClientError::Kind;

// ---------------------------------------------------------------------------------------------
// The fake server: accepts one viewer on 127.0.0.1 and runs `script` on its connection in a
// thread; then holds the connection open and silent until the server is destroyed or `hold`
// passes (so that a viewer without timeouts fails instead of hanging the test).

class FakeServer {
 public:
  using Script = std::function<void(Connection&)>;
  explicit FakeServer(Script script, std::chrono::milliseconds hold = 30s)
      : listener_("127.0.0.1", 0) {
    thread_ = std::thread([this, script = std::move(script), hold] {
      std::unique_ptr<Connection> c = listener_.accept();
      if (!c) return;
      try {
        script(*c);
      } catch (const std::exception&) {
        // the viewer hung up first: fine
      }
      std::unique_lock lock(mutex_);
      stop_cv_.wait_for(lock, hold, [&] { return stop_; });
      c->shutdown();
    });
  }
  ~FakeServer() {
    {
      std::lock_guard lock(mutex_);
      stop_ = true;
    }
    stop_cv_.notify_all();
    listener_.close();
    thread_.join();
  }
  uint16_t port() const { return listener_.port(); }

 private:
  TcpListener listener_;
  std::mutex mutex_;
  std::condition_variable stop_cv_;
  bool stop_ = false;
  std::thread thread_;
};

// Reads the viewer's Hello (whatever its fields: only the header's length is used).
void read_hello(Connection& c) {
  uint8_t header[protocol::kHeaderBytes];
  c.read_exact(header, 10000);
  const protocol::Header h = protocol::parse_header(header, protocol::kMaxHelloBytes);
  ASSERT_EQ(h.type, protocol::MessageType::kHello);
  std::vector<uint8_t> payload(h.payload_bytes);
  c.read_exact(payload, 10000);
}

void send_message(Connection& c, protocol::MessageType type, const std::vector<uint8_t>& payload) {
  c.write_all(protocol::message(type, payload), 10000);
}

// Only a header: the payload it promises never comes.
void send_header_only(Connection& c, protocol::MessageType type, uint32_t payload_bytes) {
  uint8_t header[protocol::kHeaderBytes];
  protocol::write_header(type, payload_bytes, header);
  c.write_all(header, 10000);
}

protocol::CameraInfo camera(int width, int height, std::string description = "fake camera") {
  protocol::CameraInfo cam;
  Intrinsics& k = cam.calibration.depth;
  k.width = width;
  k.height = height;
  k.fx = k.fy = 500;
  k.cx = width / 2.0;
  k.cy = height / 2.0;
  cam.description = std::move(description);
  return cam;
}

std::vector<uint8_t> welcome(std::vector<protocol::CameraInfo> cameras) {
  return protocol::serialize(protocol::Welcome{std::move(cameras), 0});
}

void send_frame_set(Connection& c, uint64_t sequence,
                    const std::vector<protocol::EncodedCamera>& cameras) {
  std::vector<uint8_t> body;
  const int64_t now = wall_clock_us();
  protocol::serialize_frame_set_body(sequence, true, {now, now, now, 0}, cameras, body);
  const auto prefix = protocol::frame_set_prefix(body.size(), now);
  const std::span<const uint8_t> parts[2] = {prefix, body};
  c.write_all(parts, 10000);
}

// One camera's frame, encoded with real codecs at `width` x `height`.
protocol::EncodedCamera encoded(const std::string& depth_codec, const std::string& color_codec,
                                int width, int height) {
  DepthImage depth(width, height);
  for (size_t i = 0; i < depth.pixels.size(); ++i)
    depth.pixels[i] = static_cast<uint16_t>(500 + i % 1000);
  ColorImage color(width, height);
  for (size_t i = 0; i < color.bgra.size(); ++i) color.bgra[i] = static_cast<uint8_t>(i * 7);
  protocol::EncodedCamera e;
  make_depth_encoder(depth_codec)->encode(depth, true, e.depth);
  make_color_encoder(color_codec)->encode(color, true, e.color);
  return e;
}

ClientConfig config(uint16_t port, const std::string& depth = "raw",
                    const std::string& color = "raw") {
  ClientConfig c;
  c.port = port;
  c.insecure = true;  // the fake server speaks plain TCP on loopback
  c.tier.depth_codec = depth;
  c.tier.color_codec = color;
  c.decode_threads = 1;
  c.handshake_timeout_ms = 20000;  // generous: a loaded machine; scenarios set their own
  c.receive_timeout_ms = 20000;
  return c;
}

struct Outcome {
  int kind = -1;  // ClientError::Kind; -1: no error, -2: another exception, -3: ViewerError
  std::string message;
  long peak_growth_kb = -1;  // peak RSS growth while the scenario ran (-1: not measured)
};

Outcome outcome_of(const std::function<void()>& scenario) {
  Outcome o;
  try {
    scenario();
  } catch (const ViewerError& e) {
    o.kind = -3;
    o.message = std::string(to_string(e.result().ended)) + ": " + e.what();
  } catch (const ClientError& e) {
    o.kind = static_cast<int>(e.kind());
    o.message = e.what();
  } catch (const std::exception& e) {
    o.kind = -2;
    o.message = e.what();
  }
  return o;
}

long proc_status_kb(const char* field) {
  std::ifstream in("/proc/self/status");
  std::string line;
  while (std::getline(in, line))
    if (line.rfind(field, 0) == 0) return std::stol(line.substr(std::strlen(field)));
  return -1;
}

// Runs `scenario` (fake server and viewer together) in a forked child and measures how much its
// resident memory grew at the peak: a zero-filled allocation of what a server claims shows there
// (AddressSanitizer included). A child that does not finish in `limit` is killed.
Outcome run_in_child(const std::function<void()>& scenario, std::chrono::seconds limit = 120s) {
  int fds[2];
  if (pipe(fds) != 0) return {-2, "pipe failed", -1};
  std::fflush(nullptr);
  const pid_t pid = fork();
  if (pid == 0) {
    ::close(fds[0]);
    // Reset the peak (VmHWM) to the current RSS, then measure from here.
    long base_kb = -1;
    if (std::ofstream clear("/proc/self/clear_refs"); clear << "5" << std::flush)
      base_kb = proc_status_kb("VmRSS:");
    Outcome o = outcome_of(scenario);
    if (base_kb >= 0) o.peak_growth_kb = proc_status_kb("VmHWM:") - base_kb;
    const std::string report =
        std::to_string(o.kind) + "\t" + std::to_string(o.peak_growth_kb) + "\t" + o.message;
    ssize_t left = static_cast<ssize_t>(report.size());
    for (const char* p = report.data(); left > 0;) {
      const ssize_t n = ::write(fds[1], p, static_cast<size_t>(left));
      if (n <= 0) break;
      p += n;
      left -= n;
    }
    _exit(0);  // no destructors, no leak check: the parent reports
  }
  ::close(fds[1]);
  std::string report;
  const auto deadline = Clock::now() + limit;
  bool finished = false;
  while (Clock::now() < deadline) {
    pollfd p{fds[0], POLLIN, 0};
    if (poll(&p, 1, 200) <= 0) continue;
    char buf[4096];
    const ssize_t n = ::read(fds[0], buf, sizeof buf);
    if (n <= 0) {
      finished = true;
      break;
    }
    report.append(buf, static_cast<size_t>(n));
  }
  ::close(fds[0]);
  if (!finished) kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  if (!finished)
    return {-2, "the scenario did not finish in " + std::to_string(limit.count()) + " s", -1};
  Outcome o;
  std::istringstream in(report);
  std::string kind, growth;
  if (!std::getline(in, kind, '\t') || !std::getline(in, growth, '\t'))
    return {-2, "the child reported nothing (crashed?): status " + std::to_string(status), -1};
  o.kind = std::stoi(kind);
  o.peak_growth_kb = std::stol(growth);
  std::getline(in, o.message, '\0');
  return o;
}

// What a scenario may allocate at its peak: the viewer's buffers for what actually arrived, its
// threads, and the fake server; far below what the hostile messages claim (>= 128 MiB).
constexpr long kBoundedGrowthKb = 64 << 10;

void expect_bounded(const Outcome& o) {
  if (o.peak_growth_kb < 0) {
    std::printf("note: peak RSS not measured (/proc/self/clear_refs not writable)\n");
    return;
  }
  std::printf("peak RSS growth %ld KiB\n", o.peak_growth_kb);
  EXPECT_LT(o.peak_growth_kb, kBoundedGrowthKb)
      << "peak RSS grew by " << o.peak_growth_kb << " KiB: " << o.message;
}

bool contains(const std::string& s, const std::string& part) {
  return s.find(part) != std::string::npos;
}

// ---------------------------------------------------------------------------------------------
// printable(): peer strings made safe to log.

TEST(PeerText, ControlCharactersAreEscapedAndLengthIsCapped) {
  EXPECT_EQ(printable("Azure Kinect 0"), "Azure Kinect 0");
  EXPECT_EQ(printable("bad\n[error] forged"), "bad\\x0a[error] forged");
  EXPECT_EQ(printable("\r\t\x1b[31mred\x7f"), "\\x0d\\x09\\x1b[31mred\\x7f");
  EXPECT_EQ(printable(std::string("a\0b", 3)), "a\\x00b");
  EXPECT_EQ(printable("C:\\x0a"), "C:\\\\x0a");  // a real backslash cannot pose as an escape
  EXPECT_EQ(printable("Kamera S\xc3\xbc"
                      "d \xe2\x82\xac"),
            "Kamera S\xc3\xbc"
            "d \xe2\x82\xac");
  EXPECT_EQ(printable("\xc3"), "\\xc3");                    // truncated UTF-8
  EXPECT_EQ(printable("\xc0\x8a"), "\\xc0\\x8a");           // overlong newline
  EXPECT_EQ(printable("\xed\xa0\x80"), "\\xed\\xa0\\x80");  // surrogate
  EXPECT_EQ(printable("\xc2\x85"), "\\xc2\\x85");           // C1 next-line
  EXPECT_EQ(printable("a\xe2\x80\xa8"
                      "b"),
            "a\\xe2\\x80\\xa8b");  // line separator
  EXPECT_EQ(printable("\xe2\x80\xae"
                      "txt"),
            "\\xe2\\x80\\xaetxt");  // right-to-left override
  EXPECT_EQ(printable(std::string(1000, 'x'), 10), "xxxxxxxxxx...");
  EXPECT_EQ(printable("abc\n", 5), "abc...");  // an escape is never cut
  EXPECT_EQ(printable("abc", 3), "abc");
  for (int c = 0; c < 256; ++c) {
    const std::string out = printable(std::string(1, static_cast<char>(c)));
    for (const char o : out) EXPECT_TRUE(o >= 0x20 && o < 0x7f) << c;
  }
}

TEST(HostileServer, RejectReasonIsSanitised) {
  FakeServer server([](Connection& c) {
    read_hello(c);
    send_message(c, protocol::MessageType::kReject,
                 protocol::serialize_reject("server full\n[error] forged\x1b[2J"));
  });
  const Outcome o = outcome_of([&] { Client client(config(server.port())); });
  EXPECT_EQ(o.kind, static_cast<int>(Kind::kRejected)) << o.message;
  EXPECT_FALSE(contains(o.message, "\n")) << o.message;
  EXPECT_FALSE(contains(o.message, "\x1b")) << o.message;
  EXPECT_TRUE(contains(o.message, "server full\\x0a[error] forged\\x1b[2J")) << o.message;
}

// ---------------------------------------------------------------------------------------------
// Welcome: sizes checked before anything is allocated for them.

TEST(HostileServer, HugeCameraInTheWelcomeIsRefused) {
  const Outcome o = run_in_child([] {
    FakeServer server([](Connection& c) {
      read_hello(c);
      send_message(c, protocol::MessageType::kWelcome, welcome({camera(12000, 12000)}));
    });
    ViewerOptions opt;
    opt.client = config(server.port());
    opt.render = false;
    run_viewer(opt);
  });
  EXPECT_EQ(o.kind, -3) << o.message;
  EXPECT_EQ(o.message.rfind("protocol_error: ", 0), 0u) << o.message;
  EXPECT_TRUE(contains(o.message, "12000x12000")) << o.message;
  EXPECT_TRUE(contains(o.message, "4096")) << o.message;
  expect_bounded(o);
}

TEST(HostileServer, TooManyPixelsOrCamerasInTheWelcomeAreRefused) {
  // 65 cameras
  {
    FakeServer server([](Connection& c) {
      read_hello(c);
      send_message(c, protocol::MessageType::kWelcome,
                   welcome(std::vector<protocol::CameraInfo>(65, camera(64, 48))));
    });
    const Outcome o = outcome_of([&] { Client client(config(server.port())); });
    EXPECT_EQ(o.kind, static_cast<int>(Kind::kProtocol)) << o.message;
    EXPECT_TRUE(contains(o.message, "camera count 65")) << o.message;
  }
  // 17 cameras of 1024x1024: each within the side limit, too many pixels together
  {
    FakeServer server([](Connection& c) {
      read_hello(c);
      send_message(c, protocol::MessageType::kWelcome,
                   welcome(std::vector<protocol::CameraInfo>(17, camera(1024, 1024))));
    });
    const Outcome o = outcome_of([&] { Client client(config(server.port())); });
    EXPECT_EQ(o.kind, static_cast<int>(Kind::kProtocol)) << o.message;
    EXPECT_TRUE(contains(o.message, "more than the limit")) << o.message;
  }
}

TEST(HostileServer, WelcomeDeclaringAHugePayloadIsRefusedFromItsHeader) {
  const Outcome o = run_in_child([] {
    FakeServer server([](Connection& c) {
      read_hello(c);
      send_header_only(c, protocol::MessageType::kWelcome, 0xf0000000u);
    });
    Client client(config(server.port()));
  });
  EXPECT_EQ(o.kind, static_cast<int>(Kind::kProtocol)) << o.message;
  EXPECT_TRUE(
      contains(o.message, "exceeds the limit of " + std::to_string(protocol::kMaxWelcomeBytes)))
      << o.message;
  expect_bounded(o);
}

// ---------------------------------------------------------------------------------------------
// Timeouts.

TEST(HostileServer, SilenceInTheHandshakeTimesOut) {
  FakeServer server([](Connection& c) { read_hello(c); });  // then nothing
  ClientConfig c = config(server.port());
  c.handshake_timeout_ms = 500;
  const auto start = Clock::now();
  const Outcome o = outcome_of([&] { Client client(c); });
  EXPECT_EQ(o.kind, static_cast<int>(Kind::kTimedOut)) << o.message;
  EXPECT_TRUE(contains(o.message, "handshake timeout")) << o.message;
  EXPECT_GE(Clock::now() - start, 450ms);
}

TEST(HostileServer, SilenceAfterTheWelcomeTimesOut) {
  FakeServer server([](Connection& c) {
    read_hello(c);
    send_message(c, protocol::MessageType::kWelcome, welcome({camera(64, 48)}));
  });
  ClientConfig c = config(server.port());
  c.receive_timeout_ms = 500;
  Client client(c);
  ReceivedFrameSet rx;
  const auto start = Clock::now();
  const Outcome o = outcome_of([&] { client.receive(rx); });
  EXPECT_EQ(o.kind, static_cast<int>(Kind::kTimedOut)) << o.message;
  EXPECT_TRUE(contains(o.message, "receive timeout")) << o.message;
  EXPECT_GE(Clock::now() - start, 450ms);
}

TEST(HostileServer, CloseFromAnotherThreadEndsABlockedReceive) {
  FakeServer server([](Connection& c) {
    read_hello(c);
    send_message(c, protocol::MessageType::kWelcome, welcome({camera(64, 48)}));
  });
  ClientConfig c = config(server.port());
  c.receive_timeout_ms = 0;  // no limit: only close() ends the wait
  Client client(c);
  std::thread closer([&] {
    std::this_thread::sleep_for(300ms);
    client.close();
  });
  ReceivedFrameSet rx;
  const auto start = Clock::now();
  EXPECT_FALSE(client.receive(rx));
  closer.join();
  EXPECT_LT(Clock::now() - start, 20s);  // well before the fake server's 30 s hold
}

// ---------------------------------------------------------------------------------------------
// Frame sets: the payload bound, a buffer that grows with what arrives, declared stream sizes.

TEST(HostileServer, FrameSetAboveTheSitesBoundIsRefusedFromItsHeader) {
  const Outcome o = run_in_child([] {
    FakeServer server([](Connection& c) {
      read_hello(c);
      send_message(c, protocol::MessageType::kWelcome, welcome({camera(640, 576)}));
      send_header_only(c, protocol::MessageType::kFrameSet, 200u << 20);  // 200 MiB, then silence
    });
    Client client(config(server.port()));
    ReceivedFrameSet rx;
    client.receive(rx);
  });
  EXPECT_EQ(o.kind, static_cast<int>(Kind::kProtocol)) << o.message;
  EXPECT_TRUE(contains(o.message, "exceeds the limit")) << o.message;
  expect_bounded(o);
}

TEST(HostileServer, FrameSetPromisingMuchAndSendingLittleTimesOutWithLittleMemory) {
  // The largest site a viewer accepts (16 Mi pixels): its bound is about 128 MiB. The server
  // promises that much, sends 1.5 MiB and falls silent.
  const std::vector<protocol::CameraInfo> site(4, camera(2048, 2048));
  const uint32_t limit = protocol::frame_set_payload_limit(protocol::Welcome{site, 0});
  ASSERT_GT(limit, 128u << 20);
  const Outcome o = run_in_child([&] {
    FakeServer server([&](Connection& c) {
      read_hello(c);
      send_message(c, protocol::MessageType::kWelcome, welcome(site));
      send_header_only(c, protocol::MessageType::kFrameSet, limit);
      c.write_all(std::vector<uint8_t>(3 << 19, 0), 10000);
    });
    ClientConfig c = config(server.port());
    c.receive_timeout_ms = 1000;
    Client client(c);
    ReceivedFrameSet rx;
    client.receive(rx);
  });
  EXPECT_EQ(o.kind, static_cast<int>(Kind::kTimedOut)) << o.message;
  EXPECT_TRUE(contains(o.message, " of " + std::to_string(limit) + " bytes")) << o.message;
  expect_bounded(o);
}

TEST(HostileServer, WellFormedFrameSetsLargerThanOneReadChunkDecode) {
  // 640x576 with raw depth and raw color: 2.2 MB, read in several chunks.
  const protocol::EncodedCamera frame = encoded("raw", "raw", 640, 576);
  ASSERT_GT(frame.depth.size() + frame.color.size(), 2u << 20);
  FakeServer server([&](Connection& c) {
    read_hello(c);
    send_message(c, protocol::MessageType::kWelcome, welcome({camera(640, 576)}));
    send_frame_set(c, 1, {frame});
    send_frame_set(c, 2, {encoded("raw", "raw", 640, 576)});
  });
  Client client(config(server.port()));
  ReceivedFrameSet rx;
  for (uint64_t sequence : {1u, 2u}) {
    ASSERT_TRUE(client.receive(rx));
    EXPECT_EQ(rx.frames.sequence, sequence);
    EXPECT_EQ(rx.frames.cameras[0].depth.width, 640);
    EXPECT_EQ(rx.frames.cameras[0].color.height, 576);
    EXPECT_EQ(rx.frames.cameras[0].depth.pixels[1], 501);
  }
}

TEST(HostileServer, DepthStreamDeclaringAnotherSizeIsRefusedBeforeDecoding) {
  const Outcome o = run_in_child([] {
    FakeServer server([](Connection& c) {
      read_hello(c);
      send_message(c, protocol::MessageType::kWelcome, welcome({camera(64, 48, "left wall")}));
      protocol::EncodedCamera cam = encoded("rvl", "raw", 64, 48);
      // An rvl frame header claiming 8000x8000 (the decoder would allocate 128 MB for it).
      cam.depth = {'V', 'D', 2, 1, 1, 0, 0, 0, 0x40, 0x1f, 0x40, 0x1f};
      cam.depth.resize(64, 0);
      send_frame_set(c, 1, {cam});
    });
    Client client(config(server.port(), "rvl", "raw"));
    ReceivedFrameSet rx;
    client.receive(rx);
  });
  EXPECT_EQ(o.kind, static_cast<int>(Kind::kProtocol)) << o.message;
  EXPECT_TRUE(contains(o.message, "camera 0 (left wall)")) << o.message;
  EXPECT_TRUE(contains(o.message, "depth stream declares 8000x8000")) << o.message;
  EXPECT_TRUE(contains(o.message, "64x48")) << o.message;
  expect_bounded(o);
}

TEST(HostileServer, JpegDeclaringAnotherSizeIsRefusedBeforeDecoding) {
  const Outcome o = run_in_child([] {
    FakeServer server([](Connection& c) {
      read_hello(c);
      send_message(c, protocol::MessageType::kWelcome,
                   welcome({camera(64, 48), camera(64, 48, "ceiling")}));
      protocol::EncodedCamera good = encoded("raw", "jpeg", 64, 48), bad = good;
      // The baseline frame header (SOF0: FF C0, length, precision, height, width; big-endian):
      // made 8000 wide and 6000 high.
      bool patched = false;
      for (size_t i = 0; !patched && i + 9 < bad.color.size(); ++i)
        if (bad.color[i] == 0xff && bad.color[i + 1] == 0xc0) {
          const uint8_t size[4] = {6000 >> 8, 6000 & 0xff, 8000 >> 8, 8000 & 0xff};
          std::copy(size, size + 4, bad.color.begin() + static_cast<ptrdiff_t>(i + 5));
          patched = true;
        }
      if (!patched) throw Error("test: no SOF0 marker in the JPEG");
      send_frame_set(c, 1, {good, bad});
    });
    Client client(config(server.port(), "raw", "jpeg"));
    ReceivedFrameSet rx;
    client.receive(rx);
  });
  EXPECT_EQ(o.kind, static_cast<int>(Kind::kProtocol)) << o.message;
  EXPECT_TRUE(contains(o.message, "camera 1 (ceiling)")) << o.message;
  EXPECT_TRUE(contains(o.message, "color stream declares 8000x6000")) << o.message;
  expect_bounded(o);
}

// ---------------------------------------------------------------------------------------------
// run_viewer and the CLI: the figures and the reason on every end.

TEST(HostileServer, ViewerReportsHowItEnded) {
  const auto dir = test::temp_dir("viewer_ends");
  // Two frame sets, then the server closes: a normal end.
  {
    FakeServer server(
        [](Connection& c) {
          read_hello(c);
          send_message(c, protocol::MessageType::kWelcome, welcome({camera(64, 48)}));
          send_frame_set(c, 1, {encoded("raw", "raw", 64, 48)});
          send_frame_set(c, 2, {encoded("raw", "raw", 64, 48)});
          uint8_t acks[2 * 20];  // read before closing: unread bytes would make it a reset
          c.read_exact(acks, 10000);
        },
        0ms);
    ViewerOptions opt;
    opt.client = config(server.port());
    opt.render = false;
    opt.stats_json = dir / "closed.json";
    const ViewerResult r = run_viewer(opt);
    EXPECT_EQ(r.ended, ViewerEnd::kServerClosed);
    EXPECT_EQ(r.frame_sets_received, 2u);
    const auto j = nlohmann::json::parse(std::ifstream(opt.stats_json));
    EXPECT_EQ(j["ended"], "server_closed");
    EXPECT_TRUE(j["error"].is_null());
  }
  // One frame set, then silence: an error end after a frame, with the figures.
  {
    FakeServer server([](Connection& c) {
      read_hello(c);
      send_message(c, protocol::MessageType::kWelcome, welcome({camera(64, 48)}));
      send_frame_set(c, 1, {encoded("raw", "raw", 64, 48)});
    });
    ViewerOptions opt;
    opt.client = config(server.port());
    opt.client.receive_timeout_ms = 500;
    opt.render = false;
    opt.stats_json = dir / "timeout.json";
    try {
      run_viewer(opt);
      ADD_FAILURE() << "no ViewerError";
    } catch (const ViewerError& e) {
      EXPECT_EQ(e.result().ended, ViewerEnd::kTimedOut);
      EXPECT_EQ(e.result().frame_sets_received, 1u);
      ASSERT_EQ(e.result().cameras.size(), 1u);
      EXPECT_EQ(e.result().cameras[0].frames_received, 1u);
      EXPECT_TRUE(contains(e.what(), "receive timeout")) << e.what();
    }
    const auto j = nlohmann::json::parse(std::ifstream(opt.stats_json));
    EXPECT_EQ(j["ended"], "timed_out");
    EXPECT_EQ(j["frame_sets_received"], 1);
  }
}

struct Process {
  int exit_code = -1;
  long max_rss_kb = 0;
  std::string output;
};

// Runs `args` (argv[0] the program) with stdout and stderr into one file; waits and reports its
// exit code and peak RSS (wait4).
Process run_process(const std::vector<std::string>& args, const std::filesystem::path& log) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  posix_spawn_file_actions_addopen(&actions, 1, log.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
  posix_spawn_file_actions_adddup2(&actions, 1, 2);
  pid_t pid = 0;
  Process p;
  const int rc = posix_spawn(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (rc != 0) {
    p.output = std::string("posix_spawn failed: ") + std::strerror(rc);
    return p;
  }
  int status = 0;
  rusage usage{};
  wait4(pid, &status, 0, &usage);
  p.exit_code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  p.max_rss_kb = usage.ru_maxrss;
  std::ifstream in(log);
  p.output.assign(std::istreambuf_iterator<char>(in), {});
  return p;
}

TEST(HostileServer, CliWritesStatsWithTheReasonAndExitsNonZeroOnSilence) {
  const auto dir = test::temp_dir("cli_silent_server");
  FakeServer server([](Connection& c) {
    read_hello(c);
    send_message(c, protocol::MessageType::kWelcome,
                 welcome({camera(64, 48, "cam\n[error] forged")}));
  });
  const Process p = run_process(
      {test::paths::volcast(), "view", "--connect", "127.0.0.1:" + std::to_string(server.port()),
       "--insecure", "--token", std::string(32, '0'), "--no-render", "--depth-codec", "raw",
       "--color-codec", "raw", "--stats-json", (dir / "stats.json").string(), "--receive-timeout",
       "1000", "--no-reconnect"},
      dir / "log.txt");
  EXPECT_EQ(p.exit_code, 1) << p.output;
  EXPECT_TRUE(contains(p.output, "receive timeout")) << p.output;
  EXPECT_TRUE(contains(p.output, "ended: timed_out")) << p.output;  // the table, printed anyway
  EXPECT_FALSE(contains(p.output, "\n[error] forged")) << p.output;
  ASSERT_TRUE(std::filesystem::exists(dir / "stats.json")) << p.output;
  const auto j = nlohmann::json::parse(std::ifstream(dir / "stats.json"));
  EXPECT_EQ(j["ended"], "timed_out");
  EXPECT_TRUE(contains(j["error"].get<std::string>(), "receive timeout"));
  EXPECT_EQ(j["frame_sets_received"], 0);
  ASSERT_EQ(j["cameras"].size(), 1u);
  EXPECT_EQ(j["cameras"][0]["description"], "cam\\x0a[error] forged");
  EXPECT_LT(p.max_rss_kb, 400 << 10) << "peak RSS of the viewer process";
}

TEST(HostileServer, CliWritesStatsWhenItCannotConnect) {
  const auto dir = test::temp_dir("cli_no_server");
  uint16_t port;
  {
    TcpListener probe("127.0.0.1", 0);  // a port nobody listens on once closed
    port = probe.port();
  }
  const Process p =
      run_process({test::paths::volcast(), "view", "--connect", "127.0.0.1:" + std::to_string(port),
                   "--insecure", "--token", std::string(32, '0'), "--no-render", "--stats-json",
                   (dir / "stats.json").string()},
                  dir / "log.txt");
  EXPECT_EQ(p.exit_code, 1) << p.output;
  EXPECT_TRUE(contains(p.output, "cannot connect")) << p.output;
  const auto j = nlohmann::json::parse(std::ifstream(dir / "stats.json"));
  EXPECT_EQ(j["ended"], "error");
  EXPECT_TRUE(contains(j["error"].get<std::string>(), "cannot connect"));
}

}  // namespace
}  // namespace volcast
