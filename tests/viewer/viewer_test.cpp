// The viewers: desktop navigation and registration sliders (pure), the voice keys and buttons
// (pure), site config poses, the desktop window under Xvfb against a real stream (its voice keys
// reaching another participant), and OpenXR's stereo path (headless) and missing runtime.
#include <gtest/gtest.h>
#include <unistd.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <Eigen/Geometry>
#include <atomic>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <random>
#include <set>
#include <thread>

#include "support/session_site.hpp"
#include "support/speech.hpp"
#include "support/test_data.hpp"
#include "support/xvfb.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/io/site_config.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/session_client.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/render/headless_target.hpp"
#include "volcast/session/hub.hpp"
#include "volcast/viewer/desktop.hpp"
#include "volcast/viewer/navigation.hpp"
#include "volcast/viewer/pose_sliders.hpp"
#include "volcast/viewer/voice_keys.hpp"
#include "volcast/viewer/xr.hpp"
#include "volcast/viewer/xr_view.hpp"
#include "volcast/voice/voice_controls.hpp"
#include "volcast/voice/voice_link.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;

constexpr double kToRadians = std::numbers::pi / 180;

// Angle between two directions, degrees.
double degrees_between(const Eigen::Vector3f& a, const Eigen::Vector3f& b) {
  return std::acos(std::clamp(a.normalized().dot(b.normalized()), -1.0f, 1.0f)) / kToRadians;
}

ViewCamera level_camera() {  // y up, looking down -z at a pivot 2 m ahead
  ViewCamera c;
  c.eye = {0, 1, 2};
  c.target = {0, 1, 0};
  c.up = {0, 1, 0};
  return c;
}

// --- Navigation (pure) ---------------------------------------------------------------------------

TEST(Navigation, OrbitTurnsTheEyeAboutThePivotKeepingItsDistance) {
  const ViewCamera start = level_camera();
  const ViewCamera turned = orbit(start, 90, 0);
  EXPECT_EQ(turned.target, start.target);
  EXPECT_NEAR((turned.eye - turned.target).norm(), 2, 1e-5);
  // 90 degrees about +y (right-handed): the eye at +z goes to +x.
  EXPECT_NEAR(turned.eye.x(), 2, 1e-5);
  EXPECT_NEAR(turned.eye.z(), 0, 1e-5);
  const ViewCamera around = orbit(orbit(orbit(turned, 90, 0), 90, 0), 90, 0);
  EXPECT_LT((around.eye - start.eye).norm(), 1e-4);
  const ViewCamera raised = orbit(start, 0, 30);  // the eye rises toward up
  EXPECT_NEAR(raised.eye.y() - 1, 2 * std::sin(30 * kToRadians), 1e-4);
  EXPECT_NEAR((raised.eye - raised.target).norm(), 2, 1e-5);
}

TEST(Navigation, PitchStopsShortOfUpSoTheViewStaysDefined) {
  for (const float pitch : {1000.0f, -1000.0f}) {
    const ViewCamera orbited = orbit(level_camera(), 0, pitch);
    const double from_up = degrees_between(orbited.target - orbited.eye, orbited.up);
    EXPECT_GE(from_up, kMinPitchGapDeg - 1e-3);
    EXPECT_LE(from_up, 180 - kMinPitchGapDeg + 1e-3);
    EXPECT_NO_THROW(to_view(orbited, 1.5f));
    const ViewCamera looked = look(level_camera(), 0, pitch);
    EXPECT_NO_THROW(to_view(looked, 1.5f));
    EXPECT_GE(degrees_between(looked.target - looked.eye, looked.up), kMinPitchGapDeg - 1e-3);
  }
}

TEST(Navigation, ZoomApproachesThePivotAlongTheLineOfSightAndNeverReachesIt) {
  const ViewCamera start = level_camera();
  const ViewCamera closer = zoom(start, 1);
  EXPECT_NEAR((closer.eye - closer.target).norm(), 2 * 0.85, 1e-5);
  EXPECT_NEAR(degrees_between(closer.eye - closer.target, start.eye - start.target), 0, 1e-3);
  EXPECT_NEAR((zoom(closer, -1).eye - start.eye).norm(), 0, 1e-5);
  EXPECT_NEAR((zoom(start, 1000).eye - start.target).norm(), 0.05, 1e-5);
  EXPECT_NO_THROW(to_view(zoom(start, 1000), 1));
}

TEST(Navigation, LookTurnsTheLineOfSightAboutTheEye) {
  const ViewCamera start = level_camera();
  const ViewCamera left = look(start, 90, 0);  // positive yaw turns left
  EXPECT_EQ(left.eye, start.eye);
  EXPECT_NEAR(degrees_between(left.target - left.eye, {-1, 0, 0}), 0, 1e-3);
  EXPECT_NEAR((left.target - left.eye).norm(), 2, 1e-5);
  const ViewCamera up = look(start, 0, 20);
  EXPECT_GT(up.target.y(), start.target.y());
}

TEST(Navigation, FlyMovesEyeAndPivotTogetherLevel) {
  ViewCamera start = level_camera();
  start.target = {0, 0, 0};  // looking down and ahead
  const ViewCamera moved = fly(start, {0.5f, 0.25f, 1});
  const Eigen::Vector3f move = moved.eye - start.eye;
  EXPECT_LT(((moved.target - start.target) - move).norm(), 1e-6);  // together
  // Forward is level (walking, not diving), right is the view's right, up is up.
  EXPECT_NEAR(move.x(), 0.5f, 1e-5);
  EXPECT_NEAR(move.y(), 0.25f, 1e-5);
  EXPECT_NEAR(move.z(), -1, 1e-5);
}

