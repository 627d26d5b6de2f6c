// Sphere centres by Hough voting: every depth sample votes for the point one model radius behind it
// along its surface normal. On a sphere of that radius the votes meet in one spot; on planes, rods
// and other balls they spread over a surface, a tube or a smaller sphere. Each cluster of votes is
// then fitted by least squares on the samples near it (a band of ~3 sigma of the depth noise; the
// silhouette's grazing ring and samples beside anything off the sphere, where flying pixels are,
// left out), checked (free radius, residual,
// coverage), and the checked spheres are matched to the model by their pairwise distances;
// Kabsch over the matched centres gives camera_from_target.
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <optional>

#include "volcast/calibrate/target.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

constexpr int kStride = 2;           // vote with every 2nd pixel in x and y
constexpr int kNormalStep = 3;       // normal from neighbours 3 pixels away
constexpr double kCell = 0.02;       // vote cell, metres
constexpr int kMaxCandidates = 16;   // vote peaks fitted, strongest first
constexpr int kMaxSpheres = 12;      // checked spheres matched to the model, most samples first
constexpr double kMinFacing = 0.35;  // a fitted sample's cos(ray, sphere normal) must exceed this
constexpr int kHashBits = 18;        // vote table: 2^18 cells (3 MB), reused between calls

// Depth noise band (metres) at depth z: ~3 sigma of an Azure Kinect-class ToF camera
// (sigma ~ 1 mm + 0.5 mm/m^2 z^2) plus 1 mm of quantisation.
double band_at(double z) {
  return 0.004 + 0.0015 * z * z;
}

// Open-addressing hash of vote counts per cell, cleared by generation so that nothing is
// allocated or zeroed per call.
struct VoteTable {
  static constexpr size_t kSize = size_t{1} << kHashBits;
  std::vector<uint64_t> keys = std::vector<uint64_t>(kSize, 0);
  std::vector<uint32_t> generation = std::vector<uint32_t>(kSize, 0);
  std::vector<int> counts = std::vector<int>(kSize, 0);
  std::vector<uint32_t> used;  // slots filled in this generation
  uint32_t now = 1;

  void clear() {
    used.clear();
    if (++now == 0) {  // wrapped: forget every slot for real
      std::fill(generation.begin(), generation.end(), 0);
      now = 1;
    }
  }
  static size_t slot(uint64_t k) { return (k * 0x9E3779B97F4A7C15ull) >> (64 - kHashBits); }
  // Adds a vote; false when the table is too full to take a new cell.
  bool add(uint64_t k) {
    for (size_t i = slot(k);; i = (i + 1) & (kSize - 1)) {
      if (generation[i] != now) {
        if (used.size() > kSize / 2) return false;
        generation[i] = now;
        keys[i] = k;
        counts[i] = 1;
        used.push_back(static_cast<uint32_t>(i));
        return true;
      }
      if (keys[i] == k) {
        ++counts[i];
        return true;
      }
    }
  }
  int find(uint64_t k) const {
    for (size_t i = slot(k);; i = (i + 1) & (kSize - 1)) {
      if (generation[i] != now) return 0;
      if (keys[i] == k) return counts[i];
    }
  }
};

struct Candidate {
  Eigen::Vector3d centre;
  int votes = 0;
};

// Buffers reused between calls (per thread): nothing is allocated per pixel.
struct Workspace {
  std::vector<Eigen::Vector3f> points;  // per pixel, camera frame, metres; z = 0 where invalid
  VoteTable votes;
  std::vector<Candidate> candidates;
  std::vector<Eigen::Vector3d> kept;
  std::vector<Eigen::Vector3d> sample;
};

uint64_t key_of(int64_t ix, int64_t iy, int64_t iz) {
  const auto q = [](int64_t v) { return static_cast<uint64_t>(v + (1 << 20)) & 0x1FFFFF; };
  return q(ix) | (q(iy) << 21) | (q(iz) << 42);
}

uint64_t key(const Eigen::Vector3d& c) {
  return key_of(static_cast<int64_t>(std::floor(c.x() / kCell)),
                static_cast<int64_t>(std::floor(c.y() / kCell)),
                static_cast<int64_t>(std::floor(c.z() / kCell)));
}

Eigen::Vector3d cell_centre(uint64_t k) {
  const auto d = [](uint64_t v) {
    return (static_cast<double>(static_cast<int64_t>(v & 0x1FFFFF) - (1 << 20)) + 0.5) * kCell;
  };
  return {d(k), d(k >> 21), d(k >> 42)};
}

