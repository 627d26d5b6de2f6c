// Point-to-plane ICP and its nearest-neighbour search (point_to_plane.hpp), feature matching and
// RANSAC (feature_ransac.hpp), on SYNTHETIC surfaces and matches
// with known answers: the search (over placed parts, and over them merged) against brute force, a
// known rigid offset recovered, the same result whatever the number of threads, the overlap score
// counted, bad input named.
#include "volcast/calibrate/point_to_plane.hpp"

#include <gtest/gtest.h>

#include "volcast/calibrate/feature_ransac.hpp"

#include <Eigen/Geometry>
#include <cmath>
#include <random>

#include "volcast/core/error.hpp"
#include "volcast/core/worker_pool.hpp"

namespace volcast {
namespace {

// SYNTHETIC: a room corner (floor, two walls; 2 cm grid) with a box and a sphere on the floor:
// shape in every direction, so point-to-plane ICP has a unique answer. Normals face +inside.
struct Scene {
  std::vector<Eigen::Vector3d> points, normals;
};

Scene corner_scene() {
  Scene s;
  const auto add = [&](const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
    s.points.push_back(p);
    s.normals.push_back(n.normalized());
  };
  for (double a = 0; a < 2.0; a += 0.02)
    for (double b = 0; b < 2.0; b += 0.02) {
      add({a, 0, b}, {0, 1, 0});  // floor (y = 0)
      add({0, a, b}, {1, 0, 0});  // wall x = 0
      add({a, b, 0}, {0, 0, 1});  // wall z = 0
    }
  for (double a = 0.6; a <= 1.0; a += 0.02)  // a 40 cm box's top and two sides
    for (double b = 0.6; b <= 1.0; b += 0.02) {
      add({a, 0.4, b}, {0, 1, 0});
      add({a, b - 0.6, 1.0}, {0, 0, 1});
      add({1.0, b - 0.6, a}, {1, 0, 0});
    }
  for (int i = 0; i < 40; ++i)  // a 25 cm sphere
    for (int j = 0; j < 40; ++j) {
      const double theta = M_PI * (i + 0.5) / 40, phi = 2 * M_PI * j / 40;
      const Eigen::Vector3d n(std::sin(theta) * std::cos(phi), std::cos(theta),
                              std::sin(theta) * std::sin(phi));
      add(Eigen::Vector3d(1.5, 0.25, 0.5) + 0.25 * n, n);
    }
  return s;
}

Eigen::Matrix4d transform(const Eigen::Vector3d& axis, double deg, const Eigen::Vector3d& t) {
  Eigen::Matrix4d m = Eigen::Matrix4d::Identity();
  m.topLeftCorner<3, 3>() = Eigen::AngleAxisd(deg * M_PI / 180, axis.normalized()).matrix();
  m.topRightCorner<3, 1>() = t;
  return m;
}

double angle_deg(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b) {
  const Eigen::Matrix3d r = a.topLeftCorner<3, 3>().transpose() * b.topLeftCorner<3, 3>();
  return Eigen::AngleAxisd(r).angle() * 180 / M_PI;
}

TEST(PointToPlane, NearestOverPlacedPartsIsTheBruteForceNearestBelowTheBound) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1, 1);
  std::vector<Eigen::Vector3d> a(3000), b(2000);
  for (auto& p : a) p = {u(rng), u(rng), u(rng)};
  for (auto& p : b) p = {u(rng), u(rng), u(rng)};
  const icp::Surface sa(a, {}), sb(b, {});
  icp::Placed pa{&sa}, pb{&sb};
  pb.rotation = Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).matrix();
  pb.translation = {0.3, -0.2, 0.1};
  const std::vector<icp::Placed> target = {pa, pb};
  // The same two surfaces merged into one in the target frame: the same answers from one tree.
  const auto one = icp::merged(target);
  ASSERT_EQ(one->points().size(), 5000u);
  const std::vector<icp::Placed> merged = {{one.get()}};
  int found = 0;
  for (int q = 0; q < 500; ++q) {
    const Eigen::Vector3d x(u(rng), u(rng), u(rng));
    const double bound =
        q % 2 ? 0.01 : 1.0;  // both: often none within 10 cm, always one within 1 m
    double best = bound;
    Eigen::Vector3d best_point = Eigen::Vector3d::Zero();
    for (const auto& p : a)
      if ((p - x).squaredNorm() < best) best = (p - x).squaredNorm(), best_point = p;
    for (const auto& p : b) {
      const Eigen::Vector3d w = pb.rotation * p + pb.translation;
      if ((w - x).squaredNorm() < best) best = (w - x).squaredNorm(), best_point = w;
    }
    icp::Neighbour n;
    const bool hit = icp::nearest(target, x, bound, n);
    ASSERT_EQ(hit, best < bound) << "query " << q;
    if (!hit) continue;
    ++found;
    EXPECT_NEAR(n.d2, best, 1e-12) << "query " << q;
    EXPECT_LT((n.point - best_point).norm(), 1e-9) << "query " << q;
    EXPECT_EQ(n.normal, Eigen::Vector3d::Zero());  // these surfaces have none
    icp::Neighbour m;
    ASSERT_TRUE(icp::nearest(merged, x, bound, m)) << "query " << q;
    EXPECT_NEAR(m.d2, n.d2, 1e-12) << "query " << q;  // rounding differs: frames
  }
  EXPECT_GT(found, 250);  // every 1 m query and some of the 10 cm ones
  EXPECT_LT(found, 500);
}