// --- Registration sliders and site config poses (pure) -----------------------------------------

RigidTransform some_pose(double rx, double ry, double rz, Eigen::Vector3d t) {
  return {rotation_from_degrees({rx, ry, rz}), t};
}

void expect_same_pose(const RigidTransform& a, const RigidTransform& b, double tolerance) {
  EXPECT_LT((a.rotation - b.rotation).cwiseAbs().maxCoeff(), tolerance);
  EXPECT_LT((a.translation - b.translation).cwiseAbs().maxCoeff(), tolerance);
}

TEST(PoseSliders, ZeroSlidersGiveTheReceivedPoseExactly) {
  const RigidTransform received = some_pose(12, -40, 170, {0.3, -1.2, 2.5});
  const RigidTransform out = apply_sliders(received, PoseSliders{});
  EXPECT_EQ(out.rotation, received.rotation);
  EXPECT_EQ(out.translation, received.translation);
}

TEST(PoseSliders, MoveInMillimetresAlongWorldAxesAndTurnInPlace) {
  const RigidTransform received = some_pose(0, 30, 0, {1, 2, 3});
  PoseSliders s;
  s.translation_mm = {1000, 0, -500};
  const RigidTransform moved = apply_sliders(received, s);
  EXPECT_LT((moved.translation - Eigen::Vector3d(2, 2, 2.5)).norm(), 1e-12);
  EXPECT_EQ(moved.rotation, received.rotation);
  s = PoseSliders{};
  s.rotation_deg = {0, 90, 0};
  const RigidTransform turned = apply_sliders(received, s);
  EXPECT_EQ(turned.translation, received.translation);  // about the camera's own origin
  // The optical axis turns 90 degrees about world +y.
  const Eigen::Vector3d axis = received.rotation * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d expected =
      Eigen::AngleAxisd(std::numbers::pi / 2, Eigen::Vector3d::UnitY()) * axis;
  EXPECT_LT((turned.rotation * Eigen::Vector3d::UnitZ() - expected).norm(), 1e-6);
}

TEST(ViewerSiteConfig, RotationIsRzTimesRyTimesRx) {
  const Eigen::Matrix3d rx = rotation_from_degrees({90, 0, 0});
  EXPECT_LT((rx * Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
  const Eigen::Matrix3d rz = rotation_from_degrees({0, 0, 90});
  EXPECT_LT((rz * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 1e-12);
  // Rz * Rx: x stays under Rx, then Rz takes it to y (Rx * Rz would take it to z).
  const Eigen::Matrix3d both = rotation_from_degrees({90, 0, 90});
  EXPECT_LT((both * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm(), 1e-12);
  EXPECT_LT((both * Eigen::Vector3d::UnitY() - Eigen::Vector3d::UnitZ()).norm(), 1e-12);
}

TEST(ViewerSiteConfig, AnglesRoundTripThroughTheRotation) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> any(-179.9, 179.9), tilt(-89.9, 89.9);
  for (int i = 0; i < 200; ++i) {
    const Eigen::Vector3d angles(any(rng), tilt(rng), any(rng));
    EXPECT_LT((degrees_from_rotation(rotation_from_degrees(angles)) - angles).norm(), 1e-7)
        << angles.transpose();
  }
  for (const double ry : {90.0, -90.0}) {  // gimbal lock: the rotation still round-trips
    const Eigen::Matrix3d r = rotation_from_degrees({25, ry, -60});
    EXPECT_LT((rotation_from_degrees(degrees_from_rotation(r)) - r).cwiseAbs().maxCoeff(), 1e-9);
  }
}

TEST(ViewerSiteConfig, SlidersSavedToTheSiteConfigReadBackAsTheSamePoseKeepingOtherKeys) {
  const fs::path dir = test::temp_dir("site_poses");
  const fs::path file = dir / "site.json";
  std::ofstream(file) << R"({"cameras": [
      {"source": "a.mkv", "name": "left", "filters": {"hole_fill": 3}},
      {"source": "b", "intrinsics": "460,460,320,180",
       "world_from_camera": {"translation_m": [9, 9, 9]}}],
    "note": "kept"})";
  const RigidTransform received[] = {some_pose(10, 20, 30, {0.1, 0.2, 0.3}),
                                     some_pose(-5, 80, 175, {-1.5, 0, 4})};
  PoseSliders first, second;
  first.translation_mm = {120, -250, 33};
  first.rotation_deg = {4.5, -12, 170};
  second.rotation_deg = {0, 9.5, 0};
  const std::vector<RigidTransform> saved = {apply_sliders(received[0], first),
                                             apply_sliders(received[1], second)};
  write_site_poses(file, saved);

  const auto back = read_site_poses(file);  // what serve --config reads
  ASSERT_EQ(back.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    ASSERT_TRUE(back[i].has_value());
    expect_same_pose(*back[i], saved[i], 1e-9);
  }
  std::ifstream in(file);
  const auto j = nlohmann::ordered_json::parse(in);
  EXPECT_EQ(j["note"], "kept");
  EXPECT_EQ(j["cameras"][0]["name"], "left");
  EXPECT_EQ(j["cameras"][0]["filters"]["hole_fill"], 3);
  EXPECT_EQ(j["cameras"][0].begin().key(), "source");  // the user's order of keys
  EXPECT_EQ(j["cameras"][1]["intrinsics"], "460,460,320,180");
  EXPECT_FALSE(fs::exists(file.string() + ".tmp"));
}

