// Intrinsics derivation (Azure Kinect SDK rules) and the Brown-Conrady lens model.
#include <gtest/gtest.h>

#include <cstring>
#include <fstream>
#include <nlohmann/json.hpp>
#include <thread>

#include "support/test_data.hpp"
#include "volcast/capture/k4a_calibration.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/ray_table.hpp"

namespace volcast {
namespace {

std::string read_text(const std::filesystem::path& p) {
  std::ifstream in(p);
  return {std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>()};
}

TEST(K4aCalibration, NfovUnbinnedIntrinsicsFollowTheSdkModeCropAndScale) {
  const auto path = test::data_dir() / "k4a-recording" / "calibration.json";
  const std::string text = read_text(path);
  // Independent reading of the raw parameters: ModelParameters = cx, cy, fx, fy, k1..k6, codx,
  // cody, p2, p1, normalised to the 1024x1024 depth sensor.
  const auto j = nlohmann::json::parse(text);
  const auto& p = j["CalibrationInformation"]["Cameras"][0]["Intrinsics"]["ModelParameters"];
  ASSERT_EQ(j["CalibrationInformation"]["Cameras"][0]["Purpose"], "CALIBRATION_CameraPurposeDepth");
  // NFOV unbinned (SDK transformation.c): scale to 1024, crop offset (192, 180), pixel centres
  // -0.5.
  const double cx = p[0].get<double>() * 1024 - 192 - 0.5;
  const double cy = p[1].get<double>() * 1024 - 180 - 0.5;
  const double fx = p[2].get<double>() * 1024;
  const double fy = p[3].get<double>() * 1024;

  const K4aCalibration cal = parse_k4a_calibration(text);
  const Intrinsics k = k4a_depth_mode_intrinsics(cal.depth, K4aDepthMode::kNfovUnbinned);
  EXPECT_EQ(k.width, 640);
  EXPECT_EQ(k.height, 576);
  EXPECT_NEAR(k.cx, cx, 1e-9);
  EXPECT_NEAR(k.cy, cy, 1e-9);
  EXPECT_NEAR(k.fx, fx, 1e-9);
  EXPECT_NEAR(k.fy, fy, 1e-9);
  EXPECT_NEAR(k.fx, 504.6076, 1e-3);  // as `volcast info` prints for this recording
  EXPECT_DOUBLE_EQ(k.k1, p[4].get<double>());
  EXPECT_DOUBLE_EQ(k.k6, p[9].get<double>());
  EXPECT_DOUBLE_EQ(k.p2, p[12].get<double>());
  EXPECT_DOUBLE_EQ(k.p1, p[13].get<double>());
  EXPECT_DOUBLE_EQ(k.metric_radius, 1.7399997711181641);
}

TEST(K4aCalibration, MatchesIntrinsicsPrintedByTheAzureKinectSdk) {
  // Test vector: normalised parameters and the SDK's own printout of the resulting NFOV unbinned
  // depth and 1080p color intrinsics for one device, as published in a public repository
  // (panispani/3DReconstruct, pointCloudGen/calib.md).
  K4aSensorCalibration depth, color;
  depth.normalized = {
      1024, 1024, 0.4921168386936188, 0.4921667277812958, 0.5122697949409485, 0.49451231956481934};
  color.normalized = {
      4096, 3072, 0.470907062292099, 0.6274453997612, 0.4967627227306366, 0.5108628273010254};
  const Intrinsics d = k4a_depth_mode_intrinsics(depth, K4aDepthMode::kNfovUnbinned);
  EXPECT_NEAR(d.cx, 332.064270, 1e-4);
  EXPECT_NEAR(d.cy, 325.880615, 1e-4);
  EXPECT_NEAR(d.fx, 503.927643, 1e-4);
  EXPECT_NEAR(d.fy, 503.978729, 1e-4);
  const Intrinsics c = k4a_color_mode_intrinsics(color, 1920, 1080);
  EXPECT_NEAR(c.cx, 953.284424, 1e-3);
  EXPECT_NEAR(c.cy, 555.142456, 1e-3);
  EXPECT_NEAR(c.fx, 904.141541, 1e-3);
  EXPECT_NEAR(c.fy, 903.521362, 1e-3);
}

TEST(K4aCalibration, BinnedAndWideModesScaleAndCrop) {
  K4aSensorCalibration depth;
  depth.normalized = {1024, 1024, 0.5, 0.5, 0.5, 0.5};
  const Intrinsics b = k4a_depth_mode_intrinsics(depth, K4aDepthMode::kNfov2x2Binned);
  EXPECT_EQ(b.width, 320);
  EXPECT_DOUBLE_EQ(b.cx, 0.5 * 512 - 96 - 0.5);
  const Intrinsics w = k4a_depth_mode_intrinsics(depth, K4aDepthMode::kWfovUnbinned);
  EXPECT_EQ(w.height, 1024);
  EXPECT_DOUBLE_EQ(w.cy, 511.5);
}

TEST(K4aCalibration, RejectsMalformedJsonNamingTheProblem) {
  EXPECT_THROW(parse_k4a_calibration("{not json"), Error);
  try {
    parse_k4a_calibration(R"({"CalibrationInformation": {"Cameras": []}})");
    FAIL();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("depth"), std::string::npos) << e.what();
  }
  EXPECT_THROW(parse_k4a_depth_mode("NFOV_HUGE"), Error);
  K4aSensorCalibration color;
  EXPECT_THROW(k4a_color_mode_intrinsics(color, 1000, 700), Error);
}

TEST(LensModel, UnprojectInvertsProjectOnEveryPixelOfTheRealDepthCamera) {
  const K4aCalibration cal =
      parse_k4a_calibration(read_text(test::data_dir() / "k4a-recording" / "calibration.json"));
  const Intrinsics k = k4a_depth_mode_intrinsics(cal.depth, K4aDepthMode::kNfovUnbinned);
  const RayTable rays = make_ray_table(k);
  size_t valid = 0;
  double worst = 0;
  for (int v = 0; v < k.height; ++v)
    for (int u = 0; u < k.width; ++u) {
      const size_t i = static_cast<size_t>(v) * k.width + u;
      if (std::isnan(rays.x[i])) continue;
      ++valid;
      const auto uv = project_normalized(k, {rays.x[i], rays.y[i]});
      ASSERT_TRUE(uv.has_value());
      worst = std::max(worst, (*uv - Eigen::Vector2d(u, v)).norm());
    }
  EXPECT_LT(worst, 1e-3) << "pixels";  // float storage of the rays limits this, not the solver
  EXPECT_GT(static_cast<double>(valid) / (k.width * k.height), 0.95);
  // The principal point's ray is the optical axis, up to distortion's tangential terms.
  const auto centre = unproject_pixel(k, {k.cx, k.cy});
  ASSERT_TRUE(centre.has_value());
  EXPECT_NEAR(centre->norm(), 0.0, 1e-4);
}

// Several renderers of one process share one table per intrinsics, made once even when asked
// for at once from several threads; other intrinsics get their own.
TEST(LensModel, SharedRayTablesAreMadeOncePerIntrinsicsAndEqualAFreshOne) {
  const K4aCalibration cal =
      parse_k4a_calibration(read_text(test::data_dir() / "k4a-recording" / "calibration.json"));
  const Intrinsics k = k4a_depth_mode_intrinsics(cal.depth, K4aDepthMode::kNfovUnbinned);
  std::vector<std::shared_ptr<const RayTable>> got(4);
  std::vector<std::thread> threads;
  for (auto& g : got) threads.emplace_back([&g, &k] { g = shared_ray_table(k); });
  for (auto& t : threads) t.join();
  for (const auto& g : got) EXPECT_EQ(g.get(), got[0].get()) << "one table for all";
  const RayTable fresh = make_ray_table(k);
  ASSERT_EQ(got[0]->x.size(), fresh.x.size());
  EXPECT_EQ(0, std::memcmp(got[0]->x.data(), fresh.x.data(), fresh.x.size() * sizeof(float)));
  EXPECT_EQ(0, std::memcmp(got[0]->y.data(), fresh.y.data(), fresh.y.size() * sizeof(float)));
  Intrinsics other = k;
  other.k1 += 0.01;
  const auto o = shared_ray_table(other);
  EXPECT_NE(o.get(), got[0].get());
  EXPECT_EQ(shared_ray_table(k).get(), got[0].get()) << "still kept";
}

TEST(LensModel, PinholeIsExact) {
  Intrinsics k{640, 360, 460, 460, 320, 180};
  const auto xy = unproject_pixel(k, {100, 50});
  ASSERT_TRUE(xy);
  EXPECT_DOUBLE_EQ(xy->x(), (100 - 320) / 460.0);
  EXPECT_DOUBLE_EQ(xy->y(), (50 - 180) / 460.0);
}

TEST(RigidTransform, ComposesRightToLeftAndInverts) {
  RigidTransform world_from_camera;
  world_from_camera.rotation = Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitY()).toRotationMatrix();
  world_from_camera.translation = {1, 2, 3};
  const Eigen::Vector3d p(0.1, -0.2, 1.5);
  const RigidTransform camera_from_world = world_from_camera.inverse();
  EXPECT_LT((camera_from_world * (world_from_camera * p) - p).norm(), 1e-12);
  EXPECT_LT(((world_from_camera * camera_from_world) * p - p).norm(), 1e-12);
}

}  // namespace
}  // namespace volcast