TEST(PointToPlane, RecoversAKnownOffsetAndTheSameWithAnyNumberOfThreads) {
  const Scene scene = corner_scene();
  const icp::Surface target(scene.points, scene.normals);
  // The source: the scene seen from a camera placed by target_from_source, i.e. source points =
  // source_from_target * scene (every other point, so no point lies exactly on a target point).
  const Eigen::Matrix4d truth = transform({0.3, 1, 0.2}, 12, {0.4, -0.1, 0.25});
  const Eigen::Matrix4d source_from_target = truth.inverse();
  std::vector<Eigen::Vector3d> source;
  for (size_t i = 0; i < scene.points.size(); i += 2)
    source.push_back((source_from_target * scene.points[i].homogeneous()).head<3>());
  // Start 6 cm and 4 degrees off.
  const Eigen::Matrix4d start = transform({1, -1, 0.5}, 4, {0.04, 0.03, -0.03}) * truth;
  const std::vector<icp::Placed> placed = {{&target}};
  icp::Criteria criteria;
  criteria.max_iterations = 60;
  const icp::Fit alone =
      icp::point_to_plane(source, placed, 0.2, start, 0.1, criteria, /*pool=*/nullptr);
  EXPECT_LT((alone.target_from_source.topRightCorner<3, 1>() - truth.topRightCorner<3, 1>()).norm(),
            1e-4);
  EXPECT_LT(angle_deg(alone.target_from_source, truth), 0.01);
  EXPECT_DOUBLE_EQ(alone.fitness, 1.0);
  EXPECT_LT(alone.inlier_rms_m, 1e-4);
  // The same numbers, bit for bit, from a pool of three workers (the fixed split of the sums).
  WorkerPool pool(3);
  const icp::Fit pooled = icp::point_to_plane(source, placed, 0.2, start, 0.1, criteria, &pool);
  EXPECT_EQ(pooled.target_from_source, alone.target_from_source);
  EXPECT_EQ(pooled.fitness, alone.fitness);
  EXPECT_EQ(pooled.inlier_rms_m, alone.inlier_rms_m);
}

