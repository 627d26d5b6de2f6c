// The depth filter chain: exact behaviour on small synthetic frames (labelled) and invariants on
// the real recordings.
#include <gtest/gtest.h>

#include <fstream>

#include "support/test_data.hpp"
#include "volcast/capture/k4a_calibration.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/filter/chain.hpp"

namespace volcast {
namespace {

DepthImage synthetic(int w, int h, std::initializer_list<uint16_t> values) {
  DepthImage d(w, h);
  std::copy(values.begin(), values.end(), d.pixels.begin());
  return d;
}

Intrinsics kinect_intrinsics() {
  std::ifstream in(test::data_dir() / "k4a-recording" / "calibration.json");
  const std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return k4a_depth_mode_intrinsics(parse_k4a_calibration(text).depth, K4aDepthMode::kNfovUnbinned);
}

TEST(Threshold, DropsDepthOutsideNearAndFar) {
  DepthImage d = synthetic(4, 1, {100, 500, 2000, 4000});  // synthetic
  threshold_depth(d, 300, 3000);
  EXPECT_EQ(d.pixels, (std::vector<uint16_t>{0, 500, 2000, 0}));
  DepthImage e = synthetic(2, 1, {100, 60000});
  threshold_depth(e, 0, 0);  // no bounds
  EXPECT_EQ(e.pixels, (std::vector<uint16_t>{100, 60000}));
}

TEST(HoleFilling, FillsASmallHoleWithTheNeighboursMedian) {
  // Synthetic 3x3: the centre is a hole; its neighbours span 1000..1007 mm.
  DepthImage d = synthetic(3, 3, {1000, 1001, 1002, 1003, 0, 1004, 1005, 1006, 1007});
  HoleFiller{}.apply(d);
  EXPECT_EQ(d.at(1, 1), 1003);  // lower median of the 8 neighbours
}

TEST(HoleFilling, NeverBridgesAStepEdge) {
  // Synthetic 3x3: a hole between a surface at 1000 mm and one at 1500 mm.
  DepthImage d = synthetic(3, 3, {1000, 1000, 1500, 1000, 0, 1500, 1000, 1000, 1500});
  HoleFiller{}.apply(d);
  EXPECT_EQ(d.at(1, 1), 0);
}

TEST(HoleFilling, NeedsEnoughValidNeighbours) {
  // Synthetic: only 3 valid neighbours (< 4) -> the border of a large invalid region stays.
  DepthImage d = synthetic(3, 3, {1000, 1000, 1000, 0, 0, 0, 0, 0, 0});
  HoleFiller{}.apply(d);
  EXPECT_EQ(d.at(1, 1), 0);
}

TEST(HoleFilling, IterationsGrowIntoLargerHoles) {
  // Synthetic 7x7 plane at 1200 mm with a 3x3 hole: one iteration fills its ring, a second the
  // centre.
  DepthImage d(7, 7);
  std::fill(d.pixels.begin(), d.pixels.end(), uint16_t{1200});
  for (int y = 2; y <= 4; ++y)
    for (int x = 2; x <= 4; ++x) d.at(x, y) = 0;
  HoleFiller one;
  one.iterations = 1;
  DepthImage a = d;
  one.apply(a);
  EXPECT_NE(a.at(2, 2), 0);
  EXPECT_EQ(a.at(3, 3), 0);
  HoleFiller two;
  two.iterations = 2;
  two.apply(d);
  EXPECT_EQ(d.at(3, 3), 1200);
}

TEST(HoleFilling, OnRealFramesStaysWithinNeighboursAndOffStepEdges) {
  for (const std::string set : {"kinect", "4cam", "hands"}) {
    auto frames = test::real_depth_frames(set);
    frames.resize(std::min<size_t>(frames.size(), 20));
    for (const DepthImage& raw : frames) {
      DepthImage d = raw;
      HoleFiller f;
      f.iterations = 1;  // one iteration: every fill is checked against the raw neighbours
      f.apply(d);
      size_t filled = 0;
      for (int y = 1; y + 1 < d.height; ++y)
        for (int x = 1; x + 1 < d.width; ++x) {
          if (raw.at(x, y) != 0 || d.at(x, y) == 0) continue;
          ++filled;
          uint16_t lo = 65535, hi = 0;
          for (int dy = -1; dy <= 1; ++dy)
            for (int dx = -1; dx <= 1; ++dx)
              if (const uint16_t v = raw.at(x + dx, y + dy))
                lo = std::min(lo, v), hi = std::max(hi, v);
          ASSERT_GE(d.at(x, y), lo);
          ASSERT_LE(d.at(x, y), hi);
          ASSERT_LE(hi - lo, f.max_spread_mm)
              << set << ": filled across a step edge at " << x << "," << y;
        }
      EXPECT_GT(filled, 0u) << set;
    }
  }
}

TEST(Kalman, FollowsASudden100mmStepWithinOneFrame) {
  // Synthetic: a static surface at 1000 mm with +-2 mm noise, then a hand moves 100 mm closer.
  KalmanFilter k;
  DepthImage d(1, 1);
  for (int i = 0; i < 30; ++i) {
    d.pixels[0] = static_cast<uint16_t>(1000 + (i % 2 ? 2 : -2));
    k.apply(d);
  }
  EXPECT_NEAR(d.pixels[0], 1000, 1);  // noise smoothed
  d.pixels[0] = 900;
  k.apply(d);
  EXPECT_EQ(d.pixels[0], 900);  // the step is taken at once: no ghosting
}

TEST(Kalman, ResetsOnInvalidAndRestartsFromTheNewValue) {
  KalmanFilter k;
  DepthImage d(1, 1);
  d.pixels[0] = 1500;
  k.apply(d);
  d.pixels[0] = 0;
  k.apply(d);
  EXPECT_EQ(d.pixels[0], 0);
  d.pixels[0] = 1490;
  k.apply(d);
  EXPECT_EQ(d.pixels[0], 1490);
}

TEST(Kalman, ReducesTemporalNoiseOnRealStaticPixels) {
  // The hands sequence: pixels that never move more than 30 mm are static background (table).
  const auto frames = test::real_depth_frames("hands");
  KalmanFilter k;
  std::vector<double> raw_var, out_var;
  const size_t n = frames[0].size();
  std::vector<double> s1(n), s2(n), o1(n), o2(n);
  std::vector<uint16_t> lo(n, 65535), hi(n, 0);
  const int count = 60;
  for (int f = 0; f < count; ++f) {
    DepthImage d = frames[static_cast<size_t>(f)];
    k.apply(d);
    for (size_t i = 0; i < n; ++i) {
      const double r = frames[static_cast<size_t>(f)].pixels[i], o = d.pixels[i];
      s1[i] += r, s2[i] += r * r, o1[i] += o, o2[i] += o * o;
      lo[i] = std::min(lo[i], frames[static_cast<size_t>(f)].pixels[i]);
      hi[i] = std::max(hi[i], frames[static_cast<size_t>(f)].pixels[i]);
    }
  }
  double raw_noise = 0, out_noise = 0;
  size_t statics = 0;
  for (size_t i = 0; i < n; ++i) {
    if (lo[i] == 0 || hi[i] - lo[i] > 30) continue;
    raw_noise += std::sqrt(s2[i] / count - std::pow(s1[i] / count, 2));
    out_noise += std::sqrt(std::max(0.0, o2[i] / count - std::pow(o1[i] / count, 2)));
    ++statics;
  }
  ASSERT_GT(statics, n / 10);
  EXPECT_LT(out_noise, raw_noise * 0.8)
      << "raw " << raw_noise / double(statics) << " mm, filtered " << out_noise / double(statics);
}

TEST(LensCorrection, UndistortedPixelsReprojectWithinHalfAPixel) {
  const Intrinsics k = kinect_intrinsics();
  const PixelMap m = make_pixel_map(k, true, std::nullopt);
  ASSERT_TRUE(m.output.is_pinhole());
  size_t mapped = 0;
  for (int v = 0; v < m.output.height; ++v)
    for (int u = 0; u < m.output.width; ++u) {
      const int32_t s = m.map[static_cast<size_t>(v) * m.output.width + u];
      if (s < 0) continue;
      ++mapped;
      // The ideal ray of output pixel (u, v), projected with the original lens model, lands on
      // (within half a pixel of) the source pixel whose depth it took.
      const Eigen::Vector2d xy((u - m.output.cx) / m.output.fx, (v - m.output.cy) / m.output.fy);
      const auto uv = project_normalized(k, xy);
      ASSERT_TRUE(uv);
      ASSERT_LE(std::abs(uv->x() - s % k.width), 0.5 + 1e-9);
      ASSERT_LE(std::abs(uv->y() - s / k.width), 0.5 + 1e-9);
    }
  EXPECT_GT(mapped, m.map.size() * 8 / 10);
}

TEST(Crop, NfovCropGives540x476WithShiftedPrincipalPoint) {
  const Intrinsics k = kinect_intrinsics();
  const PixelMap m = make_pixel_map(k, false, kNfovCrop);
  EXPECT_EQ(m.output.width, 540);
  EXPECT_EQ(m.output.height, 476);
  EXPECT_DOUBLE_EQ(m.output.cx, k.cx - 50);
  EXPECT_DOUBLE_EQ(m.output.k1, k.k1);  // no lens correction: the model is kept
  const DepthImage raw = test::real_depth_frames("kinect")[0];
  DepthImage out;
  apply_pixel_map(m, raw, out);
  EXPECT_EQ(out.at(0, 0), raw.at(50, 50));
  EXPECT_EQ(out.at(539, 475), raw.at(589, 525));
  EXPECT_THROW(make_pixel_map(k, false, CropRect{600, 0, 100, 10}), Error);
}

TEST(Background, LearnedModelRemovesARecordedStaticSceneEntirely) {
  auto src = open_source(test::kinect_mkv());
  BackgroundModel model;
  for (int i = 0; i < 5; ++i) model.learn(src->next().depth);
  DepthImage later = src->next().depth;  // the same static room, later
  model.subtract(later, 30);
  for (uint16_t v : later.pixels) ASSERT_EQ(v, 0);
}

TEST(Background, KeepsWhatIsNearerThanTheBackgroundByTheMargin) {
  BackgroundModel model;
  model.learn(synthetic(4, 1, {2000, 2000, 0, 2000}));  // synthetic empty room
  model.learn(synthetic(4, 1, {1990, 0, 0, 2010}));     // the minimum is kept per pixel
  DepthImage d = synthetic(4, 1, {1950, 1975, 800, 1500});
  model.subtract(d, 30);
  EXPECT_EQ(d.pixels, (std::vector<uint16_t>{1950, 0, 800, 1500}));  // 2000-1975 < 30: dropped
  const auto file = test::temp_dir("bg") / "cam0.png";
  model.save(file);
  EXPECT_EQ(BackgroundModel::load(file).min_depth, model.min_depth);
  DepthImage wrong(3, 1);
  EXPECT_THROW(model.subtract(wrong, 30), Error);
}

TEST(FlyingPixels, RemovesAnIsolatedMidDepthPixelAndKeepsSurfaces) {
  // Synthetic 5x3: foreground 1000 mm on the left, background 2000 mm on the right, and a mixed
  // return of 1500 mm between them.
  DepthImage d = synthetic(5, 3,
                           {1000, 1000, 1500, 2000, 2000,  //
                            1000, 1000, 1500, 2000, 2000,  //
                            1000, 1000, 1500, 2000, 2000});
  FlyingPixelFilter{}.apply(d);
  EXPECT_EQ(d.at(2, 1), 0);
  EXPECT_EQ(d.at(1, 1), 1000);
  EXPECT_EQ(d.at(3, 1), 2000);
}

TEST(FilterConfig, ParsesJsonAndRejectsUnknownFields) {
  FilterConfig c;
  apply_filter_json(R"({"undistort": true, "crop": "nfov", "near_mm": 300, "far_mm": 2500,
                        "hole_fill": {"iterations": 5, "max_spread_mm": 30}, "kalman": true,
                        "flying_pixels": false})",
                    c);
  EXPECT_TRUE(c.undistort);
  EXPECT_EQ(*c.crop, kNfovCrop);
  EXPECT_EQ(c.far_mm, 2500);
  EXPECT_EQ(c.hole_filling->iterations, 5);
  EXPECT_EQ(c.hole_filling->max_spread_mm, 30);
  EXPECT_TRUE(c.kalman.has_value());
  EXPECT_FALSE(c.flying_pixels.has_value());
  EXPECT_THROW(apply_filter_json(R"({"holefill": 3})", c), Error);
  EXPECT_THROW(apply_filter_json(R"({"crop": [1, 2]})", c), Error);
  EXPECT_THROW(apply_filter_json(R"({"near_mm": "close"})", c), Error);
  EXPECT_EQ(parse_crop("10,20,300,200"), (CropRect{10, 20, 300, 200}));
  EXPECT_THROW(parse_crop("10,20"), Error);
}

TEST(FilterChain, RunsTheFullChainOnARealFrameAndAnnouncesItsIntrinsics) {
  auto src = open_source(test::kinect_mkv());
  FilterConfig c = paper_chain_config(640, 576);
  c.near_mm = 300;
  c.far_mm = 3000;
  FilterChain chain(src->calibration().depth, c);
  EXPECT_EQ(chain.output_intrinsics().width, 540);
  EXPECT_TRUE(chain.output_intrinsics().is_pinhole());
  CameraFrame out;
  chain.apply(src->next(), out);
  EXPECT_EQ(out.depth.width, 540);
  EXPECT_EQ(out.color.width, 540);
  for (uint16_t v : out.depth.pixels) ASSERT_TRUE(v == 0 || (v >= 300 && v <= 3000));
  EXPECT_GT(chain.last_timings().us[4], 0.0);
  c.background_file = test::temp_dir("chain") / "missing.png";
  EXPECT_THROW(FilterChain(src->calibration().depth, c), Error);
}

}  // namespace
}  // namespace volcast
