// The OpenXR presenter in a real session against a mock runtime (tests/support/
// mock_openxr_runtime.cpp, loaded by Debian's OpenXR loader through a runtime manifest named by
// XR_RUNTIME_JSON), under Xvfb for its GLX context, showing the real hands stream: it runs until
// the runtime asks to exit, submitting valid stereo projection layers whose two eye images show the
// scene, each from its own eye; it leaves the runtime cleanly when the stream ends first, and a
// lost instance ends the viewer's session as closed.
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <set>
#include <string>
#include <thread>
#include <vector>

#include "support/hands_site.hpp"
#include "support/session_site.hpp"
#include "support/speech.hpp"
#include "support/test_data.hpp"
#include "support/test_paths.hpp"
#include "support/xvfb.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/viewer/xr.hpp"
#include "volcast/voice/voice_link.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;

// The runtime manifest of the mock runtime in `dir`, for XR_RUNTIME_JSON.
fs::path write_manifest(const fs::path& dir) {
  const fs::path manifest = dir / "mock_runtime.json";
  std::ofstream(manifest) << nlohmann::json{
      {"file_format_version", "1.0.0"},
      {"runtime", {{"name", "volcast mock"}, {"library_path", test::paths::mock_xr()}}}};
  return manifest;
}

// The mock runtime installed for one test: its manifest in a fresh folder, its output folder, a
// display (Xvfb) for the GLX context, and the environment naming them, restored afterwards.
// frames: VOLCAST_MOCK_XR_FRAMES; end: VOLCAST_MOCK_XR_END (null: ask to exit). `gated`: the
// scripted controllers' clock and the frames counted for the end start at start_script()
// (VOLCAST_MOCK_XR_FROM), which the test calls once what the script acts on is there; else at once.
struct MockRuntime {
  fs::path dir, out, from;
  test::Xvfb xvfb;
  test::ScopedEnv display, runtime, frames, end, out_env, from_env;
  MockRuntime(const std::string& name, const char* frame_count, const char* end_how = nullptr,
              bool gated = false)
      : dir(test::temp_dir(name)),
        out(dir / "out"),
        from(dir / "from"),
        display("DISPLAY", xvfb.display().c_str()),
        runtime("XR_RUNTIME_JSON", write_manifest(dir).c_str()),
        frames("VOLCAST_MOCK_XR_FRAMES", frame_count),
        end("VOLCAST_MOCK_XR_END", end_how),
        out_env("VOLCAST_MOCK_XR_OUT", out.c_str()),
        from_env("VOLCAST_MOCK_XR_FROM", from.c_str()) {
    fs::create_directories(out);
    if (!gated) start_script();
  }
  void start_script() const { std::ofstream(from) << "go\n"; }
};

struct Ppm {
  int width = 0, height = 0;
  std::vector<uint8_t> rgb;
  const uint8_t* pixel(int x, int y) const { return &rgb[(size_t(y) * width + x) * 3]; }
};

Ppm read_ppm(const fs::path& path) {  // binary P6 with maxval 255, as the mock writes it
  std::ifstream in(path, std::ios::binary);
  std::string magic;
  int maxval = 0;
  Ppm image;
  in >> magic >> image.width >> image.height >> maxval;
  in.get();
  if (magic != "P6" || maxval != 255 || image.width <= 0 || image.height <= 0) return {};
  image.rgb.resize(size_t(image.width) * image.height * 3);
  in.read(reinterpret_cast<char*>(image.rgb.data()),
          static_cast<std::streamsize>(image.rgb.size()));
  if (!in) return {};
  return image;
}

// The fraction of pixels clearly off the top-left corner's colour, and the number of colours.
std::pair<double, size_t> content(const Ppm& image) {
  const uint8_t* corner = image.pixel(0, 0);
  size_t differing = 0;
  std::set<uint32_t> colours;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const uint8_t* p = image.pixel(x, y);
      differing +=
          std::abs(p[0] - corner[0]) + std::abs(p[1] - corner[1]) + std::abs(p[2] - corner[2]) > 30;
      colours.insert(uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16);
    }
  return {static_cast<double>(differing) / (image.width * image.height), colours.size()};
}

double mean_difference(const Ppm& a, const Ppm& b) {
  double sum = 0;
  for (size_t i = 0; i < a.rgb.size(); ++i) sum += std::abs(a.rgb[i] - b.rgb[i]);
  return sum / static_cast<double>(a.rgb.size());
}

