// The lattice target (target.hpp): detection in one depth image and the least-squares solve over
// captures. All images here are SYNTHETIC (render_sim_depth: exact behaviour, with Azure
// Kinect-like noise), rendered through the genuine Azure Kinect recording's NFOV lens model.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <algorithm>
#include <cstdio>

#include "support/test_data.hpp"
#include "volcast/calibrate/target.hpp"
#include "volcast/calibrate/target_sim.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

const Intrinsics& nfov() {
  static const Intrinsics k = open_source(test::kinect_mkv())->calibration().depth;
  return k;
}

const RayTable& nfov_rays() {
  static const RayTable rays = make_ray_table(nfov());
  return rays;
}

RigidTransform looking(const Eigen::Vector3d& eye, const Eigen::Vector3d& target,
                       double roll_deg = 0) {
  return camera_looking_at(eye, target, roll_deg);
}

// The camera `distance_m` from the middle of the spheres, `yaw_deg` around it, looking down
// `pitch_deg`.
RigidTransform around(double distance_m, double yaw_deg, double pitch_deg, double roll_deg = 0) {
  const Eigen::Vector3d middle(0, 1.2, 0);
  const double a = yaw_deg * M_PI / 180, p = pitch_deg * M_PI / 180;
  const Eigen::Vector3d eye =
      middle + distance_m * Eigen::Vector3d(std::sin(a) * std::cos(p), std::sin(p),
                                            std::cos(a) * std::cos(p));
  return looking(eye, middle, roll_deg);
}

struct PoseError {
  double translation_mm, rotation_deg;
};

PoseError error(const RigidTransform& got, const RigidTransform& truth) {
  return {(got.translation - truth.translation).norm() * 1e3,
          Eigen::AngleAxisd(got.rotation.transpose() * truth.rotation).angle() * 180 / M_PI};
}

TEST(LatticeTarget, EveryPairOfSpheresHasItsOwnDistance) {
  const TargetModel m = lattice_target();
  ASSERT_EQ(m.centres_m.size(), 5u);
  std::vector<double> d;
  for (size_t i = 0; i < m.centres_m.size(); ++i)
    for (size_t j = i + 1; j < m.centres_m.size(); ++j)
      d.push_back((m.centres_m[i] - m.centres_m[j]).norm());
  std::sort(d.begin(), d.end());
  for (size_t i = 1; i < d.size(); ++i) EXPECT_GE(d[i] - d[i - 1], 0.040);
  EXPECT_GT(d.front(), 2 * m.sphere_radius_m + 0.1);  // no two balls touch or hide each other
}

TEST(LatticeTarget, ExactImagesGiveSubMillimetrePoses) {
  SimScene scene;
  scene.target = lattice_target();
  const DepthNoise none{0, 0, 0, 0, 0, 1};
  for (double yaw : {0.0, 70.0, 160.0, 250.0}) {
    const RigidTransform w = around(2.0, yaw, 25);
    const TargetDetection d =
        detect_target(render_sim_depth(nfov(), w, scene, none), nfov_rays(), scene.target);
    ASSERT_TRUE(d.found) << "yaw " << yaw << ": " << d.why_not;
    const PoseError e = error(d.camera_from_target, w.inverse() * scene.world_from_target);
    EXPECT_LT(e.translation_mm, 1.0) << "yaw " << yaw;
    EXPECT_LT(e.rotation_deg, 0.05) << "yaw " << yaw;
  }
}

