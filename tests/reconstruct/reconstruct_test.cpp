// Point clouds from depth: geometry, world placement and colors.
#include <gtest/gtest.h>

#include <Eigen/Geometry>

#include "support/test_data.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/reconstruct/avatar_filter.hpp"
#include "volcast/reconstruct/point_cloud.hpp"

namespace volcast {
namespace {

TEST(CloudBuilder, PinholePointsLieOnTheirPixelRaysAtTheirDepth) {
  // Synthetic 3x2 depth image (labelled) with one invalid pixel.
  CameraCalibration cal;
  cal.depth = {3, 2, 100, 100, 1, 0.5};
  cal.world_from_camera.translation = {1, 0, 0};
  DepthImage depth(3, 2);
  depth.pixels = {1000, 2000, 0, 500, 1000, 1500};
  ColorImage color(3, 2);
  color.pixel(1, 0)[2] = 200;  // red
  color.pixel(1, 0)[3] = 255;
  PointCloud cloud;
  CloudBuilder(cal).build(depth, color, cloud);
  ASSERT_EQ(cloud.points.size(), 5u);
  const SplatPoint& p = cloud.points[1];  // pixel (1, 0), 2 m
  EXPECT_FLOAT_EQ(p.position[0], 1.0f + (1 - 1) / 100.0f * 2.0f);
  EXPECT_FLOAT_EQ(p.position[1], (0 - 0.5f) / 100.0f * 2.0f);
  EXPECT_FLOAT_EQ(p.position[2], 2.0f);
  EXPECT_EQ(p.rgba, 0xff0000c8u);                // R in the lowest byte
  EXPECT_EQ(cloud.points[0].rgba, 0xffa0a0a0u);  // no color: gray
  EXPECT_NEAR(p.radius, 0.75f * 2.0f / 100.0f, 1e-6f);
}

TEST(CloudBuilder, RealKinectFrameGivesAPlausibleCloud) {
  auto src = open_source(test::kinect_mkv());
  const CameraFrame f = src->next();
  PointCloud cloud;
  CloudBuilder(src->calibration()).build(f.depth, f.color, cloud);
  size_t valid = 0;
  for (uint16_t d : f.depth.pixels) valid += d != 0;
  EXPECT_GT(cloud.points.size(), valid * 95 / 100);  // only pixels outside the lens model are lost
  for (const SplatPoint& p : cloud.points) {
    ASSERT_GT(p.position[2], 0.1f);
    ASSERT_LT(p.position[2], 6.0f);
  }
}

TEST(CloudBuilder, RejectsMismatchedImages) {
  CameraCalibration cal;
  cal.depth = {4, 4, 10, 10, 2, 2};
  PointCloud cloud;
  EXPECT_THROW(CloudBuilder(cal).build(DepthImage(3, 3), ColorImage(), cloud), Error);
  EXPECT_THROW(CloudBuilder(cal).build(DepthImage(4, 4), ColorImage(2, 2), cloud), Error);
}

// Synthetic points at known places (labelled): exact keep and hide decisions, boundaries included.
TEST(AvatarFilter, KeepsASphereAndHidesAHeadsetBoxInclusively) {
  PointCloud cloud;
  const auto add = [&](float x, float y, float z, uint32_t id) {
    cloud.points.push_back({{x, y, z}, 0.01f, id});
  };
  add(1.0f, 1.5f, 0.0f, 0);   // the head's centre: inside the headset box
  add(1.0f, 1.5f, 0.5f, 1);   // 0.5 m behind it: in the sphere, outside the box
  add(1.0f, 1.5f, 0.75f, 2);  // on the sphere (0.75 m): kept
  add(1.0f, 1.5f, 0.76f, 3);  // just outside the sphere
  add(1.0f, 0.5f, 0.0f, 4);   // 1 m below: outside the sphere
  add(1.05f, 1.5f, 0.0f, 5);  // 5 cm behind the headset (its +z, backwards, is the world's +x)
  add(1.0f, 1.5f, 0.2f, 6);   // 0.2 m to its right-hand side along world z: headset x = -0.2
  AvatarFilter f;
  f.keep = KeepSphere{{1.0f, 1.5f, 0.0f}, 0.75f};
  HideBox box;
  // The headset at the head, turned 90 degrees about y: its z (backwards) is the world's +x.
  box.world_from_headset.rotation = Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitY()).matrix();
  box.world_from_headset.translation = {1.0, 1.5, 0.0};
  box.half_extent_m = {0.15f, 0.1f, 0.1f};
  f.hide = box;