TEST(PointToPlane, EvaluateCountsThePointsWithAPartnerWithinTheDistance) {
  std::vector<Eigen::Vector3d> grid;
  for (int x = 0; x < 10; ++x)
    for (int z = 0; z < 10; ++z) grid.push_back({x * 0.1, 0, z * 0.1});
  const icp::Surface target(grid, std::vector<Eigen::Vector3d>(grid.size(), {0, 1, 0}));
  const std::vector<icp::Placed> placed = {{&target}};
  // 100 points 1 cm above the grid's points, 100 points 1 m away from everything.
  std::vector<Eigen::Vector3d> source;
  for (const auto& p : grid) source.push_back(p + Eigen::Vector3d(0, 0.01, 0));
  for (const auto& p : grid) source.push_back(p + Eigen::Vector3d(0, 1.0, 0));
  const icp::Fit f = icp::evaluate(source, placed, 0.03, Eigen::Matrix4d::Identity(), nullptr);
  EXPECT_DOUBLE_EQ(f.fitness, 0.5);
  EXPECT_NEAR(f.inlier_rms_m, 0.01, 1e-12);
  // Placed 1 m lower, the far half has partners and the near half none.
  const icp::Fit lower =
      icp::evaluate(source, placed, 0.03, transform({0, 1, 0}, 0, {0, -1, 0}), nullptr);
  EXPECT_DOUBLE_EQ(lower.fitness, 0.5);
  EXPECT_NEAR(lower.inlier_rms_m, 0.0, 1e-12);
  EXPECT_EQ(icp::evaluate({}, placed, 0.03, Eigen::Matrix4d::Identity(), nullptr).fitness, 0);
}

TEST(PointToPlane, BadInputIsNamed) {
  const std::vector<Eigen::Vector3d> points = {{0, 0, 0}, {1, 0, 0}};
  try {
    icp::Surface bad(points, {{0, 1, 0}});
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("2 points but 1 normals"), std::string::npos) << e.what();
  }
  const icp::Surface no_normals(points, {});
  const std::vector<icp::Placed> placed = {{&no_normals}};
  try {
    icp::point_to_plane(points, placed, 0.1, Eigen::Matrix4d::Identity(), 0.05, {}, nullptr);
    FAIL() << "expected an error";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no normals"), std::string::npos) << e.what();
  }
  const icp::Surface with_normals(points, {{0, 1, 0}, {0, 1, 0}});
  const std::vector<icp::Placed> ok = {{&with_normals}};
  EXPECT_THROW(icp::point_to_plane(points, ok, 0, Eigen::Matrix4d::Identity(), 0.05, {}, nullptr),
               Error);
  // An empty target: no partner anywhere, the start comes back unchanged.
  const icp::Surface empty({}, {});
  const std::vector<icp::Placed> nothing = {{&empty}};
  const Eigen::Matrix4d start = transform({0, 0, 1}, 10, {1, 2, 3});
  const icp::Fit f = icp::point_to_plane(points, nothing, 0.1, start, 0.05, {}, nullptr);
  EXPECT_EQ(f.target_from_source, start);
  EXPECT_EQ(f.fitness, 0);
}

TEST(FeatureRansac, MutualMatchesAndTheFallbackWhenFewAgree) {
  // Features (columns) 0..19 of the source are target features 19..0 plus a little noise; the
  // source has one more feature, nearest to target 0 but not its nearest: not mutual.
  Eigen::MatrixXd s(4, 21), d(4, 20);
  for (int i = 0; i < 20; ++i) {
    d.col(i) = Eigen::Vector4d(i, 2 * i, -i, 0.5 * i);
    s.col(19 - i) = d.col(i) + Eigen::Vector4d::Constant(0.01);
  }
  s.col(20) = d.col(0) + Eigen::Vector4d::Constant(0.3);
  const auto m = icp::match_features(s, d);
  ASSERT_EQ(m.size(), 20u);
  for (const auto& [i, j] : m) EXPECT_EQ(i, 19 - j);
  // Fewer than 9 mutual: every source feature with its nearest, as Open3D falls back.
  Eigen::MatrixXd six(4, 6);
  six << s.leftCols(5), s.col(20);
  const auto few = icp::match_features(six, d);
  ASSERT_EQ(few.size(), 6u);
  EXPECT_EQ(few.back(), std::make_pair(5, 0));
  EXPECT_THROW(icp::match_features(s, Eigen::MatrixXd(3, 4)), Error);
  EXPECT_TRUE(icp::match_features(Eigen::MatrixXd(4, 0), d).empty());
}