// Least squares sphere through `pts`: Gauss-Newton on the centre (and the radius when `free`) from
// the given start. Returns the RMS of the radial residuals, metres.
double fit_sphere(const std::vector<Eigen::Vector3d>& pts, bool free, Eigen::Vector3d& centre,
                  double& radius) {
  for (int it = 0; it < 12; ++it) {
    Eigen::Matrix4d jtj = Eigen::Matrix4d::Zero();
    Eigen::Vector4d jtr = Eigen::Vector4d::Zero();
    for (const auto& p : pts) {
      const Eigen::Vector3d d = p - centre;
      const double n = d.norm();
      if (n < 1e-9) continue;
      Eigen::Vector4d j;
      j << -d / n, -1;
      jtj += j * j.transpose();
      jtr += j * (n - radius);
    }
    Eigen::Vector4d step = Eigen::Vector4d::Zero();
    if (free) {
      step = jtj.ldlt().solve(-jtr);
    } else {
      step.head<3>() = jtj.topLeftCorner<3, 3>().ldlt().solve(-jtr.head<3>());
    }
    if (!step.allFinite()) break;
    centre += step.head<3>();
    radius += step(3);
    if (step.norm() < 1e-8) break;
  }
  double sum = 0;
  for (const auto& p : pts) sum += std::pow((p - centre).norm() - radius, 2);
  return pts.empty() ? 0 : std::sqrt(sum / static_cast<double>(pts.size()));
}

struct Match {
  std::vector<int> current, best;  // per found sphere: model index or -1
  int best_count = 0;
  double best_rms = 0;
};

// RMS of the Kabsch fit of the model centres onto the found ones under `assignment`.
double assignment_rms(const std::vector<FoundSphere>& found, const TargetModel& model,
                      const std::vector<int>& assignment, int count, RigidTransform* pose) {
  Eigen::Matrix3Xd from(3, count), to(3, count);
  long col = 0;
  for (size_t i = 0; i < found.size(); ++i) {
    if (assignment[i] < 0) continue;
    from.col(col) = model.centres_m[static_cast<size_t>(assignment[i])];
    to.col(col) = found[i].centre_m;
    ++col;
  }
  const Eigen::Matrix4d m = Eigen::umeyama(from, to, false);
  const RigidTransform t{m.topLeftCorner<3, 3>(), m.topRightCorner<3, 1>()};
  double sum = 0;
  for (long i = 0; i < col; ++i)
    sum += (t * Eigen::Vector3d(from.col(i)) - Eigen::Vector3d(to.col(i))).squaredNorm();
  if (pose) *pose = t;
  return std::sqrt(sum / static_cast<double>(col));
}

// Depth-first search over assignments found sphere -> model sphere (or none) whose pairwise
// distances all agree within `tolerance`; keeps the largest, ties broken by the lowest RMS.
void match(const std::vector<FoundSphere>& found, const TargetModel& model, double tolerance,
           size_t i, int count, Match& m) {
  if (i == found.size()) {
    if (count < 3 || count < m.best_count) {
      if (count > m.best_count) {  // fewer than 3: nothing to fit, just the count
        m.best_count = count;
        m.best = m.current;
      }
      return;
    }
    const double rms = assignment_rms(found, model, m.current, count, nullptr);
    if (count > m.best_count || rms < m.best_rms) {
      m.best_count = count;
      m.best_rms = rms;
      m.best = m.current;
    }
    return;
  }
  // Bound: even matching every remaining candidate cannot reach the best.
  if (count + static_cast<int>(found.size() - i) < m.best_count) return;
  for (size_t j = 0; j < model.centres_m.size(); ++j) {
    bool ok = true;
    for (size_t k = 0; k < i && ok; ++k) {
      const int mk = m.current[k];
      if (mk < 0) continue;
      if (mk == static_cast<int>(j)) {
        ok = false;
      } else {
        const double seen = (found[i].centre_m - found[k].centre_m).norm();
        const double want = (model.centres_m[j] - model.centres_m[static_cast<size_t>(mk)]).norm();
        ok = std::abs(seen - want) <= tolerance;
      }
    }
    if (!ok) continue;
    m.current[i] = static_cast<int>(j);
    match(found, model, tolerance, i + 1, count + 1, m);
  }
  m.current[i] = -1;
  match(found, model, tolerance, i + 1, count, m);
}

