#pragma once
// A loaded case (case.hpp) as the session shares it (room/patient_case.hpp): one grabbable object
// per group, its parts in the object's frame (metres, origin at the centre of the group's bounding
// box, axes the room's: case frame turned by room_from_case), placed at rest over the operating
// table: the group holding the liver 0.4 m above the table top, a group as large as a body
// lying on the table, the others in a row beside the liver. The DICOM series goes to the
// monitor.
#include "volcast/assets/case.hpp"
#include "volcast/room/patient_case.hpp"
#include "volcast/room/room.hpp"

namespace volcast {

SharedCase to_shared_case(const Case& c, const RoomLayout& room = default_operating_room());

}  // namespace volcast
