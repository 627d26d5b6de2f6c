// Point clouds from depth: geometry, world placement and colors.
#include <gtest/gtest.h>

#include "test_data.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
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

}  // namespace
}  // namespace volcast
