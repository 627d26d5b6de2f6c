#include "volcast/room/room.hpp"

#include <cmath>

namespace volcast {

RoomLayout default_operating_room() {
  return {};
}

bool is_free_floor_spot(const RoomLayout& room, const Eigen::Vector2f& spot, std::string* why) {
  const float r = room.person_radius_m;
  if (!std::isfinite(spot.x()) || !std::isfinite(spot.y()) ||
      std::abs(spot.x()) > room.width_m / 2 - r || std::abs(spot.y()) > room.depth_m / 2 - r) {
    if (why) *why = "outside the room";
    return false;
  }
  // The spot in the table's own frame, against its footprint grown by the person's radius.
  const RoomBox& t = room.table;
  const float c = std::cos(-t.yaw_rad), s = std::sin(-t.yaw_rad);
  const float dx = spot.x() - t.center.x(), dz = spot.y() - t.center.z();
  const float lx = c * dx + s * dz, lz = -s * dx + c * dz;
  if (std::abs(lx) < t.half_extent.x() + r && std::abs(lz) < t.half_extent.z() + r) {
    if (why) *why = "inside the operating table";
    return false;
  }
  return true;
}

Pose interpolate(const Pose& a, const Pose& b, float t) {
  return {a.position + (b.position - a.position) * t, a.orientation.slerp(t, b.orientation)};
}

BodyPose interpolate(const BodyPose& a, const BodyPose& b, float t) {
  return {interpolate(a.head, b.head, t), interpolate(a.left_hand, b.left_hand, t),
          interpolate(a.right_hand, b.right_hand, t), b.hands_tracked};
}

}  // namespace volcast