  const auto kept_ids = [](const PointCloud& c) {
    std::vector<uint32_t> ids;
    for (const SplatPoint& p : c.points) ids.push_back(p.rgba);
    return ids;
  };
  PointCloud only_keep = cloud;
  AvatarFilter keep_only;
  keep_only.keep = f.keep;
  EXPECT_EQ(apply_avatar_filter(keep_only, only_keep), 2u);
  EXPECT_EQ(kept_ids(only_keep), (std::vector<uint32_t>{0, 1, 2, 5, 6}));
  PointCloud only_hide = cloud;
  AvatarFilter hide_only;
  hide_only.hide = f.hide;
  EXPECT_EQ(apply_avatar_filter(hide_only, only_hide), 2u);  // the centre, and 5 cm behind it
  EXPECT_EQ(kept_ids(only_hide), (std::vector<uint32_t>{1, 2, 3, 4, 6}));
  PointCloud both = cloud;
  EXPECT_EQ(apply_avatar_filter(f, both), 4u);
  EXPECT_EQ(kept_ids(both), (std::vector<uint32_t>{1, 2, 6}));
  PointCloud none = cloud;
  EXPECT_EQ(apply_avatar_filter({}, none), 0u);
  EXPECT_EQ(none.points.size(), cloud.points.size());
  EXPECT_TRUE(avatar_filter_keeps(f, {1.0f, 1.5f, 0.5f}));
  EXPECT_FALSE(avatar_filter_keeps(f, {1.0f, 1.5f, 0.0f}));
}

// The real Azure Kinect frame: the sphere keeps exactly the points within its radius of a point
// of the scene, in their order, and allocates nothing.
TEST(AvatarFilter, OnARealFrameKeepsExactlyThePointsWithinTheRadius) {
  auto src = open_source(test::kinect_mkv());
  const CameraFrame frame = src->next();
  PointCloud cloud;
  CloudBuilder(src->calibration()).build(frame.depth, frame.color, cloud);
  ASSERT_GT(cloud.points.size(), 10000u);
  const SplatPoint& mid = cloud.points[cloud.points.size() / 2];
  AvatarFilter f;
  f.keep = KeepSphere{{mid.position[0], mid.position[1], mid.position[2]}, 0.4f};
  std::vector<uint32_t> expected;
  for (size_t i = 0; i < cloud.points.size(); ++i) {
    const SplatPoint& p = cloud.points[i];
    const Eigen::Vector3f d =
        Eigen::Vector3f(p.position[0], p.position[1], p.position[2]) - f.keep->center;
    if (d.norm() <= 0.4f) expected.push_back(static_cast<uint32_t>(i));
  }
  for (size_t i = 0; i < cloud.points.size(); ++i)
    cloud.points[i].rgba = static_cast<uint32_t>(i);  // the point's index, to check the order
  const SplatPoint* data = cloud.points.data();
  const size_t removed = apply_avatar_filter(f, cloud);
  EXPECT_EQ(cloud.points.data(), data);
  ASSERT_EQ(cloud.points.size(), expected.size());
  EXPECT_GT(removed, 0u);
  EXPECT_GT(expected.size(), 1000u);
  for (size_t i = 0; i < expected.size(); ++i) ASSERT_EQ(cloud.points[i].rgba, expected[i]);
}

}  // namespace
}  // namespace volcast
