// Leave-one-camera-out view synthesis (volcast/quality) and the blending it scores: known answers
// on a synthetic textured plane, blending on the real four Azure Kinects, colour balance.
#include <gtest/gtest.h>

#include <cmath>

#include "support/test_data.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/quality/view_quality.hpp"
#include "volcast/render/colour_balance.hpp"
#include "volcast/render/headless_target.hpp"
#include "volcast/render/view.hpp"

namespace volcast {
namespace {

// Synthetic (labelled): a 160x120 pinhole camera looking along +z at a plane 2 m away, its
// colour a smooth pattern of the plane's (X, Y) (periods 0.30 and 0.24 m, 18 and 14 pixels), so
// any camera seeing the plane sees the same colour at the same world point. `gain` scales the
// colour (an exposure difference).
constexpr double kPlaneM = 2.0;
Intrinsics plane_intrinsics() {
  return {.width = 160, .height = 120, .fx = 120, .fy = 120, .cx = 79.5, .cy = 59.5};
}
CameraFrame plane_frame(double camera_x, double gain = 1.0) {
  const Intrinsics k = plane_intrinsics();
  CameraFrame f;
  f.depth = DepthImage(k.width, k.height);
  f.color = ColorImage(k.width, k.height);
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      f.depth.pixels[static_cast<size_t>(v) * 160 + static_cast<size_t>(u)] = 2000;
      const double x = camera_x + (u - k.cx) / k.fx * kPlaneM, y = (v - k.cy) / k.fy * kPlaneM;
      uint8_t* p = f.color.pixel(u, v);
      const double r = 128 + 90 * std::sin(2 * M_PI * x / 0.30);
      const double g = 128 + 90 * std::sin(2 * M_PI * y / 0.24);
      const double b = 128 + 60 * std::sin(2 * M_PI * (x + y) / 0.4);
      p[0] = static_cast<uint8_t>(std::clamp(b * gain, 0.0, 255.0));
      p[1] = static_cast<uint8_t>(std::clamp(g * gain, 0.0, 255.0));
      p[2] = static_cast<uint8_t>(std::clamp(r * gain, 0.0, 255.0));
      p[3] = 255;
    }
  }
  return f;
}
CameraCalibration plane_camera(double x) {
  CameraCalibration c;
  c.depth = plane_intrinsics();
  c.world_from_camera.translation = {x, 0, 0};
  return c;
}
// Camera 0 at the origin, camera 1 0.4 m to its right: each sees 2.667 m of the plane across, so
// the other covers (2.667 - 0.4) / 2.667 = 85 % of its pixels.
constexpr double kBaselineM = 0.4, kOverlap = (8.0 / 3.0 - kBaselineM) / (8.0 / 3.0);

CameraPassOptions setting(Surface surface, bool blend) {
  CameraPassOptions o;
  o.surface = surface;
  o.blend = blend;
  return o;
}

TEST(ViewQuality, ATexturedPlaneHeldOutScoresHighWhereCoveredAndItsCoverageIsTheOverlap) {
  LeaveOneOut loo({plane_camera(0), plane_camera(kBaselineM)},
                  {plane_frame(0), plane_frame(kBaselineM)});
  for (const CameraPassOptions& o :
       {setting(Surface::kSplats, false), setting(Surface::kSplats, true),
        setting(Surface::kMesh, false), setting(Surface::kMesh, true)}) {
    SCOPED_TRACE(std::string(to_string(o.surface)) + (o.blend ? ", blended" : ""));
    const LeaveOneOut::Result r = loo.run(o);
    ASSERT_EQ(r.scores.size(), 2u);
    for (const ViewScore& s : r.scores) {
      EXPECT_EQ(s.valid, 160u * 120u);
      EXPECT_NEAR(s.coverage, kOverlap, 0.02);
      EXPECT_GT(s.psnr_db, 28);
      EXPECT_GT(s.ssim, 0.9);
      // The blended depth is the surface's, not the prepass's pushed front.
      EXPECT_LT(s.depth_mean_mm, 3.0);
      EXPECT_EQ(s.seam_pixels, 0u);  // one camera drawn: no seams
    }
    // Each view's dominant source is the other camera wherever something was drawn.
    for (size_t k = 0; k < 2; ++k)
      for (size_t i = 0; i < r.views[k].source.size(); ++i)
        if (r.views[k].rendered_depth_m[i] > 0) {
          ASSERT_EQ(r.views[k].source[i], 1 - k);
        }
  }
}