TEST(ViewerSiteConfig, SaveCreatesAMissingFileHoldingOnlyThePoses) {
  const fs::path file = test::temp_dir("site_new") / "new.json";
  const std::vector<RigidTransform> poses = {some_pose(0, 0, 0, {1, 2, 3})};
  write_site_poses(file, poses);
  const auto back = read_site_poses(file);
  ASSERT_EQ(back.size(), 1u);
  ASSERT_TRUE(back[0].has_value());
  expect_same_pose(*back[0], poses[0], 1e-12);
  std::ifstream in(file);
  const auto j = nlohmann::json::parse(in);
  EXPECT_EQ(j.size(), 1u);
  EXPECT_EQ(j["cameras"][0].size(), 1u);  // only "world_from_camera"
}

TEST(ViewerSiteConfig, AMalformedPoseIsAnErrorNamingTheFileCameraAndKey) {
  const fs::path file = test::temp_dir("site_bad") / "bad.json";
  const auto error_for = [&](const std::string& pose) {
    std::ofstream(file) << R"({"cameras": [{"source": "a"}, {"source": "b", "world_from_camera": )"
                        << pose << "}]}";
    return test::error_of([&] { read_site_poses(file); });
  };
  for (const auto& [pose, key] : std::vector<std::pair<std::string, std::string>>{
           {R"({"rotation_deg": [1, 2]})", "rotation_deg"},
           {R"({"translation_m": [1, "2", 3]})", "translation_m"},
           {R"({"translation_m": [1, 2, 3], "rotation": [0, 0, 0]})", "\"rotation\""},
           {"5", "world_from_camera"}}) {
    const std::string e = error_for(pose);
    EXPECT_NE(e.find(file.string()), std::string::npos) << e;
    EXPECT_NE(e.find("camera 1"), std::string::npos) << e;
    EXPECT_NE(e.find(key), std::string::npos) << e;
  }
  EXPECT_EQ(error_for(R"({"rotation_deg": [0, 0, 90]})"), "");
}

// --- Voice controls (pure) -----------------------------------------------------------------------

TEST(VoiceKeys, VIsHeldToTalkAndEachMPressTogglesMute) {
  voice::VoiceInput in;
  EXPECT_TRUE(voice_key(in, GLFW_KEY_V, GLFW_PRESS, 0));
  EXPECT_TRUE(in.talk_held);
  EXPECT_FALSE(voice_key(in, GLFW_KEY_V, GLFW_REPEAT, 0)) << "a held key repeats: still held";
  EXPECT_TRUE(in.talk_held);
  EXPECT_TRUE(voice_key(in, GLFW_KEY_V, GLFW_RELEASE, GLFW_MOD_SHIFT));
  EXPECT_FALSE(in.talk_held);
  EXPECT_TRUE(voice_key(in, GLFW_KEY_M, GLFW_PRESS, 0));
  EXPECT_TRUE(in.toggle_mute);
  EXPECT_FALSE(voice_key(in, GLFW_KEY_M, GLFW_RELEASE, 0));
  EXPECT_TRUE(voice_key(in, GLFW_KEY_M, GLFW_PRESS, 0)) << "pressed twice before a frame";
  EXPECT_FALSE(in.toggle_mute);
  EXPECT_FALSE(voice_key(in, GLFW_KEY_M, GLFW_PRESS, GLFW_MOD_CONTROL)) << "Ctrl+M is not mute";
  // Keys that navigation already uses are not voice keys.
  for (int key : {GLFW_KEY_W, GLFW_KEY_A, GLFW_KEY_S, GLFW_KEY_D, GLFW_KEY_Q, GLFW_KEY_E,
                  GLFW_KEY_R, GLFW_KEY_P, GLFW_KEY_H, GLFW_KEY_T, GLFW_KEY_F12}) {
    EXPECT_FALSE(voice_key(in, key, GLFW_PRESS, 0)) << key;
    EXPECT_NE(key, kTalkKey);
    EXPECT_NE(key, kMuteKey);
  }
  EXPECT_FALSE(in.talk_held || in.toggle_mute);
}

TEST(VoiceButtons, TalkFollowsTheButtonAndMuteTogglesOnlyWhenItGoesDown) {
  voice::VoiceInput in;
  voice::VoiceButtons before;
  voice::press_voice_buttons(in, before, {true, false});
  EXPECT_TRUE(in.talk_held);
  voice::press_voice_buttons(in, before, {true, true});
  EXPECT_TRUE(in.toggle_mute);
  in.toggle_mute = false;                                 // applied
  voice::press_voice_buttons(in, before, {false, true});  // still held: no second toggle
  EXPECT_FALSE(in.talk_held);
  EXPECT_FALSE(in.toggle_mute);
  voice::press_voice_buttons(in, before, {false, false});
  voice::press_voice_buttons(in, before, {false, true});
  EXPECT_TRUE(in.toggle_mute) << "pressed again";
}

