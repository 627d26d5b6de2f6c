#pragma once
// The virtual operating room every participant of a session stands in, and where people may stand
// in it (Fischer et al. 2024, §3.4: a virtual OR with the site's cameras placed in it).
//
// Room frame (`room`): metres, y up, the floor is y = 0, the room's centre on the floor is the
// origin; x runs along the operating table, z across it. Each participant's tracked play area
// (`playarea`: the headset runtime's STAGE space, y up, floor y = 0) is placed in the room by
// room_from_playarea, a turn about y and a shift on the floor, which the server sets on joining
// (a free spot) and on each teleport.
#include <Eigen/Core>
#include <Eigen/Geometry>
#include <string>
#include <vector>

namespace volcast {

/// An upright box: centre (room frame, metres), half sizes along its own axes (metres), turned by
/// `yaw_rad` about +y.
struct RoomBox {
  Eigen::Vector3f center = Eigen::Vector3f::Zero();
  Eigen::Vector3f half_extent = Eigen::Vector3f::Constant(0.5f);
  float yaw_rad = 0;
};

/// The room's shape and furniture. Defaults: a 7 x 6 x 3 m OR with a 2.0 x 0.6 m operating table
/// 0.9 m high in the middle along x, a surgical lamp above it.
struct RoomLayout {
  float width_m = 7.0f;   ///< along x, walls at x = +-width/2
  float depth_m = 6.0f;   ///< along z, walls at z = +-depth/2
  float height_m = 3.0f;  ///< ceiling height
  RoomBox table{{0, 0.45f, 0}, {1.0f, 0.45f, 0.3f}, 0};
  Eigen::Vector3f lamp_position{0, 2.2f, 0};  ///< centre of the lamp's head, room frame
  /// Where newcomers are placed (x, z on the floor), tried in order; the first free one is used.
  std::vector<Eigen::Vector2f> spawn_spots{{0, 1.4f},    {0, -1.4f},     {-1.8f, 1.2f},
                                           {1.8f, 1.2f}, {-1.8f, -1.2f}, {1.8f, -1.2f},
                                           {-2.6f, 0},   {2.6f, 0}};
  float person_radius_m = 0.3f;  ///< how close a person may come to a wall, the table or another
};

/// The default operating room (the values above).
RoomLayout default_operating_room();

/// Whether a person may stand at floor spot (x, z) (room frame, metres): at least
/// person_radius_m inside the walls and outside the table's footprint. Otherwise false, with the
/// reason ("outside the room", "inside the operating table") in `why` if given.
bool is_free_floor_spot(const RoomLayout& room, const Eigen::Vector2f& spot,
                        std::string* why = nullptr);

/// A rigid pose: position (metres) and orientation (unit quaternion) of a frame in its parent.
/// For a head: OpenXR view space (x right, y up, looking down -z, origin between the eyes).
struct Pose {
  Eigen::Vector3f position = Eigen::Vector3f::Zero();
  Eigen::Quaternionf orientation = Eigen::Quaternionf::Identity();
};

/// What a participant's tracking reports, all in the room frame: room_from_head,
/// room_from_left_hand, room_from_right_hand (OpenXR grip poses: palm centre, -z along the
/// pointing direction). Hands are only meaningful when `hands_tracked`.
struct BodyPose {
  Pose head;
  Pose left_hand, right_hand;
  bool hands_tracked = false;
};

/// Pose between `a` (at t = 0) and `b` (t = 1): positions linearly, orientations by slerp.
Pose interpolate(const Pose& a, const Pose& b, float t);
BodyPose interpolate(const BodyPose& a, const BodyPose& b, float t);

}  // namespace volcast