// Mean absolute difference between `a` at x + shift and `b` at x, over the middle columns: smallest
// at the shift by which `a` shows the scene further right than `b`.
double shifted_difference(const Ppm& a, const Ppm& b, int shift) {
  double sum = 0;
  size_t n = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 32; x < a.width - 32; ++x) {
      const uint8_t *p = a.pixel(x + shift, y), *q = b.pixel(x, y);
      sum += std::abs(p[0] - q[0]) + std::abs(p[1] - q[1]) + std::abs(p[2] - q[2]);
      ++n;
    }
  return sum / static_cast<double>(n);
}

TEST(XrRuntime, ThePresenterRunsASessionOnAMockRuntimeUntilItAsksToExit) {
  const MockRuntime mock("xr_runtime", "5");
  ASSERT_TRUE(mock.xvfb.running()) << mock.xvfb.error();
  const fs::path& out = mock.out;

  std::string why;
  ASSERT_TRUE(xr_available(&why)) << why;

  test::HandsSite site(15);
  ViewerOptions opt;
  opt.client = client_config_from_link(site.server.join_link("127.0.0.1"));
  opt.seconds = 300;  // a safety net only: the runtime ends the session
  opt.presenter = xr_presenter(XrOptions{});
  const ViewerResult r = run_viewer(opt);
  EXPECT_EQ(r.ended, ViewerEnd::kClosed) << to_string(r.ended) << ": " << r.error;
  EXPECT_GE(r.frames_rendered, 5u);
  EXPECT_NE(r.renderer.find("OpenGL 4."), std::string::npos) << r.renderer;
  // The default picture, the blended mesh (--blend auto judges 10 frames at least: never here).
  EXPECT_EQ(r.blend_off, "");

  // What the runtime saw.
  ASSERT_TRUE(fs::exists(out / "log.json"));
  const nlohmann::json log = nlohmann::json::parse(std::ifstream(out / "log.json"));
  std::printf("mock runtime log: %s\n", log.dump().c_str());
  EXPECT_TRUE(log["errors"].empty()) << log["errors"].dump(2);
  EXPECT_EQ(log["sessions"], 1);
  EXPECT_FALSE(log["session_destroyed_running"].get<bool>());
  EXPECT_EQ(log["sessions_ended"], 1);  // xrEndSession on STOPPING
  EXPECT_TRUE(log["exit_requested"].get<bool>());
  EXPECT_GE(log["frames_with_layer"].get<int>(), 5);
  EXPECT_GE(log["frames_with_content"].get<int>(), 5);
  ASSERT_TRUE(log["images_written"].get<bool>());

  // The two eyes' last images: the scene, seen from two places.
  const Ppm left = read_ppm(out / "eye0.ppm"), right = read_ppm(out / "eye1.ppm");
  ASSERT_EQ(left.width, 256);
  ASSERT_EQ(left.height, 256);
  ASSERT_EQ(right.width, 256);
  ASSERT_EQ(right.height, 256);
  const auto [left_fraction, left_colours] = content(left);
  const auto [right_fraction, right_colours] = content(right);
  const double difference = mean_difference(left, right);
  std::printf(
      "eye images: left %.1f %% off the background, %zu colours; right %.1f %%, %zu colours; mean "
      "difference %.2f\n",
      100 * left_fraction, left_colours, 100 * right_fraction, right_colours, difference);
  EXPECT_GT(left_fraction, 0.05);
  EXPECT_GT(right_fraction, 0.05);
  EXPECT_GT(left_colours, 200u);
  EXPECT_GT(right_colours, 200u);
  EXPECT_GT(difference, 1.0);  // two eyes 64 mm apart see two different images
  // Each eye drew its own view: the left eye (view 0) sees the scene shifted right against the
  // right eye's image.
  int best = 0;
  for (int shift = -20; shift <= 20; ++shift)
    if (shifted_difference(left, right, shift) < shifted_difference(left, right, best))
      best = shift;
  std::printf("eye images best aligned at a shift of %d px\n", best);
  EXPECT_GT(best, 0);
}

