// src/room on its own: where a person may stand in the virtual OR and how poses are interpolated
// between the ones received (room.hpp). Exact behaviour on the default room's own numbers.
#include <gtest/gtest.h>

#include <cmath>
#include <numbers>
#include <string>

#include "volcast/room/room.hpp"

namespace volcast {
namespace {

TEST(Room, APersonStandsInsideTheWallsAndOutsideTheTableWithAReason) {
  const RoomLayout room = default_operating_room();
  std::string why;
  EXPECT_TRUE(is_free_floor_spot(room, {0, 1.4f}, &why)) << why;
  // The walls at x = +-3.5, z = +-3, less the person's 0.3 m.
  EXPECT_TRUE(is_free_floor_spot(room, {3.19f, 0}));
  EXPECT_FALSE(is_free_floor_spot(room, {3.21f, 0}, &why));
  EXPECT_EQ(why, "outside the room");
  EXPECT_FALSE(is_free_floor_spot(room, {0, -2.71f}));
  EXPECT_FALSE(is_free_floor_spot(room, {NAN, 0}, &why));
  EXPECT_EQ(why, "outside the room");
  // The table's footprint (2.0 x 0.6 m at the centre) grown by the person's radius.
  EXPECT_FALSE(is_free_floor_spot(room, {1.29f, 0}, &why));
  EXPECT_EQ(why, "inside the operating table");
  EXPECT_TRUE(is_free_floor_spot(room, {1.31f, 0}));
  EXPECT_FALSE(is_free_floor_spot(room, {0, 0.59f}));
  EXPECT_TRUE(is_free_floor_spot(room, {0, 0.61f}));
  // A table turned a quarter about +y: its length now along z.
  RoomLayout turned = room;
  turned.table.yaw_rad = std::numbers::pi_v<float> / 2;
  EXPECT_TRUE(is_free_floor_spot(turned, {1.31f, 0}));
  EXPECT_FALSE(is_free_floor_spot(turned, {0, 1.29f}));
  // Every spawn spot of the default room is free: a newcomer is never put in the table.
  for (const auto& spot : room.spawn_spots)
    EXPECT_TRUE(is_free_floor_spot(room, spot, &why)) << spot.transpose() << ": " << why;
}

TEST(Room, PosesInterpolateLinearlyAndByTheShorterTurn) {
  Pose a, b;
  a.position = {0, 1.6f, 0};
  b.position = {1, 1.6f, -2};
  b.orientation = Eigen::Quaternionf(Eigen::AngleAxisf(1.0f, Eigen::Vector3f::UnitY()));
  const Pose mid = interpolate(a, b, 0.5f);
  EXPECT_TRUE(mid.position.isApprox(Eigen::Vector3f(0.5f, 1.6f, -1)));
  EXPECT_NEAR(Eigen::AngleAxisf(mid.orientation).angle(), 0.5f, 1e-5f);
  EXPECT_TRUE(interpolate(a, b, 0).orientation.isApprox(a.orientation));
  EXPECT_TRUE(interpolate(a, b, 1).position.isApprox(b.position));
  // The same turn written with the opposite sign (q and -q): still the shorter way, 0.5 rad.
  Pose c = b;
  c.orientation.coeffs() = -b.orientation.coeffs();
  EXPECT_NEAR(Eigen::AngleAxisf(interpolate(a, c, 0.5f).orientation).angle(), 0.5f, 1e-5f);
  // A body: every part; the hands tracked as the newer pose says.
  BodyPose x, y;
  x.head = a;
  y.head = b;
  y.left_hand.position = {-0.2f, 1.2f, -0.4f};
  y.hands_tracked = true;
  const BodyPose half = interpolate(x, y, 0.5f);
  EXPECT_TRUE(half.head.position.isApprox(mid.position));
  EXPECT_TRUE(half.left_hand.position.isApprox(Eigen::Vector3f(-0.1f, 0.6f, -0.2f)));
  EXPECT_TRUE(half.hands_tracked);
}

}  // namespace
}  // namespace volcast
