// Where a pointer's ray meets the live surfaces: hit_depth / hit_depths marched against depth
// images. The genuine Azure Kinect frame (its own lens model, distortion included) for what real
// data decides; synthetic planes (labelled) for exact behaviour.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cstdio>
#include <functional>

#include "support/test_data.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/reconstruct/ray_hit.hpp"

namespace volcast {
namespace {

// A pose that is not the identity, so world_from_camera is exercised.
RigidTransform posed() {
  RigidTransform t;
  t.rotation = (Eigen::AngleAxisd(-0.5, Eigen::Vector3d::UnitY()) *
                Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitX()))
                   .toRotationMatrix();
  t.translation = {-1.2, 1.8, 0.4};
  return t;
}

Eigen::Vector3f world(const CameraCalibration& c, const Eigen::Vector3d& p_camera) {
  return (c.world_from_camera * p_camera).cast<float>();
}

// The point depth pixel (u, v) (fractional allowed) measured at `mm`, camera frame, metres.
Eigen::Vector3d camera_point(const Intrinsics& k, double u, double v, double mm) {
  const auto xy = unproject_pixel(k, {u, v});
  EXPECT_TRUE(xy.has_value());
  const double z = mm * 0.001;
  return {xy->x() * z, xy->y() * z, z};
}

// --- synthetic (labelled): a 200x150 pinhole camera, planes at known depths --------------------

CameraCalibration synthetic_camera() {
  CameraCalibration c;
  c.depth = {.width = 200, .height = 150, .fx = 150, .fy = 150, .cx = 99.5, .cy = 74.5};
  c.world_from_camera = posed();
  return c;
}

// Depth (mm) per pixel from `at(u, v)`.
DepthImage synthetic_depth(const std::function<uint16_t(int, int)>& at) {
  DepthImage d(200, 150);
  for (int v = 0; v < 150; ++v)
    for (int u = 0; u < 200; ++u) d.at(u, v) = at(u, v);
  return d;
}

TEST(RayHit, MeetsAPlaneWhereTheRayCrossesIt) {
  const CameraCalibration cam = synthetic_camera();
  const DepthImage plane = synthetic_depth([](int, int) { return uint16_t{1200}; });
  const Eigen::Vector3d origin(0.3, -0.2, 0.1), target(-0.1, 0.05, 1.2);  // camera frame
  const Eigen::Vector3f o = world(cam, origin), t = world(cam, target);
  const auto hit = hit_depth(cam, plane, o, t - o, 5);
  ASSERT_TRUE(hit.has_value());
  EXPECT_LT((hit->point_world - t).norm(), 0.001f);
  EXPECT_NEAR(hit->distance_m, (t - o).norm(), 0.001f);
  EXPECT_EQ(hit->pixel_x, 87);  // 150 * -0.1 / 1.2 + 99.5 = 87.0
  EXPECT_EQ(hit->pixel_y, 81);  // 150 * 0.05 / 1.2 + 74.5 = 80.75
  // Beyond max_distance_m: no hit; a coarse step (max_steps) still finds it exactly.
  EXPECT_FALSE(hit_depth(cam, plane, o, t - o, 0.9f * (t - o).norm()).has_value());
  const auto coarse = hit_depth(cam, plane, o, t - o, 5, {.max_steps = 10});
  ASSERT_TRUE(coarse.has_value());
  EXPECT_LT((coarse->point_world - t).norm(), 0.001f);
}

TEST(RayHit, InvalidDepthNeverHitsAndSurfacesAreNotHitFromBehind) {
  const CameraCalibration cam = synthetic_camera();
  // The plane at 1.2 m with a hole (0 = invalid) on pixels 80..119 x 60..89.
  const DepthImage holed = synthetic_depth(
      [](int u, int v) { return uint16_t(u >= 80 && u < 120 && v >= 60 && v < 90 ? 0 : 1200); });
  const Eigen::Vector3f o = world(cam, {0.3, -0.2, 0.1});
  const Eigen::Vector3f in_hole = world(cam, {0, 0, 1.2});  // pixel (99.5, 74.5)
  EXPECT_FALSE(hit_depth(cam, holed, o, in_hole - o, 5).has_value());
  // From behind the plane, away from the camera or towards it: no hit.
  const Eigen::Vector3f behind = world(cam, {0.2, 0.2, 1.5});
  EXPECT_FALSE(hit_depth(cam, holed, behind, world(cam, {0.2, 0.2, 2.5}) - behind, 5));
  EXPECT_FALSE(hit_depth(cam, holed, behind, world(cam, {0.1, 0.1, 0.5}) - behind, 5));
}

TEST(RayHit, ARayPassingBehindANarrowForegroundHitsTheBackgroundBeyondIt) {
  // A 10 cm wide vertical bar at 0.8 m (|x| <= 0.05 m there) before a wall at 1.5 m. The ray
  // passes the bar's edge 5.8 cm beside it at 0.8 m, then behind it (its image crosses the bar's
  // while it is 9 to 30 cm deeper), and comes out over the wall, which it meets at (-0.3, 0, 1.5).
  const CameraCalibration cam = synthetic_camera();
  const DepthImage bar = synthetic_depth(
      [](int u, int) { return uint16_t(std::abs((u - 99.5) / 150.0) <= 0.05 / 0.8 ? 800 : 1500); });
  const Eigen::Vector3f o = world(cam, {0.4, 0, 0.3}), wall = world(cam, {-0.3, 0, 1.5});
  const auto hit = hit_depth(cam, bar, o, wall - o, 5);
  ASSERT_TRUE(hit.has_value());
  EXPECT_LT((hit->point_world - wall).norm(), 0.001f);
  // With a tolerance larger than the 9 cm it was behind the bar's edge, the same ray counts as
  // going through the bar where its image entered the bar's (the rule's knob, documented).
  const auto loose = hit_depth(cam, bar, o, wall - o, 5, {.behind_tolerance_m = 0.10f});
  ASSERT_TRUE(loose.has_value());
  EXPECT_NEAR(loose->distance_m, 0.687f, 0.01f);  // entering the bar's image, 0.894 m deep
}

TEST(RayHit, RefusesMismatchedImagesAndBadRays) {
  const CameraCalibration cam = synthetic_camera();
  const DepthImage plane = synthetic_depth([](int, int) { return uint16_t{1200}; });
  const Eigen::Vector3f o(0, 0, 0), d(0, 0, 1);
  EXPECT_THROW(hit_depth(cam, DepthImage(20, 15), o, d, 5), Error);
  EXPECT_THROW(hit_depth(cam, plane, o, Eigen::Vector3f::Zero(), 5), Error);
  EXPECT_THROW(hit_depth(cam, plane, o, d, -1), Error);
  EXPECT_THROW(hit_depth(cam, plane, o, d, 5, {.step_m = 0}), Error);
  const DepthImage* depths[] = {&plane};
  EXPECT_THROW(hit_depths(std::span<const CameraCalibration>(), depths, o, d, 5), Error);
}

// --- the genuine Azure Kinect frame -------------------------------------------------------------

struct RealCamera {
  CameraCalibration calibration;
  DepthImage depth;
};

RealCamera real_kinect() {
  auto src = open_source(test::kinect_mkv());
  RealCamera c{src->calibration(), src->next().depth};
  c.calibration.world_from_camera = posed();
  return c;
}

// The valid pixel nearest the image centre whose (2 r + 1)^2 neighbourhood is valid and within
// `spread_mm` of it (`valid` true), or all invalid (`valid` false).
bool patch_near_centre(const DepthImage& d, int r, bool valid, int spread_mm, int* u_out,
                       int* v_out) {
  long best = -1;
  for (int v = r; v < d.height - r; ++v)
    for (int u = r; u < d.width - r; ++u) {
      const long dist =
          (u - d.width / 2) * (u - d.width / 2) + (v - d.height / 2) * (v - d.height / 2);
      if (best >= 0 && dist >= best) continue;
      const int c = d.at(u, v);
      bool ok = true;
      for (int dv = -r; dv <= r && ok; ++dv)
        for (int du = -r; du <= r && ok; ++du) {
          const int n = d.at(u + du, v + dv);
          ok = valid ? n != 0 && std::abs(n - c) <= spread_mm : n == 0;
        }
      if (ok) best = dist, *u_out = u, *v_out = v;
    }
  return best >= 0;
}

TEST(RayHitRealFrame, ARayFromBesideTheCameraHitsTheMeasuredPoint) {
  const RealCamera c = real_kinect();
  int u = 0, v = 0;
  ASSERT_TRUE(patch_near_centre(c.depth, 5, true, 10, &u, &v));
  const Eigen::Vector3f p =
      world(c.calibration, camera_point(c.calibration.depth, u, v, c.depth.at(u, v)));
  // 0.5 m off the camera's centre, sideways and up (camera frame -y).
  const Eigen::Vector3f o = world(c.calibration, {0.4, -0.3, 0});
  const auto hit = hit_depth(c.calibration, c.depth, o, p - o, 8);
  ASSERT_TRUE(hit.has_value());
  std::printf("pixel (%d, %d) at %d mm: hit %.1f mm from it, at pixel (%d, %d)\n", u, v,
              c.depth.at(u, v), 1000 * (hit->point_world - p).norm(), hit->pixel_x, hit->pixel_y);
  EXPECT_LT((hit->point_world - p).norm(), 0.01f);
  EXPECT_LE(std::abs(hit->pixel_x - u) + std::abs(hit->pixel_y - v), 2);
}

TEST(RayHitRealFrame, ARayIntoAnInvalidRegionMisses) {
  const RealCamera c = real_kinect();
  int u = 0, v = 0;
  ASSERT_TRUE(patch_near_centre(c.depth, 3, false, 0, &u, &v));
  const Eigen::Vector3f o = c.calibration.world_from_camera.translation.cast<float>();
  const Eigen::Vector3f through =
      world(c.calibration, camera_point(c.calibration.depth, u, v, 1000));
  std::printf("invalid pixel (%d, %d)\n", u, v);
  EXPECT_FALSE(hit_depth(c.calibration, c.depth, o, through - o, 8).has_value());
  // The control: the same ray through a valid pixel nearby hits.
  int vu = 0, vv = 0;
  ASSERT_TRUE(patch_near_centre(c.depth, 2, true, 20, &vu, &vv));
  const Eigen::Vector3f valid =
      world(c.calibration, camera_point(c.calibration.depth, vu, vv, c.depth.at(vu, vv)));
  const auto hit = hit_depth(c.calibration, c.depth, o, valid - o, 8);
  ASSERT_TRUE(hit.has_value());
  EXPECT_LT((hit->point_world - valid).norm(), 0.01f);
}

TEST(RayHitRealFrame, ARayGrazingPastAForegroundEdgeHitsTheBackground) {
  // A clean depth edge in a row: foreground pixels (flat within 2 cm for 5 pixels), then at most
  // 8 invalid pixels (the Azure Kinect drops mixed pixels at edges), then background pixels at
  // least 20 cm deeper (flat within 2 cm for 5 pixels). The ray passes 2 cm in front of the
  // foreground's last pixel, at its outer edge, and goes on to the background 3 pixels past its
  // first pixel: it must meet the background there, not the edge (no depth is made up between
  // foreground and background, and invalid pixels never hit).
  const RealCamera c = real_kinect();
  const Intrinsics& k = c.calibration.depth;
  const DepthImage& d = c.depth;
  const auto flat = [&](int u, int v, int s, int depth) {
    for (int j = 0; j < 5; ++j) {
      const int x = u + s * j;
      if (x < 0 || x >= d.width || d.at(x, v) == 0 || std::abs(d.at(x, v) - depth) > 20)
        return false;
    }
    return true;
  };
  int best = -1, eu = 0, ev = 0, bu = 0, side = 0;
  for (int v = 0; v < d.height; ++v)
    for (int u = 0; u < d.width; ++u)
      for (int s : {1, -1}) {
        const int f = d.at(u, v);
        if (f == 0 || !flat(u, v, -s, f)) continue;
        int w = u + s;
        while (w >= 0 && w < d.width && d.at(w, v) == 0 && std::abs(w - u) <= 8) w += s;
        if (w < 0 || w >= d.width || d.at(w, v) - f < 200 || !flat(w, v, s, d.at(w, v))) continue;
        const int dist = std::abs(u - k.width / 2) + std::abs(v - k.height / 2);
        if (best < 0 || dist < best) best = dist, eu = u, ev = v, bu = w + 3 * s, side = s;
      }
  ASSERT_GE(best, 0) << "no clean depth edge in the frame";
  const int fg = d.at(eu, ev), bg = d.at(bu, ev);
  const Eigen::Vector3d past_edge = camera_point(k, eu + 0.5 * side, ev, fg - 20);
  const Eigen::Vector3d target = camera_point(k, bu, ev, bg);
  const Eigen::Vector3d o = past_edge + (past_edge - target).normalized() * 0.05;
  const Eigen::Vector3f ow = world(c.calibration, o), tw = world(c.calibration, target);
  std::printf("edge at (%d, %d): foreground %d mm, background %d mm at pixel %d\n", eu, ev, fg, bg,
              bu);
  const auto hit = hit_depth(c.calibration, d, ow, tw - ow, 8);
  ASSERT_TRUE(hit.has_value());
  EXPECT_LT((hit->point_world - tw).norm(), 0.01f);
  EXPECT_GT(hit->distance_m, (tw - ow).norm() - 0.01f);
}

TEST(RayHitRealFrame, WithTwoCamerasTheNearerHitWins) {
  // The four-Kinect set has no poses, so: the real camera, and the same camera with the same
  // depth moved 25 cm back along its optical axis (so its surfaces lie 25 cm nearer the ray's
  // origin, which is beside the first camera).
  const RealCamera c = real_kinect();
  CameraCalibration moved = c.calibration;
  moved.world_from_camera.translation -= c.calibration.world_from_camera.rotation.col(2) * 0.25;
  int u = 0, v = 0;
  ASSERT_TRUE(patch_near_centre(c.depth, 5, true, 10, &u, &v));
  const Eigen::Vector3f p =
      world(c.calibration, camera_point(c.calibration.depth, u, v, c.depth.at(u, v)));
  const Eigen::Vector3f o = world(c.calibration, {0.1, -0.1, 0});
  const auto alone = hit_depth(c.calibration, c.depth, o, p - o, 8);
  ASSERT_TRUE(alone.has_value());
  const CameraCalibration cams[] = {c.calibration, moved};
  const DepthImage* depths[] = {&c.depth, &c.depth};
  const auto both = hit_depths(cams, depths, o, p - o, 8);
  ASSERT_TRUE(both.has_value());
  EXPECT_EQ(both->camera, 1u);
  EXPECT_LT(both->distance_m, alone->distance_m - 0.15f);
  // The order of the cameras does not matter; a camera without an image is skipped.
  const CameraCalibration swapped[] = {moved, c.calibration};
  const auto reversed = hit_depths(swapped, depths, o, p - o, 8);
  ASSERT_TRUE(reversed.has_value());
  EXPECT_EQ(reversed->camera, 0u);
  EXPECT_FLOAT_EQ(reversed->distance_m, both->distance_m);
  const DepthImage* only_first[] = {&c.depth, nullptr};
  const auto skipped = hit_depths(cams, only_first, o, p - o, 8);
  ASSERT_TRUE(skipped.has_value());
  EXPECT_EQ(skipped->camera, 0u);
  EXPECT_FLOAT_EQ(skipped->distance_m, alone->distance_m);
}

}  // namespace
}  // namespace volcast
