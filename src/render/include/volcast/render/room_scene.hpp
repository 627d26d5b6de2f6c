#pragma once
// What the virtual operating room looks like (room.hpp gives its shape): furniture, the mesh
// avatar of a participant without a camera, and the effect others see where someone teleports,
// as primitives for PrimitiveRenderer. Room frame, metres, y up, floor y = 0.
#include <vector>

#include "volcast/render/primitive_renderer.hpp"
#include "volcast/room/room.hpp"

namespace volcast {

/// Floor (just below y = 0, so points on the floor stay visible), four walls (outside the room's
/// bounds), the operating table (base column, top slab, mattress), the surgical lamp (arm from the
/// ceiling, head with a glowing face below), a wall monitor and an instrument trolley. No
/// ceiling, so a view from above shows the room.
std::vector<Primitive> room_primitives(const RoomLayout& room);

/// Where the wall monitor shows its image: the unit quad [-0.5, 0.5]^2 (z = 0, facing +z) placed
/// on the left of the monitor's screen, square, 0.56 m a side (room frame).
Eigen::Matrix4f monitor_image_quad(const RoomLayout& room);
/// The monitor's status beside the image: a slice track with a marker at `slice` of `slices`, and
/// an orange square while the overlay is shown.
std::vector<Primitive> monitor_status_primitives(const RoomLayout& room, int slice, int slices,
                                                 bool overlay);

/// A participant without a camera: head (sphere, with a dark visor on its -z side, so its facing
/// shows), a torso below the head (upright, turned with the head's yaw only), and when
/// `body.hands_tracked` a box per hand. `rgb`: the participant's colour.
std::vector<Primitive> mesh_avatar_primitives(const BodyPose& body, const Eigen::Vector3f& rgb);

/// A participant's voice over its head (room frame, metres; `head`: its room_from_head position):
/// while it speaks, a glowing green ball 0.3 m above, 10 to 15 cm wide with `pulse` (0..1); while
/// its microphone is muted, a red ball 12 cm wide there instead. Empty when it neither speaks nor
/// is muted.
std::vector<Primitive> voice_badge_primitives(const Eigen::Vector3f& head, bool speaking,
                                              bool muted, float pulse);

/// A voice's volume as a headset wearer just set it (room frame, metres; `at`: where the voice
/// comes from): a grey upright track 40 cm tall and 7 cm wide, 0.45 m above `at`, filled from the
/// bottom in yellow to gain / 4 (0 to 4), with a white mark at 1 (the voice as sent).
std::vector<Primitive> volume_bar_primitives(const Eigen::Vector3f& at, float gain);

/// A headset wearer's own muted microphone, where they see it (room frame, metres; `hand`: the
/// left controller's position): a red ball 4 cm wide, 8 cm above the hand.
std::vector<Primitive> muted_hand_primitives(const Eigen::Vector3f& hand);

/// While the session is recorded, where a headset wearer always sees it (issue 53: no silent
/// recording; a window draws its own 2D badge): a glowing red ball 3 cm wide fixed in the view,
/// 0.6 m ahead of the head, 16 cm left and 12 cm up (about 15 degrees left and 11 up: in sight,
/// off the surgical field). `world_from_head`: the head between the eyes (room frame, metres;
/// -z ahead, +y up, +x right: OpenXR's view convention), the same for both eyes.
std::vector<Primitive> recording_badge_primitives(const RigidTransform& world_from_head);

/// Where someone teleported from or to, `age_s` seconds ago: three rings spreading on the floor
/// and a column of small rising particles, fading out over `duration_s`. Empty when age_s < 0 or
/// age_s >= duration_s.
std::vector<Primitive> teleport_effect_primitives(const Eigen::Vector3f& spot, float age_s,
                                                  float duration_s, const Eigen::Vector3f& rgb);

}  // namespace volcast
