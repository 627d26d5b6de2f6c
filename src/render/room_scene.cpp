#include "volcast/render/room_scene.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <numbers>

namespace volcast {
namespace {

Eigen::Vector4f rgba(float r, float g, float b, float a = 1) {
  return {r, g, b, a};
}

Primitive shape(Primitive::Shape s, const Eigen::Affine3f& world_from_shape,
                const Eigen::Vector4f& color, float emissive = 0) {
  Primitive p;
  p.shape = s;
  p.world_from_shape = world_from_shape.matrix();
  p.color = color;
  p.emissive = emissive;
  return p;
}

Eigen::Affine3f placed(const Eigen::Vector3f& at, const Eigen::Vector3f& size, float yaw = 0) {
  return Eigen::Translation3f(at) * Eigen::AngleAxisf(yaw, Eigen::Vector3f::UnitY()) *
         Eigen::Scaling(size);
}

}  // namespace

std::vector<Primitive> room_primitives(const RoomLayout& room) {
  std::vector<Primitive> p;
  const float w = room.width_m, d = room.depth_m, h = room.height_m, t = 0.1f;
  const Eigen::Vector4f wall = rgba(0.62f, 0.70f, 0.74f), floor = rgba(0.50f, 0.58f, 0.55f);
  p.push_back(box({0, -0.02f, 0}, {w + 2 * t, 0.02f, d + 2 * t}, floor));
  p.push_back(box({0, h / 2, -d / 2 - t / 2}, {w + 2 * t, h, t}, wall));
  p.push_back(box({0, h / 2, d / 2 + t / 2}, {w + 2 * t, h, t}, wall));
  p.push_back(box({-w / 2 - t / 2, h / 2, 0}, {t, h, d}, wall));
  p.push_back(box({w / 2 + t / 2, h / 2, 0}, {t, h, d}, wall));
  // A darker skirting and a green-grey band at door height, so the walls read as walls.
  for (float z : {-d / 2, d / 2})
    p.push_back(box({0, 0.05f, z}, {w, 0.1f, 0.02f}, rgba(0.3f, 0.35f, 0.37f)));
  // The operating table: a column on a foot, the slab, a teal mattress.
  const RoomBox& tb = room.table;
  const float top = tb.center.y() + tb.half_extent.y();
  p.push_back(box({tb.center.x(), 0.04f, tb.center.z()}, {0.7f, 0.08f, 0.45f},
                  rgba(0.35f, 0.37f, 0.40f), tb.yaw_rad));
  p.push_back(box({tb.center.x(), top / 2, tb.center.z()}, {0.3f, top - 0.1f, 0.25f},
                  rgba(0.55f, 0.57f, 0.60f), tb.yaw_rad));
  p.push_back(box({tb.center.x(), top - 0.06f, tb.center.z()},
                  {2 * tb.half_extent.x(), 0.06f, 2 * tb.half_extent.z()}, rgba(0.7f, 0.72f, 0.75f),
                  tb.yaw_rad));
  p.push_back(box({tb.center.x(), top - 0.015f, tb.center.z()},
                  {2 * tb.half_extent.x() - 0.06f, 0.05f, 2 * tb.half_extent.z() - 0.04f},
                  rgba(0.10f, 0.42f, 0.45f), tb.yaw_rad));
  // The surgical lamp: an arm from the ceiling, a head, its glowing face.
  const Eigen::Vector3f& lamp = room.lamp_position;
  const float arm = h - lamp.y();
  p.push_back(shape(Primitive::Shape::kCylinder,
                    placed({lamp.x(), lamp.y() + arm / 2, lamp.z()}, {0.05f, arm, 0.05f}),
                    rgba(0.75f, 0.77f, 0.8f)));
  p.push_back(shape(Primitive::Shape::kCylinder,
                    placed({lamp.x(), lamp.y(), lamp.z()}, {0.7f, 0.12f, 0.7f}),
                    rgba(0.85f, 0.86f, 0.88f)));
  p.push_back(shape(Primitive::Shape::kCylinder,
                    placed({lamp.x(), lamp.y() - 0.065f, lamp.z()}, {0.55f, 0.01f, 0.55f}),
                    rgba(1.0f, 0.98f, 0.9f), 1));
  // A monitor on the far wall and an instrument trolley beside the table.
  p.push_back(box({-1.2f, 1.6f, -d / 2 + 0.06f}, {1.2f, 0.7f, 0.05f}, rgba(0.08f, 0.09f, 0.1f)));
  p.push_back(
      box({-1.2f, 1.6f, -d / 2 + 0.09f}, {1.1f, 0.6f, 0.01f}, rgba(0.15f, 0.3f, 0.45f), 0, 0.8f));
  const Eigen::Vector3f trolley(tb.center.x() + tb.half_extent.x() + 0.6f, 0, tb.center.z() - 0.7f);
  p.push_back(
      box(trolley + Eigen::Vector3f(0, 0.85f, 0), {0.6f, 0.03f, 0.4f}, rgba(0.78f, 0.8f, 0.82f)));
  p.push_back(
      box(trolley + Eigen::Vector3f(0, 0.45f, 0), {0.04f, 0.8f, 0.04f}, rgba(0.6f, 0.62f, 0.65f)));
  p.push_back(
      box(trolley + Eigen::Vector3f(0, 0.03f, 0), {0.5f, 0.04f, 0.35f}, rgba(0.4f, 0.42f, 0.45f)));
  return p;
}

Eigen::Matrix4f monitor_image_quad(const RoomLayout& room) {
  // The screen (room_primitives): centre (-1.2, 1.6), 1.1 x 0.6 m, its face at z = -d/2 + 0.095.
  Eigen::Matrix4f m = Eigen::Matrix4f::Identity();
  m.diagonal() << 0.56f, 0.56f, 1, 1;
  m.topRightCorner<3, 1>() << -1.2f - 0.25f, 1.6f, -room.depth_m / 2 + 0.1f;
  return m;
}

std::vector<Primitive> monitor_status_primitives(const RoomLayout& room, int slice, int slices,
                                                 bool overlay) {
  std::vector<Primitive> p;
  const float z = -room.depth_m / 2 + 0.1f, x = -0.95f;
  const auto rgba = [](float r, float g, float b) { return Eigen::Vector4f(r, g, b, 1); };
  p.push_back(box({x, 1.6f, z}, {0.02f, 0.5f, 0.005f}, rgba(0.25f, 0.27f, 0.3f), 0, 0.6f));
  const float f = slices > 1 ? float(slice) / float(slices - 1) : 0.5f;
  p.push_back(box({x, 1.85f - 0.5f * f, z + 0.004f}, {0.06f, 0.02f, 0.005f},
                  rgba(0.9f, 0.9f, 0.95f), 0, 0.9f));
  if (overlay)
    p.push_back(box({-0.8f, 1.82f, z}, {0.06f, 0.06f, 0.005f}, rgba(1.0f, 0.55f, 0.1f), 0, 0.9f));
  return p;
}

std::vector<Primitive> mesh_avatar_primitives(const BodyPose& body, const Eigen::Vector3f& rgb) {
  std::vector<Primitive> p;
  const Eigen::Vector4f skin(rgb.x(), rgb.y(), rgb.z(), 1);
  const Eigen::Affine3f head = Eigen::Translation3f(body.head.position) * body.head.orientation;
  p.push_back(shape(Primitive::Shape::kSphere, head * Eigen::Scaling(0.22f, 0.24f, 0.22f), skin));
  p.push_back(
      shape(Primitive::Shape::kBox,
            head * Eigen::Translation3f(0, 0.01f, -0.1f) * Eigen::Scaling(0.18f, 0.07f, 0.05f),
            rgba(0.05f, 0.06f, 0.08f)));
  // The torso stands upright under the head, turned by the head's yaw only.
  const Eigen::Vector3f forward = body.head.orientation * Eigen::Vector3f(0, 0, -1);
  const float yaw = std::atan2(-forward.x(), -forward.z());
  const float torso_top = body.head.position.y() - 0.18f;
  const float torso = std::max(0.2f, torso_top - 0.75f);
  const Eigen::Vector3f waist(body.head.position.x(), torso_top - torso / 2,
                              body.head.position.z());
  p.push_back(shape(Primitive::Shape::kCylinder, placed(waist, {0.36f, torso, 0.22f}, yaw),
                    Eigen::Vector4f(0.6f * rgb.x(), 0.6f * rgb.y(), 0.6f * rgb.z(), 1)));
  if (body.hands_tracked)
    for (const Pose& hand : {body.left_hand, body.right_hand})
      p.push_back(shape(Primitive::Shape::kBox,
                        Eigen::Translation3f(hand.position) * hand.orientation *
                            Eigen::Scaling(0.09f, 0.04f, 0.16f),
                        skin));
  return p;
}

std::vector<Primitive> voice_badge_primitives(const Eigen::Vector3f& head, bool speaking,
                                              bool muted, float pulse) {
  // A ball: the same from every side (a ring at eye height is seen edge-on, as a line).
  std::vector<Primitive> p;
  const Eigen::Vector3f above = head + Eigen::Vector3f(0, 0.3f, 0);
  if (muted) {
    p.push_back(shape(Primitive::Shape::kSphere,
                      Eigen::Translation3f(above) * Eigen::Scaling(0.12f, 0.12f, 0.12f),
                      rgba(0.9f, 0.12f, 0.1f), 1));
  } else if (speaking) {
    const float d = 0.10f + 0.05f * std::clamp(pulse, 0.0f, 1.0f);
    p.push_back(shape(Primitive::Shape::kSphere,
                      Eigen::Translation3f(above) * Eigen::Scaling(d, d, d),
                      rgba(0.2f, 0.95f, 0.35f), 1));
  }
  return p;
}

std::vector<Primitive> volume_bar_primitives(const Eigen::Vector3f& at, float gain) {
  constexpr float kHeight = 0.4f, kWidth = 0.07f;
  const Eigen::Vector3f bottom = at + Eigen::Vector3f(0, 0.45f, 0);
  const float filled = kHeight * std::clamp(gain, 0.0f, 4.0f) / 4;
  std::vector<Primitive> p;
  p.push_back(shape(Primitive::Shape::kBox,
                    Eigen::Translation3f(bottom + Eigen::Vector3f(0, kHeight / 2, 0)) *
                        Eigen::Scaling(kWidth, kHeight, kWidth),
                    rgba(0.35f, 0.36f, 0.4f)));
  if (filled > 0)
    p.push_back(shape(Primitive::Shape::kBox,
                      Eigen::Translation3f(bottom + Eigen::Vector3f(0, filled / 2, 0)) *
                          Eigen::Scaling(kWidth * 1.3f, filled, kWidth * 1.3f),
                      rgba(0.95f, 0.8f, 0.15f), 1));
  p.push_back(shape(Primitive::Shape::kBox,
                    Eigen::Translation3f(bottom + Eigen::Vector3f(0, kHeight / 4, 0)) *
                        Eigen::Scaling(kWidth * 2, 0.008f, kWidth * 2),
                    rgba(1, 1, 1), 1));
  return p;
}

std::vector<Primitive> muted_hand_primitives(const Eigen::Vector3f& hand) {
  return {shape(Primitive::Shape::kSphere,
                Eigen::Translation3f(hand + Eigen::Vector3f(0, 0.08f, 0)) *
                    Eigen::Scaling(0.04f, 0.04f, 0.04f),
                rgba(0.9f, 0.12f, 0.1f), 1)};
}

std::vector<Primitive> recording_badge_primitives(const RigidTransform& world_from_head) {
  const Eigen::Vector3f at = (world_from_head * Eigen::Vector3d(-0.16, 0.12, -0.6)).cast<float>();
  return {shape(Primitive::Shape::kSphere,
                Eigen::Translation3f(at) * Eigen::Scaling(0.03f, 0.03f, 0.03f),
                rgba(0.95f, 0.08f, 0.06f), 1)};
}

std::vector<Primitive> teleport_effect_primitives(const Eigen::Vector3f& spot, float age_s,
                                                  float duration_s, const Eigen::Vector3f& rgb) {
  std::vector<Primitive> p;
  if (!(age_s >= 0 && age_s < duration_s && duration_s > 0)) return p;
  const float f = age_s / duration_s, fade = 1 - f;
  for (int i = 0; i < 3; ++i) {
    const float r = 0.3f + 0.9f * f + 0.25f * float(i);
    p.push_back(shape(Primitive::Shape::kRing,
                      placed(spot + Eigen::Vector3f(0, 0.01f + 0.005f * float(i), 0), {r, 1, r}),
                      Eigen::Vector4f(rgb.x(), rgb.y(), rgb.z(), 0.8f * fade), 1));
  }
  const float pi = std::numbers::pi_v<float>;
  for (int i = 0; i < 12; ++i) {
    const float a = 2 * pi * float(i) / 12 + 2 * f;
    const float rise = 2.0f * f * (0.6f + 0.4f * float(i % 3) / 2);
    const Eigen::Vector3f at =
        spot + Eigen::Vector3f(0.3f * std::cos(a), 0.1f + rise, 0.3f * std::sin(a));
    p.push_back(shape(Primitive::Shape::kSphere, placed(at, Eigen::Vector3f::Constant(0.06f)),
                      Eigen::Vector4f(rgb.x(), rgb.y(), rgb.z(), fade), 1));
  }
  return p;
}

}  // namespace volcast