TEST(LatticeTarget, NoisyImagesMeetTheAccuracyGoal) {
  // Goal (issue 12, after Muehlenbrock et al. 2022): <= 2 mm and <= 0.2 deg at 2 m. The pose is
  // the target frame's (on the floor below the spheres), so a rotation error moves it too.
  SimScene scene;
  scene.target = lattice_target();
  struct Case {
    double distance, yaw, pitch, roll;
  };
  const Case cases[] = {{0.8, 10, 10, 0},   {0.8, 200, 20, 0},   {1.2, 40, 15, 0},
                        {1.2, 120, 30, 90}, {2.0, 0, 20, 0},     {2.0, 70, 35, 0},
                        {2.0, 150, 10, 90}, {2.0, 250, 40, -30}, {3.0, 30, 20, 0},
                        {3.0, 190, 30, 90}};
  uint32_t seed = 1;
  for (const Case& c : cases) {
    DepthNoise noise;
    noise.seed = seed++;
    const RigidTransform w = around(c.distance, c.yaw, c.pitch, c.roll);
    const TargetDetection d =
        detect_target(render_sim_depth(nfov(), w, scene, noise), nfov_rays(), scene.target);
    ASSERT_TRUE(d.found) << c.distance << " m, yaw " << c.yaw << ": " << d.why_not;
    const PoseError e = error(d.camera_from_target, w.inverse() * scene.world_from_target);
    double worst_centre = 0;  // mm
    for (const FoundSphere& s : d.spheres)
      if (s.model_index >= 0)
        worst_centre = std::max(
            worst_centre,
            (w * s.centre_m - scene.target.centres_m[static_cast<size_t>(s.model_index)]).norm() *
                1e3);
    std::printf(
        "%.1f m yaw %3.0f pitch %2.0f roll %3.0f: %d spheres, %.2f mm, %.3f deg (worst centre "
        "%.2f mm, RMS %.2f mm)\n",
        c.distance, c.yaw, c.pitch, c.roll, d.matched, e.translation_mm, e.rotation_deg,
        worst_centre, d.rms_m * 1e3);
    // Up to 2 m the goal; at 3 m (noise sigma 4.4 mm, a ball ~25 px wide) 3 mm and 0.2 deg.
    const bool far = c.distance > 2.5;
    EXPECT_LE(e.translation_mm, far ? 3.0 : 2.0) << c.distance << " m, yaw " << c.yaw;
    EXPECT_LE(e.rotation_deg, 0.2) << c.distance << " m, yaw " << c.yaw;
    EXPECT_GE(d.matched, 3);
  }
}

TEST(LatticeTarget, NothingToFindIsSaidNotGuessed) {
  SimScene empty;  // floor only
  empty.target = lattice_target();
  empty.target.centres_m.clear();
  empty.target.rods_m.clear();
  DepthNoise noise;
  const RigidTransform w = around(2.0, 30, 25);
  const TargetDetection d =
      detect_target(render_sim_depth(nfov(), w, empty, noise), nfov_rays(), lattice_target());
  EXPECT_FALSE(d.found);
  EXPECT_NE(d.why_not.find("0 of 5"), std::string::npos) << d.why_not;
}

TEST(LatticeTarget, TwoSpheresInViewAreNotEnough) {
  // A camera 0.75 m in front of the two low spheres, looking down at them: the three high ones
  // (0.4 m higher) are above its field of view.
  SimScene scene;
  scene.target = lattice_target();
  const RigidTransform w = looking({-0.22, 1.0, 0.75}, {-0.22, 0.75, 0});
  const TargetDetection d = detect_target(render_sim_depth(nfov(), w, scene, DepthNoise{}),
                                          nfov_rays(), lattice_target());
  EXPECT_FALSE(d.found);
  EXPECT_NE(d.why_not.find("need 3"), std::string::npos) << d.why_not;
  EXPECT_EQ(d.spheres.size(), 2u) << d.why_not;  // the two in view, both found
  for (const FoundSphere& s : d.spheres) EXPECT_EQ(s.model_index, -1);
}

TEST(LatticeTarget, AHeadBesideTheTargetIsNotOneOfItsSpheres) {
  SimScene scene;
  scene.target = lattice_target();
  // A head (a 90 mm radius ball) 0.5 m beside the target at 1.6 m, and a ball of the target's own
  // size where no target sphere is.
  scene.extra_spheres = {{{0.9, 1.6, 0.2}, 0.09}, {{-0.9, 1.1, -0.1}, 0.075}};
  DepthNoise noise;
  noise.seed = 9;
  const RigidTransform w = around(2.2, 20, 20);
  const TargetDetection d =
      detect_target(render_sim_depth(nfov(), w, scene, noise), nfov_rays(), scene.target);
  ASSERT_TRUE(d.found) << d.why_not;
  const PoseError e = error(d.camera_from_target, w.inverse() * scene.world_from_target);
  EXPECT_LT(e.translation_mm, 2.0);
  EXPECT_LT(e.rotation_deg, 0.2);
  for (const FoundSphere& s : d.spheres) {
    if (s.model_index < 0) continue;
    EXPECT_LT((w * s.centre_m - scene.target.centres_m[static_cast<size_t>(s.model_index)]).norm(),
              0.01);
  }
  // The decoys alone: found as balls perhaps, never as the target.
  SimScene decoys;
  decoys.target = lattice_target();
  decoys.target.centres_m.clear();
  decoys.target.rods_m.clear();
  decoys.extra_spheres = {
      {{0.2, 1.6, 0.2}, 0.09}, {{-0.3, 1.1, -0.1}, 0.075}, {{0.3, 1.0, -0.3}, 0.075}};
  const TargetDetection none =
      detect_target(render_sim_depth(nfov(), w, decoys, noise), nfov_rays(), scene.target);
  EXPECT_FALSE(none.found);
}