TEST(VoiceRows, EveryoneInTheSessionWithWhatTheLinkHeardElseTheirPackets) {
  SessionSnapshot s;
  const auto other = [](uint32_t id, const char* name, bool muted, int64_t last_voice_us) {
    RemoteParticipant p;
    p.id = id;
    p.name = name;
    p.muted = muted;
    p.last_voice_us = last_voice_us;
    return p;
  };
  s.others = {other(2, "Dr. A", false, 0), other(3, "Dr. B", true, 1'000'000),
              other(4, "Dr. C", false, 1'250'000)};
  voice::VoiceStats stats;
  voice::HeardVoice heard;
  heard.id = 2;
  heard.speaking = true;
  heard.volume = 0.5f;
  stats.heard = {heard};
  const std::map<std::string, float> volumes{{"Dr. B", 2.0f}};
  const auto rows = voice::voice_rows(s, &stats, volumes, 1'400'000);
  ASSERT_EQ(rows.size(), 3u);
  EXPECT_EQ(rows[0].name, "Dr. A");
  EXPECT_TRUE(rows[0].speaking);
  EXPECT_FLOAT_EQ(rows[0].volume, 0.5f);
  EXPECT_TRUE(rows[1].muted);
  EXPECT_FALSE(rows[1].speaking) << "the link heard nothing of it";
  EXPECT_FLOAT_EQ(rows[1].volume, 2.0f) << "--volume by name until it is heard";
  EXPECT_FLOAT_EQ(rows[2].volume, 1.0f);
  // Without a link: a voice packet in the last 300 ms is speaking.
  const auto bare = voice::voice_rows(s, nullptr, {}, 1'400'000);
  EXPECT_FALSE(bare[0].speaking);
  EXPECT_FALSE(bare[1].speaking) << "400 ms ago";
  EXPECT_TRUE(bare[2].speaking) << "150 ms ago";
  EXPECT_TRUE(bare[1].muted);
}

// The headset's volume gesture (synthetic poses: exact behaviour). The listener stands at the
// origin, its head 1.6 m up looking along -z; Dr. A stands 2 m ahead, Dr. B 2 m to its right
// (90 degrees off), the OR site's voice above the table 1.5 m ahead.
TEST(VolumeGesture, EachThumbstickPushStepsTheVoiceLookedAtWithinItsRange) {
  SessionSnapshot s;
  s.has_own_body = true;
  s.own_body.head.position = {0, 1.6f, 0};
  const auto other = [](uint32_t id, const char* name, Eigen::Vector3f head) {
    RemoteParticipant p;
    p.id = id;
    p.name = name;
    p.has_pose = true;
    p.pose.head.position = head;
    return p;
  };
  s.others = {other(2, "Dr. A", {0, 1.7f, -2}), other(3, "Dr. B", {2, 1.6f, 0})};
  RemoteParticipant site;
  site.id = 1;
  site.name = "OR site";
  site.role = session::Role::kOrSite;
  s.others.push_back(site);
  const Eigen::Vector3f site_at{0.5f, 1.5f, -6};  // behind Dr. A, 5 degrees to its right
  std::vector<voice::VoiceRow> rows = voice::voice_rows(s, nullptr, {}, 0);
  voice::VolumeGesture g;
  voice::VoiceInput in;
  // Up: Dr. A (the nearest to the line of sight; the site is 5 degrees off it) to 125 %.
  EXPECT_EQ(voice::step_volume(g, in, s, rows, 0.9f, site_at, 1'000'000), 2u);
  ASSERT_EQ(in.volumes.size(), 1u);
  EXPECT_EQ(in.volumes[0], std::make_pair(2u, 1.25f));
  EXPECT_EQ(g.shown_until_us, 1'000'000 + voice::kVolumeShownUs);
  EXPECT_TRUE(g.shown_at.isApprox(Eigen::Vector3f(0, 1.7f, -2)));
  // Held out: no second step; back to rest, pushed again: 150 %.
  EXPECT_EQ(voice::step_volume(g, in, s, rows, 1.0f, site_at, 1'010'000), 0u);
  EXPECT_EQ(voice::step_volume(g, in, s, rows, 0.1f, site_at, 1'020'000), 0u);
  EXPECT_EQ(voice::step_volume(g, in, s, rows, 0.7f, site_at, 1'030'000), 2u);
  EXPECT_FLOAT_EQ(in.volumes.back().second, 1.5f) << "from the step before, not the rows' 1";
  // Down to silence, and not below.
  for (int i = 0; i < 8; ++i) {
    voice::step_volume(g, in, s, rows, 0, site_at, 1'040'000);
    voice::step_volume(g, in, s, rows, -0.8f, site_at, 1'040'000);
  }
  EXPECT_FLOAT_EQ(in.volumes.back().second, 0.0f);
  // Up to 400 %, and not above.
  in.volumes.clear();
  for (int i = 0; i < 20; ++i) {
    voice::step_volume(g, in, s, rows, 0, site_at, 1'050'000);
    voice::step_volume(g, in, s, rows, 1, site_at, 1'050'000);
  }
  EXPECT_FLOAT_EQ(in.volumes.back().second, 4.0f);
  // Turned to the right (Dr. B): the step is Dr. B's, from the rows' 100 %.
  s.own_body.head.orientation = Eigen::AngleAxisf(-float(M_PI) / 2, Eigen::Vector3f::UnitY());
  voice::step_volume(g, in, s, rows, 0, site_at, 1'060'000);
  EXPECT_EQ(voice::step_volume(g, in, s, rows, -1, site_at, 1'060'000), 3u);
  EXPECT_FLOAT_EQ(in.volumes.back().second, 0.75f);
  // Dr. A moved aside: the OR site's voice is the one looked at.
  s.own_body.head.orientation = Eigen::Quaternionf::Identity();
  s.others[0].pose.head.position = {-2, 1.6f, -1};
  voice::step_volume(g, in, s, rows, 0, site_at, 1'070'000);
  EXPECT_EQ(voice::step_volume(g, in, s, rows, 1, site_at, 1'070'000), 1u);
  // Looking up at the ceiling: nobody within 20 degrees, nothing stepped.
  s.own_body.head.orientation = Eigen::AngleAxisf(float(M_PI) / 2, Eigen::Vector3f::UnitX());
  voice::step_volume(g, in, s, rows, 0, site_at, 1'080'000);
  const size_t before = in.volumes.size();
  EXPECT_EQ(voice::step_volume(g, in, s, rows, 1, site_at, 1'080'000), 0u);
  EXPECT_EQ(in.volumes.size(), before);
}