TEST(FeatureRansac, MatchesAreTheExactMutualNearestFeatures) {
  // SYNTHETIC: 150 source and 203 target 33-bin histograms (FPFH-like: non-negative, parts of 100;
  // many leaves of the 33-dimensional tree). Every match is the mutual nearest pair by the plain
  // sum of squared differences, and every mutual nearest pair is matched.
  std::mt19937 rng(3);
  std::uniform_real_distribution<double> u(0, 1);
  auto histograms = [&](int n) {
    Eigen::MatrixXd f(33, n);
    for (int c = 0; c < n; ++c)
      for (int part = 0; part < 3; ++part) {
        double sum = 0;
        for (int b = 0; b < 11; ++b) {
          f(11 * part + b, c) = u(rng) * u(rng);
          sum += f(11 * part + b, c);
        }
        f.middleRows(11 * part, 11).col(c) *= 100 / sum;
      }
    return f;
  };
  const Eigen::MatrixXd s = histograms(150), d = histograms(203);
  auto nearest = [](const Eigen::MatrixXd& from, int col, const Eigen::MatrixXd& in) {
    int at = 0;
    double best = std::numeric_limits<double>::infinity();
    for (int c = 0; c < in.cols(); ++c) {
      double d2 = 0;
      for (int r = 0; r < in.rows(); ++r)
        d2 += (from(r, col) - in(r, c)) * (from(r, col) - in(r, c));
      if (d2 < best) best = d2, at = c;
    }
    return at;
  };
  std::vector<std::pair<int, int>> mutual;
  for (int i = 0; i < s.cols(); ++i) {
    const int j = nearest(s, i, d);
    if (nearest(d, j, s) == i) mutual.emplace_back(i, j);
  }
  ASSERT_GE(mutual.size(), 9u);  // no fallback: the mutual pairs themselves
  EXPECT_EQ(icp::match_features(s, d), mutual);
}

TEST(FeatureRansac, FindsTheTransformOfTheInliersAmongWrongMatchesWithAnyThreads) {
  const Scene scene = corner_scene();
  const Eigen::Matrix4d truth = transform({1, 0.2, -0.4}, 35, {0.8, -0.3, 1.1});
  std::mt19937 rng(3);
  std::uniform_int_distribution<size_t> any(0, scene.points.size() - 1);
  icp::Matches m;
  for (int k = 0; k < 400; ++k) {  // 30 % right matches, 70 % wrong ones
    const Eigen::Vector3d& p = scene.points[any(rng)];
    m.source.push_back(p);
    const Eigen::Vector3d& q = k % 10 < 3 ? p : scene.points[any(rng)];
    m.target.push_back((truth * q.homogeneous()).head<3>());
  }
  icp::RansacOptions o;
  o.max_distance_m = 0.03;
  const auto alone = icp::ransac_rigid(m, o, nullptr);
  ASSERT_TRUE(alone);
  EXPECT_LT((alone->target_from_source - truth).norm(), 1e-9);
  EXPECT_GE(alone->inliers, 120u);  // every right match, and wrong ones that land near a target
  EXPECT_NEAR(alone->fitness, static_cast<double>(alone->inliers) / 400, 1e-12);
  WorkerPool pool(3);
  const auto pooled = icp::ransac_rigid(m, o, &pool);
  ASSERT_TRUE(pooled);
  EXPECT_EQ(pooled->target_from_source, alone->target_from_source);
  EXPECT_EQ(pooled->inliers, alone->inliers);
  // Another seed draws other samples and finds the same transform.
  o.seed = 11;
  const auto other = icp::ransac_rigid(m, o, &pool);
  ASSERT_TRUE(other);
  EXPECT_LT((other->target_from_source - truth).norm(), 1e-9);
  // Nothing to draw from; mismatched inputs named.
  icp::Matches two;
  two.source = {{0, 0, 0}, {1, 0, 0}};
  two.target = two.source;
  EXPECT_FALSE(icp::ransac_rigid(two, o, nullptr));
  two.target.pop_back();
  EXPECT_THROW(icp::ransac_rigid(two, o, nullptr), Error);
}

}  // namespace
}  // namespace volcast
