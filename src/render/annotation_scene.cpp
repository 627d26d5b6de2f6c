#include "volcast/render/annotation_scene.hpp"

#include <Eigen/Geometry>
#include <algorithm>

namespace volcast {
namespace {

constexpr float kGlow = 0.85f;

// The unit cylinder (radius 0.5 about +y) as a tube of `width` from a to b.
Primitive tube(const Eigen::Vector3f& a, const Eigen::Vector3f& b, float width,
               const Eigen::Vector4f& rgba) {
  const Eigen::Vector3f d = b - a;
  const Eigen::Quaternionf turn = Eigen::Quaternionf::FromTwoVectors(Eigen::Vector3f::UnitY(), d);
  Primitive p;
  p.shape = Primitive::Shape::kCylinder;
  p.world_from_shape = (Eigen::Translation3f((a + b) / 2) * turn *
                        Eigen::Scaling(Eigen::Vector3f(width, d.norm(), width)))
                           .matrix();
  p.color = rgba;
  p.emissive = kGlow;
  return p;
}

Primitive ball(const Eigen::Vector3f& at, float width, const Eigen::Vector4f& rgba) {
  Primitive p;
  p.shape = Primitive::Shape::kSphere;
  p.world_from_shape = (Eigen::Translation3f(at) * Eigen::Scaling(width)).matrix();
  p.color = rgba;
  p.emissive = kGlow;
  return p;
}

Eigen::Vector4f opaque(const Eigen::Vector3f& rgb) {
  return {rgb.x(), rgb.y(), rgb.z(), 1};
}

}  // namespace

Eigen::Vector3f toward_eye(const Eigen::Vector3f& p, const Eigen::Vector3f& eye, float lift_per_m) {
  const Eigen::Vector3f to_eye = eye - p;
  const float d = to_eye.norm();
  if (d < 1e-4f) return p;
  return p + to_eye / d * std::min(0.02f + lift_per_m * d, 0.5f * d);
}

Eigen::Vector3f participant_color(uint32_t id) {
  static const Eigen::Vector3f palette[] = {{0.95f, 0.55f, 0.2f}, {0.3f, 0.7f, 0.95f},
                                            {0.6f, 0.85f, 0.3f},  {0.9f, 0.35f, 0.6f},
                                            {0.95f, 0.85f, 0.3f}, {0.55f, 0.45f, 0.95f}};
  return palette[id % 6];
}

std::vector<Primitive> pointer_primitives(const Eigen::Vector3f& origin, bool has_hit,
                                          const Eigen::Vector3f& hit, const Eigen::Vector3f& rgb,
                                          const Eigen::Vector3f& eye, float lift_per_m) {
  const Eigen::Vector3f ray = hit - origin;
  if (ray.norm() < 1e-4f) return {};
  const Eigen::Vector3f dir = ray.normalized();
  const Eigen::Vector4f beam{rgb.x(), rgb.y(), rgb.z(), 0.6f};
  if (!has_hit) return {tube(origin, origin + 3 * dir, 0.005f, beam)};
  constexpr float kDot = 0.03f, kThick = 0.004f;
  std::vector<Primitive> out{tube(origin, hit, 0.005f, beam)};
  // On the line from the eye to the hit: it projects where the hit does, in front of the surface.
  const Eigen::Vector3f to_eye = eye - hit;
  const Eigen::Vector3f facing = to_eye.norm() > 1e-4f ? to_eye.normalized() : -dir;
  const Eigen::Vector3f centre = toward_eye(hit, eye, lift_per_m);
  Primitive dot = ball(centre, 1, opaque(rgb));
  dot.world_from_shape = (Eigen::Translation3f(centre) *
                          Eigen::Quaternionf::FromTwoVectors(Eigen::Vector3f::UnitZ(), facing) *
                          Eigen::Scaling(Eigen::Vector3f(kDot, kDot, kThick)))
                             .matrix();
  dot.emissive = 1;
  out.push_back(dot);
  return out;
}

Eigen::Vector3f label_anchor(const Eigen::Vector3f& pin) {
  return pin + Eigen::Vector3f(0, 0.12f, 0);
}

std::vector<Primitive> stroke_primitives(std::span<const Eigen::Vector3f> p,
                                         const Eigen::Vector3f& rgb) {
  std::vector<Primitive> out;
  const Eigen::Vector4f c = opaque(rgb);
  for (size_t i = 0; i < p.size(); ++i) {
    out.push_back(ball(p[i], 0.008f, c));
    if (i > 0 && (p[i] - p[i - 1]).norm() > 1e-5f) out.push_back(tube(p[i - 1], p[i], 0.008f, c));
  }
  return out;
}

std::vector<Primitive> arrow_primitives(const Eigen::Vector3f& tail, const Eigen::Vector3f& head,
                                        const Eigen::Vector3f& rgb) {
  if ((head - tail).norm() < 1e-4f) return {};
  const Eigen::Vector4f c = opaque(rgb);
  const Eigen::Vector3f dir = (head - tail).normalized();
  const float length = std::min(0.06f, (head - tail).norm());
  const Eigen::Vector3f base = head - dir * length;
  std::vector<Primitive> out{tube(tail, base, 0.01f, c)};
  // The head: four stacked discs narrowing to the point.
  for (int i = 0; i < 4; ++i) {
    const Eigen::Vector3f from = base + dir * (length * float(i) / 4);
    const Eigen::Vector3f to = base + dir * (length * float(i + 1) / 4);
    out.push_back(tube(from, to, 0.04f * float(4 - i) / 4, c));
  }
  return out;
}

std::vector<Primitive> label_pin_primitives(const Eigen::Vector3f& pin,
                                            const Eigen::Vector3f& rgb) {
  const Eigen::Vector4f c = opaque(rgb);
  const Eigen::Vector3f top = label_anchor(pin);
  std::vector<Primitive> out{ball(pin, 0.025f, c), tube(pin, top, 0.006f, c)};
  Primitive flag = ball(top + Eigen::Vector3f(0.03f, -0.02f, 0), 1, c);
  flag.shape = Primitive::Shape::kBox;
  flag.world_from_shape = (Eigen::Translation3f(top + Eigen::Vector3f(0.03f, -0.02f, 0)) *
                           Eigen::Scaling(Eigen::Vector3f(0.06f, 0.04f, 0.004f)))
                              .matrix();
  out.push_back(flag);
  return out;
}

}  // namespace volcast