// --- The desktop window under Xvfb ---------------------------------------------------------------

TEST(DesktopViewer, WithoutADisplaySaysWhyInsteadOfFailing) {
  const test::ScopedEnv display("DISPLAY", ":4093");  // nothing listens there
  std::string why;
  EXPECT_FALSE(desktop_available(&why));
  EXPECT_NE(why.find(":4093"), std::string::npos) << why;
}

TEST(DesktopViewer, ShowsTheRealStreamUnderXvfbScreenshotKeyAndCtrlSSave) {
  const test::Xvfb xvfb;
  ASSERT_TRUE(xvfb.running()) << xvfb.error();
  const test::ScopedEnv display("DISPLAY", xvfb.display().c_str());
  const fs::path dir = test::temp_dir("desktop_viewer");
  test::HandsSite site(15);
  ViewerOptions opt;
  opt.client = client_config_from_link(site.server.join_link("127.0.0.1"));
  opt.seconds = 300;  // a safety net only: the window closes itself after max_frames
  DesktopOptions desktop;
  desktop.width = 640;
  desktop.height = 400;
  desktop.screenshot = dir / "shot.png";
  desktop.site_config = dir / "site.json";
  // Pressed before drawing the third and fourth frames of the stream.
  desktop.script = {{3, GLFW_KEY_F12}, {4, GLFW_KEY_S, GLFW_MOD_CONTROL}};
  desktop.max_frames = 5;
  opt.presenter = desktop_presenter(desktop);
  const ViewerResult r = run_viewer(opt);
  EXPECT_EQ(r.ended, ViewerEnd::kClosed) << r.error;
  EXPECT_EQ(r.frames_rendered, 5u);
  EXPECT_NE(r.renderer.find("OpenGL 4."), std::string::npos) << r.renderer;
  // The default picture, the blended mesh (--blend auto judges 10 frames at least: never here).
  EXPECT_EQ(r.blend_off, "");
  ASSERT_TRUE(fs::exists(desktop.screenshot));
  const ColorImage shot = read_color_png(desktop.screenshot);
  EXPECT_EQ(shot.width, 640);
  EXPECT_EQ(shot.height, 400);
  // Real content, not the cleared background: many pixels differ from the corner's colour and
  // they are of many colours (the hands and the room, not one flat fill).
  const uint8_t* corner = shot.pixel(0, 0);
  size_t differing = 0;
  std::set<uint32_t> colours;
  for (int y = 0; y < shot.height; ++y)
    for (int x = 0; x < shot.width; ++x) {
      const uint8_t* p = shot.pixel(x, y);
      differing +=
          std::abs(p[0] - corner[0]) + std::abs(p[1] - corner[1]) + std::abs(p[2] - corner[2]) > 30;
      colours.insert(uint32_t{p[0]} | uint32_t{p[1]} << 8 | uint32_t{p[2]} << 16);
    }
  const double fraction = static_cast<double>(differing) / (shot.width * shot.height);
  std::printf("desktop screenshot %s: %.1f %% of pixels off the background, %zu colours\n",
              desktop.screenshot.c_str(), 100 * fraction, colours.size());
  EXPECT_GT(fraction, 0.05);
  EXPECT_GT(colours.size(), 500u);
  // Ctrl+S saved the camera's pose (untouched sliders: the pose the server sent, the identity).
  const auto poses = read_site_poses(desktop.site_config);
  ASSERT_EQ(poses.size(), 1u);
  ASSERT_TRUE(poses[0].has_value());
  expect_same_pose(*poses[0], RigidTransform::identity(), 1e-12);
}