TEST(XrRuntime, WhenTheStreamEndsFirstThePresenterLeavesTheRuntimeCleanly) {
  const MockRuntime mock("xr_runtime_stream_end", "1000000");  // never asks to exit
  ASSERT_TRUE(mock.xvfb.running()) << mock.xvfb.error();
  const fs::path& out = mock.out;

  test::HandsSite site(15);
  ViewerOptions opt;
  opt.client = client_config_from_link(site.server.join_link("127.0.0.1"));
  opt.frames = 10;
  opt.seconds = 300;  // a safety net only
  opt.presenter = xr_presenter(XrOptions{});
  const ViewerResult r = run_viewer(opt);
  EXPECT_EQ(r.ended, ViewerEnd::kFramesReached) << to_string(r.ended) << ": " << r.error;

  ASSERT_TRUE(fs::exists(out / "log.json"));
  const nlohmann::json log = nlohmann::json::parse(std::ifstream(out / "log.json"));
  std::printf("mock runtime log: %s\n", log.dump().c_str());
  EXPECT_TRUE(log["errors"].empty()) << log["errors"].dump(2);  // swapchains and spaces destroyed
  EXPECT_EQ(log["sessions"], 1);
  EXPECT_FALSE(log["exit_requested"].get<bool>());
}

TEST(XrRuntime, ALostInstanceEndsTheSessionAsClosedNotAsAnError) {
  const MockRuntime mock("xr_runtime_lost", "5", "lost");  // lost: XR_ERROR_INSTANCE_LOST, no event
  ASSERT_TRUE(mock.xvfb.running()) << mock.xvfb.error();
  const fs::path& out = mock.out;

  test::HandsSite site(15);
  ViewerOptions opt;
  opt.client = client_config_from_link(site.server.join_link("127.0.0.1"));
  opt.seconds = 300;  // a safety net only
  opt.presenter = xr_presenter(XrOptions{});
  ViewerResult r;
  ASSERT_NO_THROW(r = run_viewer(opt));
  EXPECT_EQ(r.ended, ViewerEnd::kClosed) << to_string(r.ended) << ": " << r.error;

  ASSERT_TRUE(fs::exists(out / "log.json"));
  const nlohmann::json log = nlohmann::json::parse(std::ifstream(out / "log.json"));
  std::printf("mock runtime log: %s\n", log.dump().c_str());
  EXPECT_TRUE(log["errors"].empty()) << log["errors"].dump(2);
  EXPECT_TRUE(log["lost"].get<bool>());
  EXPECT_GE(log["frames_with_content"].get<int>(), 5);
}