// A pinhole approximation of the lens near the image centre, to size pixel boxes and caps.
struct CentreLens {
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

// The depth samples in [min_depth_m, max_depth_m] as points in the camera frame (metres), per
// pixel; zero where invalid.
void back_project(const DepthImage& depth, const RayTable& rays, const TargetDetectOptions& o,
                  std::vector<Eigen::Vector3f>& points) {
  points.assign(depth.size(), Eigen::Vector3f::Zero());
  const float min_mm = static_cast<float>(o.min_depth_m * 1000);
  const float max_mm = static_cast<float>(o.max_depth_m * 1000);
  for (size_t i = 0; i < depth.size(); ++i) {
    const float mm = depth.pixels[i];
    if (mm < min_mm || mm > max_mm || !std::isfinite(rays.x[i]) || !std::isfinite(rays.y[i]))
      continue;
    const float z = mm * 1e-3f;
    points[i] = Eigen::Vector3f(rays.x[i] * z, rays.y[i] * z, z);
  }
}

// The lens at the image centre from the ray table; nullopt where it has no rays there.
std::optional<CentreLens> centre_lens(const RayTable& rays, int w, int h) {
  const size_t mid = static_cast<size_t>(h / 2) * w + w / 2;
  CentreLens l;
  l.fx = 1.0 / static_cast<double>(rays.x[mid + 1] - rays.x[mid]);
  l.fy = 1.0 / static_cast<double>(rays.y[mid + w] - rays.y[mid]);
  l.cx = w / 2 - rays.x[mid] * l.fx, l.cy = h / 2 - rays.y[mid] * l.fy;
  if (!std::isfinite(l.fx) || !std::isfinite(l.fy) || !std::isfinite(l.cx) ||
      !std::isfinite(l.cy) || l.fx <= 0 || l.fy <= 0)
    return std::nullopt;
  return l;
}

// The back-projected image: a point per pixel (z = 0 where invalid).
struct PointGrid {
  const std::vector<Eigen::Vector3f>& points;
  int w, h;
  const Eigen::Vector3f& at(int x, int y) const { return points[static_cast<size_t>(y) * w + x]; }
};

// 1. Votes: each sample's normal (from neighbours kNormalStep pixels away, toward the camera)
// points from the centre of the sphere it would lie on. Returns false when the vote table filled
// up before every sample voted.
bool cast_votes(const PointGrid& g, double r, VoteTable& votes) {
  votes.clear();
  const int w = g.w, h = g.h;
  for (int y = kNormalStep; y < h - kNormalStep; y += kStride)
    for (int x = kNormalStep; x < w - kNormalStep; x += kStride) {
      const Eigen::Vector3f& p = g.at(x, y);
      if (p.z() == 0) continue;
      const Eigen::Vector3f &l = g.at(x - kNormalStep, y), &rr = g.at(x + kNormalStep, y),
                            &u = g.at(x, y - kNormalStep), &d = g.at(x, y + kNormalStep);
      if (l.z() == 0 || rr.z() == 0 || u.z() == 0 || d.z() == 0) continue;
      const float jump = 0.05f * p.z();  // across a depth edge: no normal
      if (std::abs(l.z() - p.z()) > jump || std::abs(rr.z() - p.z()) > jump ||
          std::abs(u.z() - p.z()) > jump || std::abs(d.z() - p.z()) > jump)
        continue;
      Eigen::Vector3f n = (rr - l).cross(d - u);
      const float len = n.norm();
      if (len < 1e-12f) continue;
      n /= len;
      if (n.dot(p) > 0) n = -n;
      if (!votes.add(key((p - n * static_cast<float>(r)).cast<double>()))) return false;
    }
  return true;
}

// 2. Peaks: the vote mass of each cell's 3x3x3 neighbourhood against what a sphere's visible cap
// would cast at that depth; strongest first, one per model radius, into ws.kept.
void find_peaks(const CentreLens& lens, double r, const TargetDetectOptions& o, Workspace& ws) {
  ws.candidates.clear();
  for (const uint32_t slot : ws.votes.used) {
    if (ws.votes.counts[slot] < 3) continue;
    const uint64_t k = ws.votes.keys[slot];
    const Eigen::Vector3d c = cell_centre(k);
    if (c.z() < o.min_depth_m) continue;
    const int64_t ix = static_cast<int64_t>(std::floor(c.x() / kCell)),
                  iy = static_cast<int64_t>(std::floor(c.y() / kCell)),
                  iz = static_cast<int64_t>(std::floor(c.z() / kCell));
    int sum = 0;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int dz = -1; dz <= 1; ++dz)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dx = -1; dx <= 1; ++dx) {
          const int n = ws.votes.find(key_of(ix + dx, iy + dy, iz + dz));
          sum += n;
          mean += (c + Eigen::Vector3d(dx, dy, dz) * kCell) * n;
        }
    const double pixel_m = c.z() / lens.fx;  // a depth pixel's footprint there, metres
    const double cap = M_PI * std::pow(r / pixel_m, 2) / (kStride * kStride);
    if (sum < std::max(8.0, 0.15 * cap)) continue;
    ws.candidates.push_back({mean / sum, sum});
  }
  std::sort(ws.candidates.begin(), ws.candidates.end(),
            [](const Candidate& a, const Candidate& b) { return a.votes > b.votes; });
  ws.kept.clear();
  for (const Candidate& c : ws.candidates) {
    if (std::any_of(ws.kept.begin(), ws.kept.end(),
                    [&](const Eigen::Vector3d& k) { return (k - c.centre).norm() < r; }))
      continue;
    ws.kept.push_back(c.centre);
    if (ws.kept.size() >= kMaxCandidates) break;
  }
}