// The desktop window as a participant (the paper's mouse-and-keyboard fallback): it publishes
// its eye as the head pose, draws the room, and T then a click on the floor teleports there; then,
// holding L, it points (the observer sees its pointer), drags a stroke over what it sees and
// pins a label with N (the observer receives both, on the surfaces under the mouse).
TEST(DesktopViewer, JoinsASessionPublishesItsEyeTeleportsByClickAndDraws) {
  const test::Xvfb xvfb;
  ASSERT_TRUE(xvfb.running()) << xvfb.error();
  const test::ScopedEnv display("DISPLAY", xvfb.display().c_str());
  const fs::path dir = test::temp_dir("desktop_session");
  test::SessionSite s(test::patient_hub());
  const std::string link = s.link();
  test::TestParticipant observer(s, test::named("Observer"));
  SessionClientOptions window_options;
  window_options.participant.name = "Desk";
  window_options.drive_poses = false;  // the window publishes its eye
  SessionClient window(window_options);
  ViewerOptions opt;
  opt.client = client_config_from_link(link);
  opt.seconds = 300;  // a safety net only
  opt.on_connected = [&](Client& c) { window.start(c); };
  opt.on_finished = [&](ViewerResult&) { window.stop(); };
  DesktopOptions desktop;
  desktop.width = 640;
  desktop.height = 400;
  desktop.screenshot = dir / "eye.png";
  desktop.participant = [&] { return window.participant(); };
  // T, then a click low in the window (the floor ahead), then a screenshot; 40 frames in all.
  desktop.script = {{3, GLFW_KEY_T},
                    {8, GLFW_KEY_L},
                    {23, GLFW_KEY_N},
                    {25, GLFW_KEY_L, 0, true},
                    {30, GLFW_KEY_F12}};
  desktop.clicks = {{4, 120, 395}};  // ahead and to the left, clear of the others
  // With L held: the left button drags from (250, 330) to (390, 330), low in the window.
  desktop.mouse = {{8, 250, 330}, {10, 250, 330, GLFW_MOUSE_BUTTON_LEFT}};
  for (int i = 1; i <= 10; ++i) desktop.mouse.push_back({uint64_t(10 + i), 250.0 + 14 * i, 330});
  desktop.mouse.push_back({21, 390, 330, GLFW_MOUSE_BUTTON_LEFT, true});
  desktop.max_frames = 40;
  // The default picture, the blended mesh, pointed and drawn on in every frame: kept on (--blend
  // on), however slow the frames, against a display of 0.1 ms periods that none keeps.
  desktop.blend = BlendPolicy::kOn;
  desktop.frame_period_us = 100;
  std::atomic<bool> pointer_seen{false}, watching{true};
  std::thread watch([&] {
    while (watching && !pointer_seen) {
      for (const PointerView& p : observer.now().pointers) pointer_seen = pointer_seen || p.has_hit;
      std::this_thread::sleep_for(std::chrono::milliseconds(5));
    }
  });
  opt.presenter = desktop_presenter(desktop);
  const ViewerResult r = run_viewer(opt);
  EXPECT_EQ(r.ended, ViewerEnd::kClosed) << r.error;
  EXPECT_EQ(r.frames_rendered, 40u);
  EXPECT_EQ(r.blend_off, "") << "--blend on";

  watching = false;
  watch.join();
  EXPECT_TRUE(pointer_seen) << "the window's pointer, on a surface, while L was held";
  ASSERT_TRUE(test::eventually([&] { return observer.now().annotations.size() == 2; },
                               std::chrono::seconds(30)));
  const SessionSnapshot seen = observer.p().snapshot(wall_clock_us());
  const ParticipantStats stats = observer.p().stats();
  observer.end();
  const session::Annotation& stroke = seen.annotations[0];
  EXPECT_EQ(stroke.kind, session::AnnotationKind::kStroke);
  EXPECT_GE(stroke.points.size(), 5u) << "a point a frame dragged, 3 mm apart at least";
  for (const Eigen::Vector3f& q : stroke.points)  // inside the room, on what the window drew
    EXPECT_TRUE(q.allFinite() && q.y() > -0.05f && q.y() < 3 && q.cwiseAbs().maxCoeff() < 10)
        << q.transpose();
  EXPECT_EQ(seen.annotations[1].kind, session::AnnotationKind::kLabel);
  EXPECT_EQ(seen.annotations[1].text, "here");
  uint64_t poses = 0;
  for (const auto& o : stats.others)
    if (o.name == "Desk") poses = o.poses_received;
  EXPECT_GE(poses, 20u) << "a pose per frame drawn";
  bool teleported = false;
  for (const auto& t : seen.teleports)
    teleported |= std::hypot(t.to.x - t.from.x, t.to.z - t.from.z) > 0.5f;
  EXPECT_TRUE(teleported) << "the click on the floor teleported the window's participant";
  ASSERT_TRUE(fs::exists(desktop.screenshot));
  const ColorImage shot = read_color_png(desktop.screenshot);
  size_t lit = 0;  // the room's floor and walls, not the cleared background
  for (size_t i = 0; i < shot.bgra.size(); i += 4) lit += shot.bgra[i + 1] > 50;
  EXPECT_GT(lit, shot.bgra.size() / 4 / 2);
}