TEST(LatticeTarget, ASizeMismatchBetweenImageAndRaysThrows) {
  EXPECT_THROW(detect_target(DepthImage(320, 288), nfov_rays(), lattice_target()), Error);
}

// Three cameras around the target, four placements of it; camera 3 never sees it.
TEST(TargetSolve, FourPlacementsPlaceThreeCamerasAndNameTheFourth) {
  const TargetModel model = lattice_target();
  const RigidTransform cams[] = {around(2.2, 0, 25), around(2.0, 100, 30), around(2.4, 220, 20)};
  std::vector<RigidTransform> placements;
  for (int k = 0; k < 4; ++k) {
    RigidTransform t;
    t.rotation = Eigen::AngleAxisd(0.4 * k, Eigen::Vector3d::UnitY()).toRotationMatrix();
    t.translation = Eigen::Vector3d(0.3 * k - 0.4, 0, 0.2 * (k % 2));
    placements.push_back(t);
  }
  // Camera 2 misses placements 0 and 1 (someone stood in front of it).
  std::vector<TargetObservation> observations;
  uint32_t seed = 20;
  for (int k = 0; k < 4; ++k)
    for (int c = 0; c < 3; ++c) {
      if (c == 2 && k < 2) continue;
      SimScene scene;
      scene.target = model;
      scene.world_from_target = placements[static_cast<size_t>(k)];
      DepthNoise noise;
      noise.seed = seed++;
      const TargetDetection d =
          detect_target(render_sim_depth(nfov(), cams[c], scene, noise), nfov_rays(), model);
      ASSERT_TRUE(d.found) << "camera " << c << " placement " << k << ": " << d.why_not;
      TargetObservation o{c, k, {}};
      for (const FoundSphere& s : d.spheres)
        if (s.model_index >= 0) o.centres.emplace_back(s.model_index, s.centre_m);
      observations.push_back(o);
    }
  const TargetSolution s = solve_target_registration(4, 4, observations, 0);
  for (int c = 0; c < 3; ++c) {
    ASSERT_TRUE(s.world_from_camera[static_cast<size_t>(c)]) << "camera " << c;
    // World = camera 0's frame: compare with camera 0_from_camera c.
    const PoseError e =
        error(*s.world_from_camera[static_cast<size_t>(c)], cams[0].inverse() * cams[c]);
    std::printf("camera %d: %.2f mm, %.3f deg, RMS %.2f mm over %d centres\n", c, e.translation_mm,
                e.rotation_deg, s.rms_m[static_cast<size_t>(c)] * 1e3,
                s.features[static_cast<size_t>(c)]);
    EXPECT_LE(e.translation_mm, 2.0) << "camera " << c;
    EXPECT_LE(e.rotation_deg, 0.2) << "camera " << c;
    EXPECT_LT(s.rms_m[static_cast<size_t>(c)], 0.002);
  }
  EXPECT_FALSE(s.world_from_camera[3]);
  ASSERT_EQ(s.problems.size(), 1u);
  EXPECT_NE(s.problems[0].find("camera 3"), std::string::npos) << s.problems[0];
  // The world as the first placement's target frame instead.
  const TargetSolution t = solve_target_registration(4, 4, observations, -1);
  ASSERT_TRUE(t.world_from_camera[1]);
  for (int c = 0; c < 3; ++c) {
    ASSERT_TRUE(t.world_from_camera[static_cast<size_t>(c)]) << "camera " << c;
    const PoseError e =
        error(*t.world_from_camera[static_cast<size_t>(c)], placements[0].inverse() * cams[c]);
    EXPECT_LE(e.translation_mm, 2.0) << "camera " << c;
    EXPECT_LE(e.rotation_deg, 0.2) << "camera " << c;
  }
}

