#include "volcast/core/calibration.hpp"

#include <cmath>
#include <limits>

namespace volcast {
namespace {

struct Projection {
  Eigen::Vector2d uv;
  Eigen::Matrix2d jacobian;  // d(uv)/d(xy)
};

// The Brown-Conrady rational model and its Jacobian (see Intrinsics).
std::optional<Projection> project_with_jacobian(const Intrinsics& k, const Eigen::Vector2d& xy) {
  const double xp = xy.x() - k.codx;
  const double yp = xy.y() - k.cody;
  const double r2 = xp * xp + yp * yp;
  if (k.metric_radius > 0 && r2 > k.metric_radius * k.metric_radius) return std::nullopt;
  const double r4 = r2 * r2, r6 = r4 * r2;
  const double a = 1 + k.k1 * r2 + k.k2 * r4 + k.k3 * r6;
  const double b = 1 + k.k4 * r2 + k.k5 * r4 + k.k6 * r6;
  if (b == 0) return std::nullopt;
  const double d = a / b;
  const double xd = xp * d + (r2 + 2 * xp * xp) * k.p2 + 2 * xp * yp * k.p1 + k.codx;
  const double yd = yp * d + (r2 + 2 * yp * yp) * k.p1 + 2 * xp * yp * k.p2 + k.cody;

  const double da = k.k1 + 2 * k.k2 * r2 + 3 * k.k3 * r4;
  const double db = k.k4 + 2 * k.k5 * r2 + 3 * k.k6 * r4;
  const double dd_dr2 = (da * b - a * db) / (b * b);
  Projection out;
  out.uv = {k.fx * xd + k.cx, k.fy * yd + k.cy};
  out.jacobian(0, 0) = k.fx * (d + 2 * xp * xp * dd_dr2 + 6 * xp * k.p2 + 2 * yp * k.p1);
  out.jacobian(0, 1) = k.fx * (2 * xp * yp * dd_dr2 + 2 * yp * k.p2 + 2 * xp * k.p1);
  out.jacobian(1, 0) = k.fy * (2 * xp * yp * dd_dr2 + 2 * xp * k.p1 + 2 * yp * k.p2);
  out.jacobian(1, 1) = k.fy * (d + 2 * yp * yp * dd_dr2 + 6 * yp * k.p1 + 2 * xp * k.p2);
  return out;
}

}  // namespace

std::optional<Eigen::Vector2d> project_normalized(const Intrinsics& k, const Eigen::Vector2d& xy) {
  auto p = project_with_jacobian(k, xy);
  if (!p) return std::nullopt;
  return p->uv;
}

std::optional<Eigen::Vector2d> unproject_pixel(const Intrinsics& k, const Eigen::Vector2d& uv) {
  if (k.fx <= 0 || k.fy <= 0) return std::nullopt;
  // Closed-form first guess: invert the radial term at the distorted radius and correct the
  // tangential terms approximately (the SDK's transformation_unproject_internal).
  const double xp_d = (uv.x() - k.cx) / k.fx - k.codx;
  const double yp_d = (uv.y() - k.cy) / k.fy - k.cody;
  if (k.is_pinhole()) return Eigen::Vector2d(xp_d, yp_d);
  const double r2 = xp_d * xp_d + yp_d * yp_d, r4 = r2 * r2, r6 = r4 * r2;
  const double a = 1 + k.k1 * r2 + k.k2 * r4 + k.k3 * r6;
  const double b = 1 + k.k4 * r2 + k.k5 * r4 + k.k6 * r6;
  const double di = (a != 0 ? 1 / a : 1) * b;
  Eigen::Vector2d xy(xp_d * di, yp_d * di);
  const double two_xy = 2 * xy.x() * xy.y(), xx = xy.x() * xy.x(), yy = xy.y() * xy.y();
  xy.x() -= (yy + 3 * xx) * k.p2 + two_xy * k.p1;
  xy.y() -= (xx + 3 * yy) * k.p1 + two_xy * k.p2;
  xy += Eigen::Vector2d(k.codx, k.cody);

  // Newton iterations on the forward model, keeping the best estimate.
  Eigen::Vector2d best = xy;
  double best_err = std::numeric_limits<double>::max();
  for (int pass = 0; pass < 20; ++pass) {
    auto p = project_with_jacobian(k, xy);
    if (!p) return std::nullopt;
    const Eigen::Vector2d err = uv - p->uv;
    const double e = err.squaredNorm();
    if (e >= best_err) break;
    best_err = e;
    best = xy;
    if (e < 1e-22) break;
    const double det = p->jacobian.determinant();
    if (det == 0 || !std::isfinite(det)) break;
    xy += p->jacobian.inverse() * err;
  }
  if (!(best_err <= 1e-6)) return std::nullopt;
  return best;
}

}  // namespace volcast
