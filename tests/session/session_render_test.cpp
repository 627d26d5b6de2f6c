// What a participant sees: the OR site's cameras and a remote camera avatar in one picture from
// its eye, the head-radius and own-headset filters, and the whole thing through the CLI
// (volcast serve + two volcast view --join processes).
#include <gtest/gtest.h>

#include <chrono>
#include <fstream>
#include <thread>

#include "support/session_site.hpp"
#include "support/test_paths.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/session_client.hpp"
#include "volcast/pipeline/session_scene.hpp"
#include "volcast/reconstruct/point_cloud.hpp"
#include "volcast/render/case_renderer.hpp"
#include "volcast/render/headless_target.hpp"
#include "volcast/render/primitive_renderer.hpp"
#include "volcast/render/room_scene.hpp"
#include "volcast/session/hub.hpp"

namespace volcast {
namespace {

using namespace std::chrono_literals;

bool eventually(const std::function<bool()>& done) {
  return test::eventually(done, 30s);
}

// Pixels that are not the clear colour (the room is not drawn in these renders).
// Which pixels differ from the background colour at all (a dim point may be close to it): one
// flag per pixel.
std::vector<bool> covered_mask(const ColorImage& image) {
  std::vector<bool> mask(image.bgra.size() / 4);
  for (size_t i = 0; i < mask.size(); ++i)
    mask[i] = std::abs(image.bgra[4 * i] - 28) + std::abs(image.bgra[4 * i + 1] - 23) +
                  std::abs(image.bgra[4 * i + 2] - 20) >
              0;
  return mask;
}

size_t count(const std::vector<bool>& mask) {
  return std::count(mask.begin(), mask.end(), true);
}

TEST(SessionFilters, HeadRadiusAndOwnHeadset) {
  RemoteParticipant other;
  EXPECT_FALSE(remote_avatar_filter(other, 0.6f).keep) << "no pose yet: nothing to centre on";
  other.has_pose = true;
  other.pose.head.position = {1, 1.6f, 0};
  const AvatarFilter f = remote_avatar_filter(other, 0.6f);
  EXPECT_TRUE(avatar_filter_keeps(f, {1, 1.2f, -0.3f}));   // its hands
  EXPECT_FALSE(avatar_filter_keeps(f, {1, 1.6f, -1.0f}));  // the room behind its camera's view
  SessionSnapshot self;
  self.has_own_body = true;
  self.own_body.head.position = {0, 1.6f, 0};
  const AvatarFilter own = own_camera_filter(self, 0.6f);
  EXPECT_FALSE(avatar_filter_keeps(own, {0, 1.6f, -0.08f}));    // the headset, before the eyes
  EXPECT_TRUE(avatar_filter_keeps(own, {0.1f, 1.2f, -0.35f}));  // own hands
  EXPECT_FALSE(avatar_filter_keeps(own, {0, 1.0f, -1.5f}));     // the room behind
}

// The room's shapes composite with the clouds by depth. Synthetic (exact behaviour): a flat wall
// of points 1 m ahead of a pinhole camera at the origin, a box before or behind it.
TEST(PrimitiveRenderer, ShapesAndCloudsOccludeEachOtherByDepth) {
  HeadlessTarget target(160, 120);
  CameraRenderer cameras;
  PrimitiveRenderer shapes;
  CameraCalibration cal;
  cal.depth = Intrinsics{64, 48, 60, 60, 31.5, 23.5};
  cameras.set_cameras(std::span(&cal, 1));
  CameraFrame wall;
  wall.depth = DepthImage(64, 48);
  std::fill(wall.depth.pixels.begin(), wall.depth.pixels.end(), uint16_t{1000});
  wall.color = ColorImage(64, 48);
  for (size_t i = 0; i < wall.color.bgra.size(); i += 4) {
    wall.color.bgra[i + 2] = 255;  // red points
    wall.color.bgra[i + 3] = 255;
  }
  cameras.upload(0, wall);
  View view;
  view.world_from_view = look_at({0, 0, 0}, {0, 0, 1}, {0, -1, 0});
  view.clip_from_view = perspective(60, target.target().aspect(), 0.05f, 10);
  ColorImage image;
  const auto centre = [&](float box_z) {
    CameraPassOptions pass;
    pass.blend = false;
    cameras.draw_cameras(view, target.target(), pass);
    const Primitive blue = box({0, 0, box_z}, {0.2f, 0.2f, 0.05f}, {0, 0, 1, 1}, 0, 1);
    shapes.draw(view, target.target(), std::span(&blue, 1));
    target.read_image(image);
    return image.pixel(80, 60);
  };
  const uint8_t* in_front = centre(0.6f);
  EXPECT_GT(in_front[0], 200);  // blue box (BGRA)
  EXPECT_LT(in_front[2], 60);
  const uint8_t* behind = centre(1.5f);
  EXPECT_GT(behind[2], 200);  // the red points hide it
  EXPECT_LT(behind[0], 60);
  // Outside the box the wall shows either way; a faded effect is empty once it is over.
  EXPECT_GT(image.pixel(40, 40)[2], 200);
  EXPECT_TRUE(teleport_effect_primitives({0, 0, 0}, 1.0f, 0.8f, {1, 1, 1}).empty());
  EXPECT_FALSE(teleport_effect_primitives({0, 0, 0}, 0.2f, 0.8f, {1, 1, 1}).empty());
  BodyPose body;
  const size_t without_hands = mesh_avatar_primitives(body, {1, 0, 0}).size();
  body.hands_tracked = true;
  EXPECT_EQ(mesh_avatar_primitives(body, {1, 0, 0}).size(), without_hands + 2);
  // The voice badge over a head: nothing when silent, a green ball while speaking, a red ball
  // while muted (muted wins), 0.3 m above the head.
  const Eigen::Vector3f head(1, 1.6f, 2);
  EXPECT_TRUE(voice_badge_primitives(head, false, false, 0).empty());
  const auto speaking = voice_badge_primitives(head, true, false, 0.5f);
  ASSERT_EQ(speaking.size(), 1u);
  EXPECT_EQ(speaking[0].shape, Primitive::Shape::kSphere);
  EXPECT_GT(speaking[0].color.y(), speaking[0].color.x());
  EXPECT_NEAR(speaking[0].world_from_shape(1, 3), 1.9f, 1e-6f);
  const auto muted = voice_badge_primitives(head, true, true, 0.5f);
  ASSERT_EQ(muted.size(), 1u);
  EXPECT_EQ(muted[0].shape, Primitive::Shape::kSphere);
  EXPECT_GT(muted[0].color.x(), muted[0].color.y());
  // The headset's own mute: a small red ball 8 cm over the left hand.
  const auto own = muted_hand_primitives({-0.2f, 1.1f, 0.3f});
  ASSERT_EQ(own.size(), 1u);
  EXPECT_GT(own[0].color.x(), own[0].color.y());
  EXPECT_NEAR(own[0].world_from_shape(1, 3), 1.18f, 1e-6f);
  EXPECT_NEAR(own[0].world_from_shape(0, 0), 0.04f, 1e-6f);
  // While recorded, the headset's red ball fixed in its view: 0.6 m ahead, 16 cm left, 12 cm up
  // of the head, wherever the head turns (here: a quarter turn to the left, about +y).
  RigidTransform world_from_head;
  world_from_head.translation = {1, 1.6, 2};
  const auto rec = recording_badge_primitives(world_from_head);
  ASSERT_EQ(rec.size(), 1u);
  EXPECT_EQ(rec[0].shape, Primitive::Shape::kSphere);
  EXPECT_GT(rec[0].color.x(), 0.9f);
  EXPECT_LT(rec[0].color.y(), 0.2f);
  EXPECT_EQ(rec[0].emissive, 1) << "it glows: seen in a dark room as in a lit one";
  EXPECT_NEAR(rec[0].world_from_shape(0, 0), 0.03f, 1e-6f);
  const Eigen::Vector3f ahead(0.84f, 1.72f, 1.4f), turned(0.4f, 1.72f, 2.16f);
  const Eigen::Vector3f at = rec[0].world_from_shape.block<3, 1>(0, 3);
  EXPECT_TRUE(at.isApprox(ahead)) << at.transpose();
  world_from_head.rotation =
      Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()).toRotationMatrix();
  const Eigen::Vector3f after =
      recording_badge_primitives(world_from_head)[0].world_from_shape.block<3, 1>(0, 3);
  EXPECT_TRUE(after.isApprox(turned)) << "ahead is -x once turned left: " << after.transpose();
  // A volume the headset just set: the 40 cm track 0.45 m over the voice, yellow filled to gain
  // / 4 from its bottom, the white mark at 1 (a quarter up); silence leaves the track and mark.
  const auto bar = volume_bar_primitives(head, 2.0f);
  ASSERT_EQ(bar.size(), 3u);
  EXPECT_NEAR(bar[0].world_from_shape(1, 1), 0.4f, 1e-6f);
  EXPECT_NEAR(bar[0].world_from_shape(1, 3), 1.6f + 0.45f + 0.2f, 1e-6f);
  EXPECT_GT(bar[1].color.x(), 0.9f);
  EXPECT_LT(bar[1].color.z(), 0.2f);
  EXPECT_NEAR(bar[1].world_from_shape(1, 1), 0.2f, 1e-6f) << "half of the track at 200 %";
  EXPECT_NEAR(bar[1].world_from_shape(1, 3), 1.6f + 0.45f + 0.1f, 1e-6f);
  EXPECT_NEAR(bar[2].world_from_shape(1, 3), 1.6f + 0.45f + 0.1f, 1e-6f) << "the mark at 100 %";
  EXPECT_EQ(volume_bar_primitives(head, 0).size(), 2u);
  EXPECT_NEAR(volume_bar_primitives(head, 9)[1].world_from_shape(1, 1), 0.4f, 1e-6f);
}

// The case's organs and the monitor. Synthetic (exact behaviour): a quad-shaped "organ" 1 m ahead,
// opaque red or a half-transparent green shell in front of it; the monitor quad showing a
// 2 x 1 slice with a known window.
TEST(CaseRenderer, OpaqueOccludesTransparentBlendsMonitorShowsTheWindow) {
  HeadlessTarget target(160, 120);
  CaseRenderer renderer;
  View view;
  view.world_from_view = look_at({0, 0, 0}, {0, 0, -1}, {0, 1, 0});
  view.clip_from_view = perspective(60, target.target().aspect(), 0.05f, 10);
  SharedCase c;
  c.generation = 1;
  const auto square = [](const char* name, Eigen::Vector4f rgba, float z) {
    SharedPart p;  // two triangles facing +z (the eye), 0.6 m wide, at depth z
    p.name = name;
    p.rgba = rgba;
    p.positions = {{-0.3f, -0.3f, z}, {0.3f, -0.3f, z}, {0.3f, 0.3f, z}, {-0.3f, 0.3f, z}};
    p.normals.assign(4, Eigen::Vector3f::UnitZ());
    p.indices = {0, 1, 2, 0, 2, 3};
    return p;
  };
  SharedObject o;
  o.name = "organ";
  o.parts = {square("inside", {1, 0, 0, 1}, 0), square("shell", {0, 1, 0, 0.5f}, 0.2f)};
  c.objects = {o};
  std::vector<PlacedObject> placed{{}};
  placed[0].pose.position = {0, 0, -1};
  Lighting light;
  light.to_key_light = {0, 0, 1};
  light.point_light = false;
  ColorImage image;
  renderer.clear(target.target());
  renderer.draw(view, target.target(), c, placed, light);
  target.read_image(image);
  const uint8_t* mid = image.pixel(80, 60);
  // BGRA: red seen through a half-transparent green: both channels, neither full.
  EXPECT_GT(mid[2], 60);
  EXPECT_GT(mid[1], 60);
  EXPECT_LT(mid[2], 230);
  const uint8_t* outside = image.pixel(5, 5);
  EXPECT_LT(outside[1] + outside[2], 80) << "the background stays";
  // The shell alone, opaque: it hides the inside.
  c.objects[0].parts[1].rgba.w() = 1;
  c.generation = 2;  // uploaded again
  renderer.clear(target.target());
  renderer.draw(view, target.target(), c, placed, light);
  target.read_image(image);
  EXPECT_LT(image.pixel(80, 60)[2], 40);
  EXPECT_GT(image.pixel(80, 60)[1], 100);
  // The monitor: a 2 x 1 slice, HU 90 (the liver window's centre: mid grey) and 1000 (white).
  MonitorSeries series;
  series.width = 2, series.height = 1, series.slices = 1;
  series.hu = {90, 1000};
  MonitorState state{2, 0, 90, 150, false, 0};
  Eigen::Matrix4f quad = Eigen::Matrix4f::Identity();
  quad.diagonal() << 1.0f, 1.0f, 1, 1;
  quad(2, 3) = -1;
  renderer.clear(target.target());
  renderer.draw_monitor(view, target.target(), series, state, quad);
  target.read_image(image);
  // The quad is 104 px wide from x = 28: the texel centres (linear filtering) at x = 54 and 106.
  const int left = image.pixel(54, 60)[1], right = image.pixel(106, 60)[1];
  EXPECT_NEAR(left, window_gray(90, 90, 150), 3);
  EXPECT_EQ(right, 255);
  state.center = 1000, state.width = 10;  // another window: the left pixel goes black
  renderer.draw_monitor(view, target.target(), series, state, quad);
  target.read_image(image);
  EXPECT_LT(image.pixel(54, 60)[1], 4);
}

// The OR site (the real hands sequence, lifted into the room) and a remote participant's camera
// avatar (the hands sequence again) in one picture from a participant's eye; the avatar keeps
// only the points near its sender's head.
TEST(SessionScene, SiteAndRemoteAvatarFromTheEye) {
  SessionHubConfig config;
  config.site_translation = {0, 1.5f, 0.5f};  // the site camera's points float above the floor
  // The surgeon is frozen below while the renders run (seconds under a sanitizer on a loaded
  // machine): it must not time out meanwhile.
  config.presence_timeout_ms = 120000;
  test::SessionSite s(config, 10);
  SessionClientOptions with_camera = test::named("Surgeon");
  with_camera.camera_source = test::hands_dir();
  with_camera.camera_options.intrinsics = Intrinsics{0, 0, 460, 460, 320, 180};
  auto a = std::make_unique<test::TestParticipant>(s, with_camera);
  auto b = std::make_unique<test::TestParticipant>(s, test::named("Viewer"));
  ASSERT_TRUE(eventually([&] {
    for (const auto& o : b->p().snapshot(wall_clock_us()).others)
      if (o.name == "Surgeon" && o.has_pose && o.avatar_sequence > 0) return true;
    return false;
  }));
  // Freeze the surgeon (its last pose and frame stay with the viewer): the renders compare.
  a->session->stop();
  std::this_thread::sleep_for(200ms);
  // The site's frame, as a receiver of the stream has it.
  const std::vector<CameraCalibration> site_cameras = {s.site.player.cameras()[0].calibration};
  CameraFrame site_frame;
  test::HandsSite::sources()[0]->next(site_frame);
  const std::vector<std::shared_ptr<const CameraFrame>> frames = {
      std::make_shared<const CameraFrame>(site_frame)};

  HeadlessTarget target(640, 360);
  SessionScene scene;
  SessionSceneOptions o;
  o.room = false;  // only points: every non-background pixel is a point
  ColorImage image;
  // One eye and one moment for every render: the viewer's own idle sway moves its head.
  const int64_t now = wall_clock_us();
  const View eye = participant_eye(b->p().snapshot(now), target.target().aspect());
  const auto render = [&](float radius, bool site_on) {
    o.keep_radius_m = radius;
    scene.draw(eye, target.target(),
               site_on ? std::span(site_cameras) : std::span<const CameraCalibration>(),
               site_on ? std::span(frames) : std::span<const std::shared_ptr<const CameraFrame>>(),
               b->p(), now, o);
    target.read_image(image);
    return covered_mask(image);
  };
  const std::vector<bool> site_mask = render(0.001f, true);  // the avatar filtered away entirely
  const std::vector<bool> both_mask = render(0.6f, true);
  EXPECT_EQ(scene.cameras_drawn(), 2u);  // the site's camera and the surgeon's
  write_color_png(test::temp_dir("session_scene") / "eye.png", image);
  const std::vector<bool> avatar_mask = render(0.6f, false);
  EXPECT_EQ(scene.cameras_drawn(), 1u);
  const size_t site_only = count(site_mask), avatar_only = count(avatar_mask);
  const size_t avatar_small = count(render(0.15f, false));
  const size_t nothing = count(render(0.001f, false));
  EXPECT_GT(site_only, 500u) << "the site's points are in view";
  EXPECT_GT(avatar_only, 500u) << "the surgeon's avatar is in view";
  // Coverage of the picture with both is the union of the two alone (either may hide the other,
  // which leaves a pixel covered); how much the avatar adds depends on which hands frame the
  // surgeon sent last, so the check is on the pixels, not on a share of the avatar.
  size_t in_union = 0, union_covered = 0, avatar_adds = 0;
  for (size_t i = 0; i < both_mask.size(); ++i) {
    if (!site_mask[i] && !avatar_mask[i]) continue;
    ++in_union;
    union_covered += both_mask[i];
    avatar_adds += !site_mask[i] && both_mask[i];
  }
  EXPECT_GT(union_covered, in_union * 95 / 100) << "both show in one picture";
  EXPECT_GT(avatar_adds, 50u) << "the avatar covers pixels the site does not";
  EXPECT_LT(avatar_small, avatar_only) << "a smaller head radius drops points";
  EXPECT_LT(nothing, 20u) << "a ~zero radius drops every point";
  b.reset();
  a.reset();
}

// Pointing (issue 36): A points at a spot of the live cloud; in B's render the pointer's dot
// lands within 3 px of where that 3D point projects in B's eye; A puts it away and it is gone.
TEST(SessionScene, APointersDotShowsWhereItPointsOnTheLiveCloudForOthersWhileHeld) {
  SessionHubConfig config;
  config.site_translation = {0, 1.5f, 0.5f};
  config.presence_timeout_ms = 120000;
  test::SessionSite s(config, 10);
  auto a = std::make_unique<test::TestParticipant>(s, test::hand_driven("Mentor"));
  auto b = std::make_unique<test::TestParticipant>(s, test::hand_driven("Viewer"));
  ASSERT_TRUE(eventually([&] { return b->other("Mentor").has_value() && a->now().joined; }));
  const CameraCalibration site_camera = s.site.player.cameras()[0].calibration;
  CameraFrame site_frame;
  test::HandsSite::sources()[0]->next(site_frame);
  const std::vector<CameraCalibration> site_cameras = {site_camera};
  const std::vector<std::shared_ptr<const CameraFrame>> frames = {
      std::make_shared<const CameraFrame>(site_frame)};
  HeadlessTarget target(640, 360);
  SessionScene scene;
  SessionSceneOptions o;
  o.room = false;
  const int64_t now = wall_clock_us();
  const SessionSnapshot seen = b->p().snapshot(now);
  // B looks at the live cloud from 20 cm beside the site camera, at the cloud's middle.
  const RigidTransform room_from_camera = seen.room_from_site * site_camera.world_from_camera;
  const DepthImage& d = site_frame.depth;
  std::vector<Eigen::Vector3f> cloud;
  for (int v = 0; v < d.height; v += 2)
    for (int u = 0; u < d.width; u += 2)
      if (const uint16_t mm = d.at(u, v); mm != 0)
        if (const auto xy = unproject_pixel(site_camera.depth, {double(u), double(v)}))
          cloud.push_back((room_from_camera * Eigen::Vector3d(xy->x() * mm / 1000.0,
                                                              xy->y() * mm / 1000.0, mm / 1000.0))
                              .cast<float>());
  ASSERT_GT(cloud.size(), 1000u);
  Eigen::Vector3f middle = Eigen::Vector3f::Zero();
  for (const Eigen::Vector3f& p : cloud) middle += p / float(cloud.size());
  const Eigen::Vector3d camera_at = room_from_camera.translation;
  View eye;
  eye.world_from_view = look_at(camera_at + room_from_camera.rotation * Eigen::Vector3d(0.2, 0, 0),
                                middle.cast<double>(), {0, 1, 0});
  eye.clip_from_view = perspective(60, target.target().aspect(), 0.05f, 50);
  const Eigen::Matrix4f clip_from_world = eye.clip_from_world();
  const auto window = [&](const Eigen::Vector3f& p) {  // window coordinates, row 0 at the top
    const Eigen::Vector4f c = clip_from_world * p.homogeneous();
    return Eigen::Vector2f((c.x() / c.w() + 1) / 2 * 640, (1 - c.y() / c.w()) / 2 * 360);
  };
  // The spot: the cloud's point nearest B's eye among those well inside its view (nothing of the
  // cloud stands in front of it).
  const Eigen::Vector3f eye_at = eye.world_from_view.translation.cast<float>();
  Eigen::Vector3f spot = Eigen::Vector3f::Zero();
  float nearest = 1e9f;
  for (const Eigen::Vector3f& p : cloud) {
    const Eigen::Vector2f w = window(p);
    if (w.x() < 60 || w.x() > 580 || w.y() < 60 || w.y() > 300) continue;
    if ((p - eye_at).norm() < nearest) nearest = (p - eye_at).norm(), spot = p;
  }
  ASSERT_LT(nearest, 10.0f) << "the site's cloud is in B's view";
  ColorImage before, held, after;
  const auto render = [&](ColorImage& image) {
    scene.draw(eye, target.target(), site_cameras, frames, b->p(), now, o);
    target.read_image(image);
  };
  render(before);
  // A's hand is 50 cm above the spot and 30 cm towards B: it points down at it.
  const Eigen::Vector3f origin =
      spot + Eigen::Vector3f(0, 0.5f, 0) + (eye_at - spot).normalized() * 0.3f;
  a->p().point(true, origin, true, spot);
  ASSERT_TRUE(eventually([&] { return b->p().snapshot(wall_clock_us()).pointers.size() == 1; }));
  const PointerView shown = b->p().snapshot(wall_clock_us()).pointers[0];
  EXPECT_EQ(shown.participant, a->now().id);
  EXPECT_EQ(shown.hit, spot);  // exactly: f32 on the wire
  render(held);
  const std::filesystem::path pictures = test::temp_dir("session_pointer");
  write_color_png(pictures / "pointer.png", held);
  // The dot: what changes when the same pointer misses (its beam goes on, it has no dot).
  a->p().point(true, origin, false, spot);
  ASSERT_TRUE(eventually([&] {
    const auto p = b->p().snapshot(wall_clock_us()).pointers;
    return p.size() == 1 && !p[0].has_hit;
  }));
  ColorImage missed;
  render(missed);
  write_color_png(pictures / "missed.png", missed);
  const auto changed = [&](const ColorImage& x, const ColorImage& y, int u, int v) {
    const size_t i = 4 * (size_t(v) * 640 + size_t(u));
    return std::abs(x.bgra[i] - y.bgra[i]) + std::abs(x.bgra[i + 1] - y.bgra[i + 1]) +
               std::abs(x.bgra[i + 2] - y.bgra[i + 2]) >
           30;
  };
  // Its largest connected part (the missed beam also shows a little beyond the hit, through gaps
  // between the table's splats).
  std::vector<int> part(640 * 360, -1);
  std::vector<int> sizes;
  int beam = 0;
  for (int v = 0; v < 360; ++v)
    for (int u = 0; u < 640; ++u) {
      beam += changed(held, before, u, v);
      if (part[v * 640 + u] >= 0 || !changed(held, missed, u, v)) continue;
      const int id = int(sizes.size());
      sizes.push_back(0);
      std::vector<std::pair<int, int>> frontier{{u, v}};
      part[v * 640 + u] = id;
      while (!frontier.empty()) {
        const auto [x, y] = frontier.back();
        frontier.pop_back();
        ++sizes[id];
        for (const auto& [dx, dy] : {std::pair{1, 0}, {-1, 0}, {0, 1}, {0, -1}}) {
          const int nx = x + dx, ny = y + dy;
          if (nx < 0 || ny < 0 || nx >= 640 || ny >= 360 || part[ny * 640 + nx] >= 0 ||
              !changed(held, missed, nx, ny))
            continue;
          part[ny * 640 + nx] = id;
          frontier.push_back({nx, ny});
        }
      }
    }
  ASSERT_FALSE(sizes.empty()) << "the dot shows (" << beam << " pixels changed)";
  const int largest = int(std::max_element(sizes.begin(), sizes.end()) - sizes.begin());
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  int dot = 0;
  for (int v = 0; v < 360; ++v)
    for (int u = 0; u < 640; ++u)
      if (part[v * 640 + u] == largest) sum += Eigen::Vector2d(u + 0.5, v + 0.5), ++dot;
  ASSERT_GT(dot, 20) << "the dot shows (" << beam << " pixels changed)";
  const Eigen::Vector2d centre = sum / dot;
  const Eigen::Vector2f expected = window(spot);
  std::printf("the dot (%d px) is %.2f px from where the spot projects\n", dot,
              (centre - expected.cast<double>()).norm());
  EXPECT_LT((centre - expected.cast<double>()).norm(), 3.0)
      << "dot at " << centre.transpose() << ", the spot projects to " << expected.transpose();
  // Put away: gone for B.
  a->p().point(false, origin, true, spot);
  ASSERT_TRUE(eventually([&] { return b->p().snapshot(wall_clock_us()).pointers.empty(); }));
  render(after);
  int left = 0;
  for (int v = 0; v < 360; ++v)
    for (int u = 0; u < 640; ++u) left += changed(after, before, u, v);
  EXPECT_EQ(left, 0);
  b.reset();
  a.reset();
}

// The CLI: a server, a participant with a camera avatar, and a headless participant who writes
// the screenshot from its eye and the session figures.
TEST(SessionCli, ServeAndTwoParticipants) {
  const auto dir = test::temp_dir("session_cli");
  const std::string token = "00112233445566778899aabbccddeeff";
  { std::ofstream(dir / "token") << token << "\n"; }
  const std::string serve = std::string(test::paths::volcast()) + " serve --source " +
                            test::hands_dir().string() +
                            " --intrinsics 460,460,320,180 --port 0 --insecure --fps 10"
                            " --seconds 25 --token-file " +
                            (dir / "token").string() + " --room-from-site 0,1.5,0.5,0";
  // The server picks a free port and prints it in the join link.
  const std::string script = dir.string() + "/run.sh";
  {
    std::ofstream s(script);
    s << "set -u\n"
      << serve << " > " << dir.string() << "/serve.log 2>&1 &\n"
      << "for i in $(seq 100); do link=$(grep -o 'volcast://[^ ]*' " << dir.string()
      << "/serve.log | head -1); [ -n \"$link\" ] && break; sleep 0.1; done\n"
      << "[ -n \"$link\" ] || { cat " << dir.string() << "/serve.log; exit 9; }\n"
      << test::paths::volcast() << " view --connect \"$link\" --no-render --join OR --name Surgeon"
      << " --camera " << test::hands_dir().string() << " --camera-intrinsics 460,460,320,180"
      << " --seconds 8 --depth-codec rvl > " << dir.string() << "/a.log 2>&1 &\n"
      << "sleep 1\n"
      << test::paths::volcast() << " view --connect \"$link\" --headless --join OR --name Viewer"
      << " --seconds 6 --size 320x180 --screenshot " << dir.string() << "/eye.png --stats-json "
      << dir.string() << "/b.json > " << dir.string() << "/b.log 2>&1; b=$?\n"
      << "wait %2; a=$?\n"
      << "kill %1; wait %1\n"
      << "echo \"a=$a b=$b\"; [ $a -eq 0 ] && [ $b -eq 0 ]\n";
  }
  std::string output;
  const int code = test::run_command("bash " + script, output);
  std::string logs;
  for (const char* f : {"serve.log", "a.log", "b.log"}) {
    std::ifstream in(dir / f);
    logs += std::string("--- ") + f + "\n" +
            std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  ASSERT_EQ(code, 0) << output << logs;
  std::ifstream json(dir / "b.json");
  const std::string stats((std::istreambuf_iterator<char>(json)), std::istreambuf_iterator<char>());
  const size_t names = stats.find("\"participants\"");
  ASSERT_NE(names, std::string::npos) << stats;
  EXPECT_NE(stats.find("\"Surgeon\"", names), std::string::npos) << stats;
  EXPECT_NE(stats.find("\"session_round_trip_ms_p99\""), std::string::npos);
  EXPECT_NE(stats.find("\"session\": \"OR\""), std::string::npos);
  const ColorImage eye = read_color_png(dir / "eye.png");
  EXPECT_EQ(eye.width, 320);
  size_t lit = 0;  // the room and the points: not the clear colour
  for (size_t i = 0; i < eye.bgra.size(); i += 4) lit += eye.bgra[i + 1] > 40;
  EXPECT_GT(lit, eye.bgra.size() / 4 / 2) << "the eye's picture is mostly empty";
  EXPECT_NE(logs.find("'Surgeon' joined"), std::string::npos) << logs;
  EXPECT_NE(logs.find("avatar frames"), std::string::npos) << logs;
}

}  // namespace
}  // namespace volcast