// The samples within `band` of the sphere (`centre`, radius r) in its pixel box, into `sample`;
// after the first pass only those facing the camera whose 4-neighbours are invalid or on the
// sphere too.
void gather_band(const PointGrid& g, const CentreLens& lens, double r,
                 const Eigen::Vector3d& centre, double band, int pass, double u, double v,
                 std::vector<Eigen::Vector3d>& sample) {
  const int w = g.w, h = g.h;
  const double zc = centre.z();
  const int half_x = static_cast<int>(std::ceil((r + 0.03) / zc * lens.fx * 1.2)) + 4;
  const int half_y = static_cast<int>(std::ceil((r + 0.03) / zc * lens.fy * 1.2)) + 4;
  sample.clear();
  const int x0 = std::max(0, static_cast<int>(u) - half_x),
            x1 = std::min(w, static_cast<int>(u) + half_x);
  const int y0 = std::max(0, static_cast<int>(v) - half_y),
            y1 = std::min(h, static_cast<int>(v) + half_y);
  for (int y = y0; y < y1; ++y)
    for (int x = x0; x < x1; ++x) {
      const Eigen::Vector3f& pf = g.at(x, y);
      if (pf.z() == 0) continue;
      const Eigen::Vector3d p = pf.cast<double>();
      const Eigen::Vector3d d = p - centre;
      const double dn = d.norm();
      if (std::abs(dn - r) >= band) continue;
      // Only where the surface faces the camera: the silhouette's ring is noisy and holds the
      // flying pixels mixed with the background.
      if (pass > 0 && -d.dot(p) < kMinFacing * dn * p.norm()) continue;
      // Nor next to anything off the sphere (an occluding edge, the rod, a flying pixel): each
      // 4-neighbour is invalid or on the sphere too.
      if (pass > 0) {
        const auto on = [&](int nx, int ny) {
          if (nx < 0 || ny < 0 || nx >= w || ny >= h) return true;
          const Eigen::Vector3f& q = g.at(nx, ny);
          return q.z() == 0 || std::abs((q.cast<double>() - centre).norm() - r) < band;
        };
        if (!on(x - 1, y) || !on(x + 1, y) || !on(x, y - 1) || !on(x, y + 1)) continue;
      }
      sample.push_back(p);
    }
}

