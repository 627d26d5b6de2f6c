// Headless splat rendering through EGL (Mesa llvmpipe on machines without a GPU).
#include <gtest/gtest.h>

#include "test_data.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/render/splat_renderer.hpp"

namespace volcast {
namespace {

TEST(SplatRenderer, DrawsAPointWhereItProjectsInItsColor) {
  SplatRenderer renderer(160, 120);
  EXPECT_NE(renderer.gl_description().find("4."), std::string::npos) << renderer.gl_description();
  // Synthetic cloud (labelled): one red point straight ahead, one green point up and to the left.
  PointCloud cloud;
  cloud.points.push_back({{0, 0, 2}, 0.05f, 0xff0000ffu});
  cloud.points.push_back({{-0.5f, -0.4f, 2}, 0.05f, 0xff00ff00u});
  const PointCloud* clouds[] = {&cloud};
  ViewCamera view;  // at the origin looking down +z, up = -y
  ColorImage image;
  renderer.render(clouds, view, image);
  ASSERT_EQ(image.width, 160);
  const uint8_t* centre = image.pixel(80, 60);
  EXPECT_GT(centre[2], 200);  // red (BGRA)
  EXPECT_LT(centre[1], 50);
  // (-0.5, -0.4, 2) is left of the axis and, with -y up, above it: the upper-left quadrant.
  bool green_upper_left = false;
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x) green_upper_left |= image.pixel(x, y)[1] > 200;
  EXPECT_TRUE(green_upper_left);
  const uint8_t* corner = image.pixel(159, 119);
  EXPECT_LT(corner[0] + corner[1] + corner[2], 100);  // background
}

TEST(SplatRenderer, RendersARealFrameFromItsCamera) {
  auto src = open_source(test::kinect_mkv());
  const CameraFrame f = src->next();
  PointCloud cloud;
  CloudBuilder(src->calibration()).build(f.depth, f.color, cloud);
  SplatRenderer renderer(320, 288);
  ViewCamera view;
  view.vertical_fov_deg = 65;
  const PointCloud* clouds[] = {&cloud};
  ColorImage image;
  renderer.render(clouds, view, image);
  size_t covered = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const uint8_t* p = image.pixel(x, y);
      covered += (p[0] + p[1] + p[2]) > 90;
    }
  // The NFOV depth image covers most of a view from its own camera with a similar field of view.
  EXPECT_GT(static_cast<double>(covered) / (image.width * image.height), 0.4);
}

}  // namespace
}  // namespace volcast