// A participant in a headset: the presenter draws the virtual OR for each eye and publishes the
// head as the participant's pose; another participant sees it standing at its spot. Its voice
// (push-to-talk, real speech) is sent while the mock holds the left controller's X (syncs 3 to
// 20) and only then; a press of Y (syncs 30 to 32) mutes it; the observer sees both, and the
// headset shows a red ball over its left hand.
TEST(XrRuntime, AHeadsetParticipantPublishesItsHeadTalksWithXAndMutesWithY) {
  // 42 frames: X held, a pause, Y pressed, and 9 frames to show the muted ball (31 s at 60, alone).
  // Its script runs once the observer stands ahead of the headset (start_script, below).
  const MockRuntime mock("xr_runtime_session", "42", nullptr, true);
  ASSERT_TRUE(mock.xvfb.running()) << mock.xvfb.error();
  // Then the left thumbstick pushed up once, looking at the observer: its voice 25 % louder.
  const test::ScopedEnv buttons("VOLCAST_MOCK_XR_BUTTONS",
                                "x/click:3,20;y/click:30,32;thumbstick/y:34,35");
  // The left hand held up ahead, where the eyes see the red ball over it once muted.
  const test::ScopedEnv left_grip("VOLCAST_MOCK_XR_LEFT_GRIP", "-0.05,1.4,-0.45");
  // A display of 0.1 ms periods: every frame is too slow to blend (the frame budget).
  const test::ScopedEnv period("VOLCAST_MOCK_XR_PERIOD_US", "100");
  std::vector<std::string> phrases;  // 90 s of speech: longer than X is held on a loaded machine
  for (int i = 0; i < 12; ++i)
    for (const char* name :
         {"Front_Center", "Front_Left", "Front_Right", "Side_Left", "Side_Right"})
      phrases.push_back(name);
  const fs::path speech = test::write_voice(mock.dir / "speech.wav", test::phrases(phrases, 0.1));
  test::SessionSite s(test::patient_hub(),
                      5);  // 5 frame sets a second: the room to see, less to encode
  const std::string link = s.link();
  s.hub.start_recording("Dr. Recorder");  // the headset must show it (no silent recording)
  test::TestParticipant observer(s, test::hand_driven("Observer"));
  // The headset participant.
  SessionClientOptions headset_options;
  headset_options.participant.name = "Headset";
  headset_options.drive_poses = false;  // the headset publishes
  SessionClient headset(headset_options);
  std::unique_ptr<voice::VoiceLink> talk;  // as volcast view --xr --join --mic --push-to-talk
  std::thread place_observer;
  ViewerOptions opt;
  opt.client = client_config_from_link(link);
  opt.seconds = 300;  // a safety net only: the runtime ends the session
  opt.on_connected = [&](Client& c) {
    headset.start(c);
    voice::VoiceConfig v;
    v.mic = speech.string();
    v.push_to_talk = true;
    v.spatial = false;  // no loudspeaker: no HRTF to run
    talk = std::make_unique<voice::VoiceLink>(*headset.participant(), v);
    // Its first frames wait for the join, so that the headset's poses count.
    for (int i = 0; i < 500 && !headset.participant()->joined(); ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    // Once the headset has published its head, the observer stands 1.5 m ahead of its eyes.
    place_observer = std::thread([&] {
      Participant* p = headset.participant();
      if (test::eventually([&] { return p->snapshot(wall_clock_us()).has_own_body; })) {
        const Pose head = p->snapshot(wall_clock_us()).own_body.head;
        const Eigen::Vector3f ahead =
            head.position + head.orientation * Eigen::Vector3f(0, 0, -1.5f);
        test::stand(observer, ahead);
        test::eventually([&] {  // the headset sees it there (what the thumbstick aims at)
          for (const auto& o : p->snapshot(wall_clock_us()).others)
            if (o.name == "Observer" && o.has_pose &&
                (o.newest_pose.head.position - ahead).norm() < 0.01f)
              return true;
          return false;
        });
      }
      mock.start_script();  // X, Y and the thumbstick, now that the observer stands there
    });
  };
  opt.on_finished = [&](ViewerResult&) {
    talk->stop();
    headset.stop();
  };
  XrOptions xr;
  xr.participant = [&] { return headset.participant(); };
  xr.voice = [&] { return talk.get(); };
  opt.presenter = xr_presenter(xr);
  // What the observer hears of the headset while it is there (it leaves when the session ends).
  test::VoiceWatch watch(observer, "Headset");
  const ViewerResult r = run_viewer(opt);
  if (place_observer.joinable()) place_observer.join();
  watch.stop();
  EXPECT_EQ(r.ended, ViewerEnd::kClosed) << to_string(r.ended) << ": " << r.error;
  EXPECT_GE(r.frames_rendered, 30u);
  // 42 frames span more than the frame budget's 2 s (a frame of llvmpipe's takes tens of ms).
  EXPECT_NE(r.blend_off.find("blending off: frames took "), std::string::npos) << r.blend_off;
  EXPECT_NE(r.blend_off.find("the display's period is 0.1 ms"), std::string::npos) << r.blend_off;
  ASSERT_TRUE(talk);
  const voice::VoiceStats sent = talk->stats();
  std::printf("headset's microphone: %llu frames captured, %llu sent, %llu silent (DTX)\n",
              static_cast<unsigned long long>(sent.frames_captured),
              static_cast<unsigned long long>(sent.packets_sent),
              static_cast<unsigned long long>(sent.dtx_frames));
  EXPECT_TRUE(talk->muted()) << "Y muted it";
  const auto observer_heard =
      std::find_if(sent.heard.begin(), sent.heard.end(),
                   [&](const voice::HeardVoice& h) { return h.id == observer.now().id; });
  ASSERT_NE(observer_heard, sent.heard.end()) << "the thumbstick set the observer's volume";
  EXPECT_FLOAT_EQ(observer_heard->volume, 1.25f) << "one push up, looking at it";
  EXPECT_GT(sent.packets_sent, 0u) << "X held: it talked";
  EXPECT_LT(sent.packets_sent + sent.dtx_frames, sent.frames_captured)
      << "before X and after it, the microphone was not sent";
  EXPECT_TRUE(watch.heard) << "the observer heard the headset";
  EXPECT_TRUE(watch.saw_muted) << "then saw it muted";

  const SessionSnapshot seen = observer.p().snapshot(wall_clock_us());
  observer.end();
  const ParticipantStats stats = observer.p().stats();
  uint64_t poses = 0;
  for (const auto& o : stats.others)
    if (o.name == "Headset") poses = o.poses_received;
  EXPECT_GE(poses, 10u) << "the observer saw the headset's head move";
  const auto departed = seen.departed;
  // Where it stood: above its spot (the mock's eyes are at the stage's origin height).
  bool found = false;
  for (const auto& o : seen.others)
    if (o.name == "Headset") {
      found = true;
      EXPECT_LT(std::hypot(o.newest_pose.head.position.x() - o.spot.x,
                           o.newest_pose.head.position.z() - o.spot.z),
                0.3f);
    }
  EXPECT_TRUE(found || !departed.empty());
  const nlohmann::json log = nlohmann::json::parse(std::ifstream(mock.out / "log.json"));
  EXPECT_TRUE(log["errors"].empty()) << log["errors"].dump(2);
  const Ppm left = read_ppm(mock.out / "eye0.ppm");
  ASSERT_EQ(left.width, 256);
  EXPECT_GT(content(left).first, 0.3) << "the room fills the eye";
  const auto red_in = [&](int x0, int x1, int y0, int y1) {
    size_t red = 0;
    for (int y = y0; y < y1; ++y)
      for (int x = x0; x < x1; ++x) {
        const uint8_t* p = left.pixel(x, y);
        red += p[0] > 170 && p[1] < 70 && p[2] < 70;
      }
    return red;
  };
  // Muted at the end: the red ball over the left hand, 45 cm ahead and 20 cm below the eyes
  // (about 100 pixels, around row 185 of 256).
  const size_t muted = red_in(0, left.width, left.height / 2, left.height);
  std::printf("left eye: %zu red pixels in its lower half (the muted ball over the left hand)\n",
              muted);
  EXPECT_GT(muted, 40u) << "the headset shows its own mute";
  // Recorded all along: the red ball fixed in view, 0.6 m ahead, 16 cm left and 12 cm up of the
  // head -- in the left eye (90 degrees wide, 256 pixels; 32 mm left of the head) about 3 pixels
  // round (101, 102).
  const size_t recording = red_in(92, 111, 94, 112);
  std::printf("left eye: %zu red pixels where the recording badge is\n", recording);
  EXPECT_GT(recording, 12u) << "the headset shows that the session is recorded";
}

// A headset participant grabs an organ with its controller: the mock's right grip, within reach
// of the (synthetic, exact) object, squeezes for 12 syncs while turning 0.03 rad per sync; the
// object follows the hand, is let go turned 0.36 rad, and an observer sees who held it and the
// headset's two tracked hands.
TEST(XrRuntime, AHeadsetGrabsAnOrganWithItsControllerAndTurnsIt) {
  // Its script runs once the headset holds the case and the observer has joined (below).
  const MockRuntime mock("xr_runtime_grab", "40", nullptr, true);
  ASSERT_TRUE(mock.xvfb.running()) << mock.xvfb.error();
  const test::ScopedEnv grip("VOLCAST_MOCK_XR_RIGHT_GRIP", "0.2,1.2,-0.3");
  const test::ScopedEnv squeeze("VOLCAST_MOCK_XR_SQUEEZE", "8,20");
  // A display of 0.1 ms periods, with blending kept on (--blend on): the frame budget is not asked.
  const test::ScopedEnv period("VOLCAST_MOCK_XR_PERIOD_US", "100");
  test::SessionSite s(test::patient_hub(),
                      5);  // 5 frame sets a second: the room to see, less to encode
  // The headset joins first: spawn spot (0, 1.4) facing the table (yaw 0), so its stage grip
  // (0.2, 1.2, -0.3) is at (0.2, 1.2, 1.1) in the room. The object waits 7 cm from it.
  SharedCase c;
  c.name = "synthetic";
  SharedObject o;
  o.name = "organ";
  o.rest.position = {0.2f, 1.25f, 1.05f};
  SharedPart part;
  part.name = "shell";
  part.positions = {{0, 0, 0}, {0.1f, 0, 0}, {0, 0.1f, 0}, {0, 0, 0.1f}};
  part.normals = {{0, 0, -1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  part.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  o.parts.push_back(part);
  c.objects.push_back(o);
  s.hub.set_case(c);
  SessionClientOptions headset_options;
  headset_options.participant.name = "Headset";
  headset_options.drive_poses = false;
  SessionClient headset(headset_options);
  std::unique_ptr<test::TestParticipant> observer;
  std::atomic<bool> done{false}, saw_held{false}, saw_hands{false}, ready{false};
  std::thread watch;
  ViewerOptions opt;
  opt.client = client_config_from_link(s.link());
  opt.seconds = 300;  // a safety net only: the runtime ends the session
  opt.on_connected = [&](Client& client) {
    headset.start(client);
    // The headset's join goes out once the viewer reads, after this returns: the observer joins
    // only after it, so that the headset has the first spawn spot (the grip's place above).
    watch = std::thread([&] {
      ready = test::eventually([&] {
        return headset.participant()->joined() && headset.participant()->shared_case() != nullptr;
      });
      observer = std::make_unique<test::TestParticipant>(s, test::named("Observer"));
      mock.start_script();  // the squeeze, now that the case is there and the observer watches
      while (!done) {
        const SessionSnapshot n = observer->now();
        for (const auto& other : n.others)
          if (other.name == "Headset" && other.has_pose && other.newest_pose.hands_tracked)
            saw_hands = true;
        if (!n.objects.empty() && n.objects[0].owner != 0) saw_held = true;
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    });
  };
  opt.on_finished = [&](ViewerResult&) { headset.stop(); };
  XrOptions xr;
  xr.participant = [&] { return headset.participant(); };
  xr.blend = BlendPolicy::kOn;
  opt.presenter = xr_presenter(xr);
  const ViewerResult r = run_viewer(opt);
  done = true;
  EXPECT_EQ(r.blend_off, "") << "--blend on";
  if (watch.joinable()) watch.join();
  EXPECT_EQ(r.ended, ViewerEnd::kClosed) << to_string(r.ended) << ": " << r.error;
  const nlohmann::json log = nlohmann::json::parse(std::ifstream(mock.out / "log.json"));
  EXPECT_TRUE(log["errors"].empty()) << log["errors"].dump(2);
  EXPECT_TRUE(ready) << "the headset joined and received the case";
  const SessionHubStats st = s.hub.stats();
  EXPECT_EQ(st.grabs, 1u);
  EXPECT_EQ(st.releases, 1u);
  EXPECT_GE(st.object_moves, 5u) << "it followed the hand";
  const session::ObjectState final_state = s.hub.objects("OR")[0];
  EXPECT_EQ(final_state.owner, 0u);
  EXPECT_NEAR(final_state.pose.orientation.angularDistance(o.rest.orientation), 0.36f, 0.01f);
  // Turned about the hand's vertical axis through the grip: still within reach of it.
  EXPECT_LT((final_state.pose.position - Eigen::Vector3f(0.2f, 1.2f, 1.1f)).norm(), 0.1f);
  EXPECT_TRUE(saw_held) << "the observer saw the headset hold it";
  EXPECT_TRUE(saw_hands) << "the observer received both tracked controllers as hands";
  ASSERT_TRUE(observer);
  ASSERT_TRUE(test::eventually([&] {
    const auto n = observer->now();
    return !n.objects.empty() &&
           n.objects[0].pose.orientation.angularDistance(final_state.pose.orientation) < 1e-4f;
  }));
}

// A headset points and draws on the live cloud with its right controller (issue 36): A held shows
// its pointer to an observer, the dot where the aim ray meets the hands camera's measured surface;
// B held while the hand turns (the mock turns it while it squeezes) draws a stroke along the
// table that the observer receives; the right thumbstick pressed leant up pins a 'cut here' label
// there, and the left thumbstick pressed in the same frame -- the label is sent by that frame and
// has not come back from the server -- erases it (the newest), not the stroke. The site is placed
// so that the camera sits at the controller, looking where it aims: the ray runs from the camera's
// centre.
TEST(XrRuntime, AHeadsetPointsAndDrawsOnTheLiveCloudWithItsRightController) {
  // Its script runs once the observer has joined (below).
  const MockRuntime mock("xr_runtime_point", "34", nullptr, true);
  ASSERT_TRUE(mock.xvfb.running()) << mock.xvfb.error();
  const test::ScopedEnv buttons("VOLCAST_MOCK_XR_BUTTONS",
                                "right/a/click:3,9;right/b/click:12,24;right/thumbstick/y:26,29;"
                                "right/thumbstick/click:27,28;thumbstick/click:27,28");
  const test::ScopedEnv squeeze("VOLCAST_MOCK_XR_SQUEEZE", "12,24");
  // The runtime ends the session once the observer was sent the label's erasing.
  const fs::path erased_seen = mock.dir / "erased";
  const test::ScopedEnv until("VOLCAST_MOCK_XR_UNTIL", erased_seen.c_str());
  // The headset joins first: spawn spot (0, 1.4) facing the table, so its right grip (the mock's
  // default, stage (0.2, 1.1, -0.3)) is at (0.2, 1.1, 1.1) in the room, aiming along -z.
  const Eigen::Vector3f aim_origin(0.2f, 1.1f, 1.1f), aim(0, 0, -1);
  SessionHubConfig hub;
  hub.site_translation = aim_origin;
  // The camera turned so that the aim runs through depth pixel (372, 180), 6.4 degrees off its
  // optical axis: that pixel and its 8 neighbours are valid in all 207 frames of the recording,
  // and so is (573, 180), where the ray turned by the stroke pins the label. The axis' own pixel
  // (320, 180) is invalid in 8 of them, where a ray rightly meets nothing (ray_hit.hpp).
  hub.site_yaw = float(M_PI - std::atan(52.0 / 460.0));
  ASSERT_EQ(test::hands_frames_with_holes_near({{372, 180}, {573, 180}}, 1), 0);
  test::SessionSite s(test::patient_hub(hub),
                      5);  // 5 frame sets a second: enough to point at, less to encode
  SessionClientOptions headset_options;
  headset_options.participant.name = "Headset";
  headset_options.drive_poses = false;
  SessionClient headset(headset_options);
  std::unique_ptr<test::TestParticipant> observer;
  std::atomic<bool> done{false}, ready{false}, saw_off{false};
  std::mutex seen_mutex;
  std::vector<PointerView> seen;  // the headset's pointer as the observer saw it, each change
  std::vector<std::pair<uint8_t, std::vector<uint8_t>>> handed;  // the observer's 0x51 and 0x52
  std::thread watch;
  ViewerOptions opt;
  opt.client = client_config_from_link(s.link());
  opt.seconds = 300;  // a safety net only: the runtime ends the session
  opt.on_connected = [&](Client& client) {
    headset.start(client);
    watch = std::thread([&] {  // the observer joins after the headset (its spawn spot, above)
      ready = test::eventually([&] { return headset.participant()->joined(); });
      observer = std::make_unique<test::TestParticipant>(s, test::named("Observer"));
      observer->p().set_drawing_handler([&](uint8_t type, std::span<const uint8_t> payload) {
        std::lock_guard lock(seen_mutex);
        handed.emplace_back(type, std::vector<uint8_t>(payload.begin(), payload.end()));
        if (type == 0x52) std::ofstream(erased_seen) << "erased\n";
      });
      // The pointer and the drawing, now that the observer watches (it joined after the
      // headset: its spawn spot) -- and sees the others (its snapshot lists the headset).
      test::eventually([&] { return observer->other("Headset").has_value(); });
      mock.start_script();
      while (!done) {
        const SessionSnapshot n = observer->now();
        const auto h = observer->other("Headset");
        bool on = false;
        for (const PointerView& p : n.pointers)
          if (h && p.participant == h->id) {
            on = true;
            std::lock_guard lock(seen_mutex);
            if (seen.empty() || seen.back().time_us != p.time_us) seen.push_back(p);
          }
        std::lock_guard lock(seen_mutex);
        saw_off = saw_off || (!on && !seen.empty());
        std::this_thread::sleep_for(std::chrono::milliseconds(5));
      }
    });
  };
  opt.on_finished = [&](ViewerResult&) { headset.stop(); };
  XrOptions xr;
  xr.participant = [&] { return headset.participant(); };
  // The default picture, the blended mesh, pointed at and drawn on: kept on (--blend on) however
  // slowly llvmpipe draws it.
  xr.blend = BlendPolicy::kOn;
  opt.presenter = xr_presenter(xr);
  const ViewerResult r = run_viewer(opt);
  EXPECT_EQ(r.ended, ViewerEnd::kClosed) << to_string(r.ended) << ": " << r.error;
  EXPECT_EQ(r.blend_off, "") << "--blend on";
  ASSERT_TRUE(observer);
  // The stroke, once it reached the observer.
  test::eventually([&] { return !observer->now().annotations.empty(); });
  done = true;
  if (watch.joinable()) watch.join();
  const nlohmann::json log = nlohmann::json::parse(std::ifstream(mock.out / "log.json"));
  EXPECT_TRUE(log["errors"].empty()) << log["errors"].dump(2);
  EXPECT_TRUE(ready) << "the headset joined";
  ASSERT_TRUE(headset.participant());
  EXPECT_EQ(headset.participant()->snapshot(wall_clock_us()).spot.z, 1.4f) << "its spawn spot";

  // The pointer: from the aim, its dot on the measured surface straight ahead (the hands
  // recording's pixel (372, 180): the table or a hand over it, 0.68 to 0.87 m from the camera).
  ASSERT_FALSE(seen.empty()) << "the observer never saw the headset's pointer";
  std::printf("the observer saw the headset's pointer %zu times\n", seen.size());
  const PointerView& first = seen.front();
  EXPECT_LT((first.origin - aim_origin).norm(), 1e-4f) << first.origin.transpose();
  ASSERT_TRUE(first.has_hit) << "the ray from the camera's centre meets what it measured";
  const Eigen::Vector3f ray = first.hit - first.origin;
  EXPECT_LT(std::acos(std::clamp(ray.normalized().dot(aim), -1.0f, 1.0f)), 0.002f)
      << "on the aim ray: " << ray.transpose();
  EXPECT_GT(ray.norm(), 0.3f);
  EXPECT_LT(ray.norm(), 1.2f);
  EXPECT_TRUE(saw_off) << "put away when A was let go";
  // The stroke: drawn while B was held and the hand turned 0.03 rad a frame, each point a hit
  // on the ray of its frame (from the aim's origin), the whole sweeping across the table.
  const SessionSnapshot final_view = observer->now();
  ASSERT_EQ(final_view.annotations.size(), 1u);
  const session::Annotation& stroke = final_view.annotations[0];
  EXPECT_EQ(stroke.kind, session::AnnotationKind::kStroke);
  EXPECT_EQ(stroke.author, headset.participant()->snapshot(wall_clock_us()).id);
  EXPECT_GE(stroke.points.size(), 5u);
  for (size_t i = 0; i < stroke.points.size(); ++i) {
    const float d = (stroke.points[i] - aim_origin).norm();
    EXPECT_GT(d, 0.3f) << i;
    EXPECT_LT(d, 1.5f) << i;
    EXPECT_NEAR(stroke.points[i].y(), aim_origin.y(), 0.01f) << "turned about +y only: " << i;
    if (i > 0) {
      EXPECT_GE((stroke.points[i] - stroke.points[i - 1]).norm(), 0.003f) << i;
    }
  }
  EXPECT_GT((stroke.points.back() - stroke.points.front()).norm(), 0.05f) << "it swept";
  // The label: pinned where the turned ray met the table, the preset the stick leant to, then
  // erased by the headset; the stroke stays.
  observer->p().set_drawing_handler(nullptr);
  std::lock_guard lock(seen_mutex);
  ASSERT_GE(handed.size(), 2u);
  ASSERT_EQ(handed.back().first, 0x52) << "the last drawing message: an erasing";
  const auto [erased_id, erased_by] = session::parse_erased(handed.back().second);
  EXPECT_EQ(erased_by, stroke.author);
  ASSERT_EQ(handed[handed.size() - 2].first, 0x51);
  const session::Annotation label = session::parse_annotation(handed[handed.size() - 2].second);
  EXPECT_EQ(erased_id, label.id) << "the newest, the label, not the stroke " << stroke.id;
  EXPECT_EQ(label.kind, session::AnnotationKind::kLabel);
  EXPECT_EQ(label.text, "cut here");
  EXPECT_EQ(label.author, stroke.author);
  ASSERT_EQ(label.points.size(), 1u);
  // On the ray turned as it was for the stroke's last point (within a frame's turn, 0.03 rad).
  const Eigen::Vector3f last = (stroke.points.back() - aim_origin).normalized();
  const Eigen::Vector3f pin = label.points[0] - aim_origin;
  EXPECT_LT(std::acos(std::clamp(pin.normalized().dot(last), -1.0f, 1.0f)), 0.035f)
      << pin.transpose() << " against " << last.transpose();
  EXPECT_GT(pin.norm(), 0.3f);
  EXPECT_LT(pin.norm(), 1.5f);
  observer->end();
}

}  // namespace
}  // namespace volcast