// 3. Fits a candidate on the samples near its surface (a shrinking band), then checks it: its
// free radius, the share of the facing cap it covers, its RMS. nullopt if it is no target sphere.
std::optional<FoundSphere> fit_candidate(const PointGrid& g, const CentreLens& lens, double r,
                                         const TargetDetectOptions& o, Eigen::Vector3d centre,
                                         std::vector<Eigen::Vector3d>& sample) {
  FoundSphere s;
  double radius = r;
  for (int pass = 0; pass < 4; ++pass) {
    const double zc = centre.z();
    if (zc < 0.1) return std::nullopt;
    const double band = pass == 0 ? 0.03 : pass == 1 ? 0.015 : band_at(zc);
    const double u = centre.x() / zc * lens.fx + lens.cx, v = centre.y() / zc * lens.fy + lens.cy;
    if (!(std::abs(u) < 1e6 && std::abs(v) < 1e6)) return std::nullopt;
    gather_band(g, lens, r, centre, band, pass, u, v, sample);
    if (sample.size() < 12) return std::nullopt;
    radius = r;
    s.rms_m = fit_sphere(sample, false, centre, radius);
  }
  if (!centre.allFinite()) return std::nullopt;
  s.centre_m = centre;
  s.inliers = static_cast<int>(sample.size());
  Eigen::Vector3d free_centre = centre;
  s.radius_m = r;
  fit_sphere(sample, true, free_centre, s.radius_m);
  // Coverage: the samples must fill a fair part of the facing cap (pixels of the disc within
  // kMinFacing of the silhouette: 1 - kMinFacing^2 of its area).
  const double pixel_m = centre.z() / std::sqrt(lens.fx * lens.fy);
  const double cap = M_PI * std::pow(r / pixel_m, 2) * (1 - kMinFacing * kMinFacing);
  if (std::abs(s.radius_m - r) > o.radius_tolerance_m || s.inliers < 0.25 * cap ||
      s.rms_m > band_at(centre.z()))
    return std::nullopt;
  return s;
}

}  // namespace

TargetDetection detect_target(const DepthImage& depth, const RayTable& rays,
                              const TargetModel& model, const TargetDetectOptions& o) {
  if (depth.width != rays.width || depth.height != rays.height ||
      depth.pixels.size() != static_cast<size_t>(depth.width) * depth.height ||
      rays.x.size() != depth.pixels.size() || rays.y.size() != depth.pixels.size())
    throw Error("detect_target: depth is " + std::to_string(depth.width) + "x" +
                std::to_string(depth.height) + " but the ray table is " +
                std::to_string(rays.width) + "x" + std::to_string(rays.height));
  TargetDetection out;
  const double r = model.sphere_radius_m;
  if (!(r > 0) || model.centres_m.size() < 3)
    throw Error("detect_target: the model needs a positive sphere radius and >= 3 spheres");
  const int w = depth.width, h = depth.height;
  if (w < 2 * kNormalStep + 2 || h < 2 * kNormalStep + 2) {
    out.why_not = "the depth image is too small";
    return out;
  }
  thread_local Workspace ws;
  back_project(depth, rays, o, ws.points);
  const std::optional<CentreLens> lens = centre_lens(rays, w, h);
  if (!lens) {
    out.why_not = "the ray table has no rays at the image centre";
    return out;
  }
  const PointGrid grid{ws.points, w, h};
  const bool full = !cast_votes(grid, r, ws.votes);
  find_peaks(*lens, r, o, ws);
  for (const Eigen::Vector3d& centre : ws.kept)
    if (const auto s = fit_candidate(grid, *lens, r, o, centre, ws.sample))
      out.spheres.push_back(*s);
  std::sort(out.spheres.begin(), out.spheres.end(),
            [](const FoundSphere& a, const FoundSphere& b) { return a.inliers > b.inliers; });
  if (out.spheres.size() > kMaxSpheres) out.spheres.resize(kMaxSpheres);

  // 4. Match to the model by pairwise distances; Kabsch.
  Match m;
  m.current.assign(out.spheres.size(), -1);
  m.best.assign(out.spheres.size(), -1);
  match(out.spheres, model, o.distance_tolerance_m, 0, 0, m);
  out.matched = m.best_count;
  const int need = std::max(3, o.min_spheres);
  if (m.best_count < need) {
    out.matched = 0;
    out.why_not = std::to_string(m.best_count) + " of " + std::to_string(model.centres_m.size()) +
                  " target spheres found (need " + std::to_string(need) + "; " +
                  std::to_string(out.spheres.size()) + " ball" +
                  (out.spheres.size() == 1 ? "" : "s") + " of radius " +
                  std::to_string(static_cast<int>(std::lround(r * 1000))) + " mm seen)";
    if (full) out.why_not += "; the image was too cluttered to vote in full";
    return out;
  }
  for (size_t i = 0; i < out.spheres.size(); ++i) out.spheres[i].model_index = m.best[i];
  out.rms_m = assignment_rms(out.spheres, model, m.best, m.best_count, &out.camera_from_target);
  out.found = true;
  return out;
}

}  // namespace volcast