// Exact centres (no images): the solve recovers every pose to 1e-6 m, with the world either the
// reference camera's frame or the lowest capture's target frame, and names what it cannot place.
TEST(TargetSolve, ExactObservationsGiveExactPoses) {
  const TargetModel model = lattice_target();
  const RigidTransform cams[] = {around(2.0, 10, 20), around(2.5, 130, 30, 15),
                                 around(1.8, 250, 25), around(2.0, 300, 20)};
  std::vector<RigidTransform> placements;
  for (int k = 0; k < 3; ++k) {
    RigidTransform t;
    t.rotation = Eigen::AngleAxisd(1.1 * k, Eigen::Vector3d::UnitY()).toRotationMatrix();
    t.translation = Eigen::Vector3d(0.5 * k, 0, -0.3 * k);
    placements.push_back(t);
  }
  // Captures 1 (cameras 0, 1), 2 (cameras 1, 2) chain the cameras; capture 0 is camera 3's alone.
  const std::pair<int, int> seen[] = {{0, 1}, {1, 1}, {1, 2}, {2, 2}, {3, 0}};
  std::vector<TargetObservation> observations;
  for (const auto& [c, k] : seen) {
    TargetObservation o{c, k, {}};
    for (int j = 0; j < 5; ++j)
      if ((j + c + k) % 5 != 0)  // each misses one sphere
        o.centres.emplace_back(j, cams[c].inverse() * placements[static_cast<size_t>(k)] *
                                      model.centres_m[static_cast<size_t>(j)]);
    observations.push_back(o);
  }
  const TargetSolution s = solve_target_registration(5, 3, observations, 1);
  for (int c = 0; c < 3; ++c) {
    ASSERT_TRUE(s.world_from_camera[static_cast<size_t>(c)]) << "camera " << c;
    EXPECT_LT(error(*s.world_from_camera[static_cast<size_t>(c)], cams[1].inverse() * cams[c])
                  .translation_mm,
              1e-3);
    EXPECT_LT(s.rms_m[static_cast<size_t>(c)], 1e-6);
  }
  EXPECT_EQ(s.features[1], 8);
  EXPECT_FALSE(s.world_from_camera[3]);
  EXPECT_FALSE(s.world_from_camera[4]);
  EXPECT_FALSE(s.world_from_target[0]);
  ASSERT_EQ(s.problems.size(), 2u);
  EXPECT_NE(s.problems[0].find("camera 3: saw the target only in captures"), std::string::npos)
      << s.problems[0];
  EXPECT_NE(s.problems[1].find("camera 4: never saw the target"), std::string::npos)
      << s.problems[1];
  // Without a reference camera the world is capture 1's target frame: capture 0 comes first, but
  // only camera 3 saw it, and captures 1 and 2 join three cameras.
  const TargetSolution t = solve_target_registration(5, 3, observations);
  ASSERT_TRUE(t.world_from_target[1]);
  EXPECT_LT(error(*t.world_from_target[1], RigidTransform{}).translation_mm, 1e-9);
  for (int c = 0; c < 3; ++c) {
    ASSERT_TRUE(t.world_from_camera[static_cast<size_t>(c)]) << "camera " << c;
    EXPECT_LT(error(*t.world_from_camera[static_cast<size_t>(c)], placements[1].inverse() * cams[c])
                  .translation_mm,
              1e-3);
  }
  EXPECT_FALSE(t.world_from_camera[3]);
  EXPECT_FALSE(t.world_from_target[0]);
}

TEST(TargetSolve, OutOfRangeIndicesThrow) {
  std::vector<TargetObservation> bad = {{5, 0, {}}};
  EXPECT_THROW(solve_target_registration(2, 1, bad, 0), Error);
  bad = {{0, 3, {}}};
  EXPECT_THROW(solve_target_registration(2, 1, bad, 0), Error);
  EXPECT_THROW(solve_target_registration(2, 1, {}, 4), Error);
  bad = {{0, 0, {{7, Eigen::Vector3d(0, 0, 2)}}}};  // the model has 5 spheres
  EXPECT_THROW(solve_target_registration(2, 1, bad, 0), Error);
}

}  // namespace
}  // namespace volcast