// The window's voice keys reach the others: with push-to-talk the window's microphone (real
// speech) sends only while V is held, and M mutes it, which the observer sees (VoiceState). The
// panel, pictured while V is held, lists the observer speaking.
TEST(DesktopViewer, PushToTalkWithVAndMuteWithMReachTheOthers) {
  const test::Xvfb xvfb;
  ASSERT_TRUE(xvfb.running()) << xvfb.error();
  const test::ScopedEnv display("DISPLAY", xvfb.display().c_str());
  const fs::path dir = test::temp_dir("desktop_voice");
  // Speech long enough to outlast the window: five phrases, four times (30 s).
  std::vector<std::string> phrases;
  for (int i = 0; i < 4; ++i)
    for (const char* name :
         {"Front_Center", "Front_Left", "Front_Right", "Side_Left", "Side_Right"})
      phrases.push_back(name);
  const fs::path speech = test::write_voice(dir / "speech.wav", test::phrases(phrases, 0.1));
  test::SessionSite s(test::patient_hub());
  const std::string link = s.link();
  test::TestParticipant observer(s, test::hand_driven("Observer"));
  voice::VoiceConfig observer_voice;
  observer_voice.mic = speech.string();
  voice::VoiceLink observer_link(observer.p(), observer_voice);
  SessionClientOptions window_options;
  window_options.participant.name = "Desk";
  window_options.drive_poses = false;  // the window publishes its eye
  SessionClient window(window_options);
  std::unique_ptr<voice::VoiceLink> window_link;  // as volcast view --join --mic --push-to-talk
  ViewerOptions opt;
  opt.client = client_config_from_link(link);
  opt.seconds = 300;  // a safety net only
  opt.on_connected = [&](Client& c) {
    window.start(c);
    voice::VoiceConfig v;
    v.mic = speech.string();
    v.push_to_talk = true;
    v.spatial = false;             // no loudspeaker: no HRTF to run
    v.volumes["Observer"] = 0.5f;  // --volume Observer=0.5
    window_link = std::make_unique<voice::VoiceLink>(*window.participant(), v);
  };
  opt.on_finished = [&](ViewerResult&) {
    window_link->stop();
    window.stop();
  };
  DesktopOptions desktop;
  desktop.width = 800;
  desktop.height = 600;
  desktop.screenshot = dir / "panel.png";
  desktop.screenshot_panel = true;
  desktop.participant = [&] { return window.participant(); };
  // Read once a frame: it also paces the window at 50 frames a second at most (Xvfb has no
  // vsync), so that V held for 12 frames is held for 0.24 s at least.
  desktop.voice = [&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
    return window_link.get();
  };
  // V held from frame 3 to 15 (the picture at 12), then M.
  desktop.script = {
      {3, GLFW_KEY_V}, {12, GLFW_KEY_F12}, {15, GLFW_KEY_V, 0, true}, {17, GLFW_KEY_M}};
  desktop.max_frames = 22;
  desktop.frame_period_us = 100;  // every frame too slow to blend (the frame budget, --blend auto)
  opt.presenter = desktop_presenter(desktop);
  // What the observer sees of the window while it is there (it leaves when the window closes).
  test::VoiceWatch watch(observer, "Desk");
  const ViewerResult r = run_viewer(opt);
  // 22 frames, the display's period 0.1 ms: the budget turned blending off once 10 were judged.
  EXPECT_NE(r.blend_off.find("blending off: frames took "), std::string::npos) << r.blend_off;
  EXPECT_NE(r.blend_off.find("the display's period is 0.1 ms"), std::string::npos) << r.blend_off;
  watch.stop();
  EXPECT_EQ(r.ended, ViewerEnd::kClosed) << r.error;
  ASSERT_TRUE(window_link);
  const voice::VoiceStats sent = window_link->stats();
  EXPECT_TRUE(window_link->muted()) << "M muted the microphone";
  std::printf("window's microphone: %llu frames captured, %llu sent, %llu silent (DTX)\n",
              static_cast<unsigned long long>(sent.frames_captured),
              static_cast<unsigned long long>(sent.packets_sent),
              static_cast<unsigned long long>(sent.dtx_frames));
  EXPECT_GT(sent.packets_sent, 5u) << "V held: it talked";
  EXPECT_LT(sent.packets_sent + sent.dtx_frames, sent.frames_captured)
      << "before V and after it, the microphone was not sent";
  EXPECT_TRUE(watch.heard) << "the observer heard the window";
  EXPECT_TRUE(watch.saw_muted) << "then saw it muted";
  // The window heard the observer at --volume's gain; a slider's gain replaces it.
  const auto observer_voice_heard = [&]() -> std::optional<voice::HeardVoice> {
    for (const voice::HeardVoice& h : window_link->stats().heard)
      if (h.name == "Observer") return h;
    return std::nullopt;
  };
  const auto before = observer_voice_heard();
  ASSERT_TRUE(before) << "the window heard the observer";
  EXPECT_GT(before->stream.packets, 0u);
  EXPECT_FLOAT_EQ(before->volume, 0.5f);
  voice::VoiceInput slider;
  slider.volumes = {{before->id, 2.0f}};
  apply_voice_input(*window_link, slider);
  EXPECT_FLOAT_EQ(observer_voice_heard()->volume, 2.0f);
  EXPECT_TRUE(slider.volumes.empty()) << "applied";
  observer_link.stop();
  observer.end();
  ASSERT_TRUE(fs::exists(desktop.screenshot));
  const ColorImage shot = read_color_png(desktop.screenshot);
  EXPECT_EQ(shot.width, 800);
}

// --- OpenXR --------------------------------------------------------------------------------------

TEST(Xr, AMissingRuntimeIsReportedCleanly) {
  const test::ScopedEnv runtime("XR_RUNTIME_JSON", "/nonexistent/openxr_runtime.json");
  // The loader was quieted before main() (xr_common.cpp), so asking for a runtime never changes
  // the environment: setenv there raced another thread's getenv (a JPEG encode) and crashed it.
  ASSERT_NE(std::getenv("XR_LOADER_DEBUG"), nullptr);
  char** const environment = environ;
  std::string why;
  bool available = true;
  EXPECT_NO_THROW(available = xr_available(&why));
  EXPECT_EQ(environ, environment);
  EXPECT_FALSE(available);
  EXPECT_NE(why.find("no runtime available (XR_ERROR_"), std::string::npos) << why;
  EXPECT_EQ(why.find('\n'), std::string::npos) << why;  // one line
}

XrPosef head_eye(float x_m, float yaw_deg) {  // an eye x_m right of a head 1.6 m above the floor
  const Eigen::Quaternionf q(
      Eigen::AngleAxisf(yaw_deg * static_cast<float>(kToRadians), Eigen::Vector3f::UnitY()));
  const Eigen::Vector3f p = Eigen::Vector3f(0, 1.6f, 0) + q * Eigen::Vector3f(x_m, 0, 0);
  XrPosef pose{};
  pose.orientation = {q.x(), q.y(), q.z(), q.w()};
  pose.position = {p.x(), p.y(), p.z()};
  return pose;
}

// A headset's asymmetric fields of view: each eye sees further outward than inward.
constexpr XrFovf kLeftFov{-0.95f, 0.80f, 0.85f, -0.90f}, kRightFov{-0.80f, 0.95f, 0.85f, -0.90f};

TEST(XrView, APoseIsTheRigidTransformItDescribes) {
  const XrPosef pose = head_eye(0, 90);
  const RigidTransform t = rigid_from_xr(pose);
  // 90 degrees about +y takes the view's forward (-z) to -x.
  EXPECT_LT((t.rotation * Eigen::Vector3d(0, 0, -1) - Eigen::Vector3d(-1, 0, 0)).norm(), 1e-6);
  EXPECT_LT((t.translation - Eigen::Vector3d(0, 1.6, 0)).norm(), 1e-6);
}