TEST(ViewQuality, ACameraMovedByTwoCentimetresMakesTheScoreDrop) {
  LeaveOneOut loo({plane_camera(0), plane_camera(kBaselineM)},
                  {plane_frame(0), plane_frame(kBaselineM)});
  const CameraPassOptions o = setting(Surface::kMesh, true);
  const ViewScore good = loo.run(o).scores[1];  // camera 1 held out, camera 0 drawn
  RigidTransform sideways;
  sideways.translation = {0.02, 0, 0};
  loo.set_world_from_camera(0, sideways);
  const ViewScore beside = loo.run(o).scores[1];
  EXPECT_LT(beside.psnr_db, good.psnr_db - 3) << good.psnr_db << " -> " << beside.psnr_db;
  EXPECT_LT(beside.ssim, good.ssim);
  RigidTransform back;
  back.translation = {0, 0, 0.02};
  loo.set_world_from_camera(0, back);
  const ViewScore behind = loo.run(o).scores[1];
  EXPECT_NEAR(behind.depth_mean_mm, 20, 2);
  EXPECT_LT(behind.psnr_db, good.psnr_db);
}

TEST(ViewQuality, BlendingNeverUncoversAPixelTheCamerasCover) {
  // Real: the four Azure Kinects, turned about one point so their surfaces overlap on screen
  // (their registration does not matter here: what is covered does).
  auto sources = four_camera_site(test::data_dir());
  std::vector<CameraCalibration> cams;
  std::vector<CameraFrame> frames;
  for (auto& source : sources) {
    cams.push_back(source->calibration());
    frames.push_back(source->next());
  }
  cams = turned_to_overlap(cams);
  HeadlessTarget target(320, 240);
  CameraRenderer renderer;
  renderer.set_cameras(cams);
  for (size_t i = 0; i < frames.size(); ++i) renderer.upload(i, frames[i]);
  View view;
  view.world_from_view = look_at({0.3, -0.2, -0.5}, {0, 0, 2.0}, {0, -1, 0});
  view.clip_from_view = perspective(70, 320.0f / 240.0f, 0.05f, 30);
  std::vector<float> off, on;
  for (Surface surface : {Surface::kSplats, Surface::kMesh}) {
    SCOPED_TRACE(to_string(surface));
    renderer.draw_cameras(view, target.target(), setting(surface, false));
    target.read_depth(off);
    for (BlendWeights weights : {BlendWeights::kAngleDistance, BlendWeights::kReliability}) {
      CameraPassOptions o = setting(surface, true);
      o.blend_weights = weights;
      renderer.draw_cameras(view, target.target(), o);
      target.read_depth(on);
      size_t covered = 0, uncovered = 0;
      for (size_t i = 0; i < off.size(); ++i) {
        covered += off[i] < 1;
        uncovered += off[i] < 1 && !(on[i] < 1);
      }
      EXPECT_GT(covered, off.size() / 4);
      EXPECT_EQ(uncovered, 0u) << "of " << covered << " covered pixels";
    }
  }
}

TEST(ColourBalance, TwoCamerasSeeingOneSurfaceAreGivenGainsThatUndoTheirExposureDifference) {
  // Synthetic: camera 1's colour is 80 % of camera 0's on the same plane.
  std::vector<ColourSamples> samples(3);
  const CameraFrame frames[3] = {plane_frame(0), plane_frame(kBaselineM, 0.8),
                                 plane_frame(kBaselineM)};
  for (size_t i = 0; i < 3; ++i) {
    samples[i].intrinsics = plane_intrinsics();
    samples[i].rays = shared_ray_table(plane_intrinsics());
    take_colour_samples(frames[i], samples[i]);
  }
  samples[0].world_from_camera = plane_camera(0).world_from_camera;
  samples[1].world_from_camera = plane_camera(kBaselineM).world_from_camera;
  samples[2].world_from_camera.translation = {50, 0, 0};  // sees nothing the others see
  const std::vector<Eigen::Vector3f> g = colour_gains(samples);
  ASSERT_EQ(g.size(), 3u);
  for (int ch = 0; ch < 3; ++ch) {
    EXPECT_NEAR(g[1][ch] / g[0][ch], 1.25, 0.04) << "channel " << ch;
    EXPECT_NEAR(g[0][ch] * g[1][ch], 1.0, 0.05);  // the exposure between them, not either's
    EXPECT_FLOAT_EQ(g[2][ch], 1.0f);              // no overlap: left alone
  }
}

}  // namespace
}  // namespace volcast