TEST(XrView, TheStageStartsWhereTheStartingViewIs) {
  ViewCamera start;  // camera 0's viewpoint: y down, looking down +z
  start.eye = {0.5f, -0.2f, 0.1f};
  start.target = {0.5f, -0.2f, 2};
  const RigidTransform world_from_stage_ = world_from_stage(start, 1.6f);
  const View v = xr_eye_view(world_from_stage_, head_eye(0, 0), kLeftFov, 0.05f, 100);
  EXPECT_LT((v.world_from_view.translation - start.eye.cast<double>()).norm(), 1e-6);
  // The view's forward (-z) is the line of sight, its up (+y) is start.up.
  EXPECT_LT(
      (v.world_from_view.rotation * Eigen::Vector3d(0, 0, -1) - Eigen::Vector3d::UnitZ()).norm(),
      1e-6);
  EXPECT_LT(
      (v.world_from_view.rotation * Eigen::Vector3d::UnitY() + Eigen::Vector3d::UnitY()).norm(),
      1e-6);
  // The field of view's edges: a point along the left edge's direction lands on x_ndc = -1.
  const Eigen::Vector4f p =
      v.clip_from_view * Eigen::Vector4f(std::tan(kLeftFov.angleLeft), 0, -1, 1);
  EXPECT_NEAR(p.x() / p.w(), -1, 1e-5);
}

TEST(XrView, EyesSixtyFourMillimetresApartGiveTwoDifferentViews) {
  const RigidTransform world_from_stage_ = world_from_stage(level_camera(), 1.6f);
  const View left = xr_eye_view(world_from_stage_, head_eye(-0.032f, 15), kLeftFov, 0.05f, 100);
  const View right = xr_eye_view(world_from_stage_, head_eye(0.032f, 15), kRightFov, 0.05f, 100);
  EXPECT_NEAR((left.world_from_view.translation - right.world_from_view.translation).norm(), 0.064,
              1e-6);
  EXPECT_LT((left.world_from_view.rotation - right.world_from_view.rotation).norm(), 1e-9);
  EXPECT_GT((left.clip_from_view - right.clip_from_view).norm(), 0.01);  // mirrored asymmetry
}

// Mean absolute colour difference between `a` at x + shift and `b` at x, over the middle of the
// images: smallest at the shift by which `a` shows the scene further right than `b`.
double shifted_difference(const ColorImage& a, const ColorImage& b, int shift) {
  double sum = 0;
  size_t n = 0;
  for (int y = 0; y < a.height; ++y)
    for (int x = 40; x < a.width - 40; ++x) {
      const uint8_t *p = a.pixel(x + shift, y), *q = b.pixel(x, y);
      sum += std::abs(p[0] - q[0]) + std::abs(p[1] - q[1]) + std::abs(p[2] - q[2]);
      ++n;
    }
  return sum / static_cast<double>(n);
}

ColorImage crop(const ColorImage& image, int x0, int width) {
  ColorImage out(width, image.height);
  for (int y = 0; y < image.height; ++y)
    std::copy_n(image.pixel(x0, y), width * 4, out.pixel(0, y));
  return out;
}

TEST(XrStereo, TheStereoPathRendersTwoDifferentEyeImagesWithTheRightParallax) {
  // The real Azure Kinect frame, seen by a scripted head standing where the camera stood, through
  // the same per-eye Views the OpenXR presenter makes, into the two halves of one offscreen target
  // (as a side-by-side swapchain would be).
  auto src = open_source(test::kinect_mkv());
  const CameraFrame frame = src->next();
  const CameraCalibration cal = src->calibration();
  ViewCamera start;  // the camera's own viewpoint
  start.target = {0, 0, 1.5f};
  const RigidTransform world_from_stage_ = world_from_stage(start, 1.6f);
  constexpr int kEye = 320, kHeight = 320;
  HeadlessTarget target(2 * kEye, kHeight);
  CameraRenderer renderer;
  renderer.set_cameras(std::span(&cal, 1));
  renderer.upload(0, frame);
  // Symmetric fields of view here, so that the images differ by parallax alone.
  const XrFovf fov{-0.875f, 0.875f, 0.85f, -0.85f};
  for (int eye = 0; eye < 2; ++eye) {
    const View view =
        xr_eye_view(world_from_stage_, head_eye(eye == 0 ? -0.032f : 0.032f, 3), fov, 0.05f, 100);
    renderer.draw_cameras(view,
                          RenderTarget{target.target().framebuffer, eye * kEye, 0, kEye, kHeight});
  }
  ColorImage both;
  target.read_image(both);
  const ColorImage left = crop(both, 0, kEye), right = crop(both, kEye, kEye);
  const auto content = [](const ColorImage& image) {
    size_t n = 0;
    const uint8_t* corner = image.pixel(0, image.height - 1);
    for (size_t i = 0; i < image.bgra.size(); i += 4)
      n += std::abs(image.bgra[i] - corner[0]) + std::abs(image.bgra[i + 1] - corner[1]) +
               std::abs(image.bgra[i + 2] - corner[2]) >
           30;
    return static_cast<double>(n) / static_cast<double>(image.bgra.size() / 4);
  };
  EXPECT_GT(content(left), 0.2);
  EXPECT_GT(content(right), 0.2);
  const double unshifted = shifted_difference(left, right, 0);
  EXPECT_GT(unshifted, 2.0);  // two different images
  // Parallax: the left eye sees the scene shifted right against the right eye's image; the shift
  // that best aligns them is positive.
  int best = 0;
  for (int shift = -20; shift <= 20; ++shift)
    if (shifted_difference(left, right, shift) < shifted_difference(left, right, best))
      best = shift;
  std::printf("stereo eyes: mean difference %.1f unshifted, best alignment at %d px\n", unshifted,
              best);
  EXPECT_GT(best, 0);
}

}  // namespace
}  // namespace volcast
