#pragma once
// The patient case in a session (Fischer et al. 2024, §3.4: organ models every participant can
// grab and inspect, fully synchronised; a virtual monitor with medical images): the case's
// grabbable objects and CT series as every participant receives them, who holds which object and
// where it is, and what the monitor shows. Session channel messages (header as messages.hpp);
// little-endian, strings u16 length + UTF-8, f32 IEEE-754.
//
// Every message names the case `generation` (u32) it is about; the server bumps it when it swaps
// the case, and ignores messages about another generation (they were sent before the swap).
// A pose is messages.hpp's (position 3 f32 metres | quaternion x, y, z, w), here room_from_object.
//
// participant -> server:
//   0x0a Grab         generation u32 | object u16. The server makes the sender the object's owner
//                     if it has none (or already is); otherwise answers 0x43 ("held by ...").
//                     Grabs are handled one at a time in arrival order: of two at once, the first
//                     to arrive wins, and everyone is told the one owner by 0x4c.
//   0x0b ObjectMove   generation u32 | object u16 | pose. From the owner only (others' moves, e.g.
//                     sent just before losing a race, are ignored). Forwarded as 0x4c, coalesced.
//   0x0c Release      generation u32 | object u16 | pose (where it is let go; it stays there).
//   0x0d SetMonitor   generation u32 | monitor state (below, without `by`). Any participant.
// server -> participant:
//   0x4b Case         generation u32 | name string | object count u16 (<= kMaxCaseObjects) |
//                     per object: name string | rest pose | part count u16 (<= kMaxObjectParts) |
//                       per part: name string | rgba 4 u8 (linear RGB, alpha = opacity) |
//                       vertices u32 | triangles u32 | positions vertices x 3 f32 (metres, the
//                       object's frame) | normals vertices x 3 i8 (unit vector x 127) | indices
//                       triangles x 3 u32 (each < vertices; counter-clockwise from outside) |
//                     monitor u8 (0/1) | if 1: width u16 | height u16 | slices u16 | spacing 3 f32
//                       (mm: columns, rows, slices) | Hounsfield units width x height x slices i16
//                       (slice by slice, rows top to bottom) | overlay u8 (0/1) | if 1: label
//                       string | overlay bits ceil(w x h x s / 8) bytes (pixel i: byte i / 8, bit i
//                       % 8).
//                     Sent on joining and to everyone when the case is swapped; an empty case
//                     (no objects, no monitor) clears it.
//   0x4c ObjectState  generation u32 | object u16 | owner u32 (participant id, 0: none) |
//                     sequence u32 (grows with every change of the object) | time i64 (server
//                     clock, µs) | pose. To everyone on grab and release, to the others on a move;
//                     coalesced per object (the newest state replaces a queued one).
//   0x4d MonitorState generation u32 | slice u16 (< slices) | window center f32 (HU) | window
//                     width f32 (HU, >= 1) | overlay u8 (0/1) | by u32 (who set it; 0: the
//                     server). To everyone, coalesced.
// Limits: 0x4b at most kMaxCaseBytes and kMaxCaseTriangles triangles; others at most
// kMaxSessionMessageBytes. A count is checked against the bytes left before anything is
// allocated.
#include <cstdint>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "volcast/room/patient_case.hpp"
#include "volcast/room/room.hpp"
#include "volcast/session/messages.hpp"

namespace volcast::session {

inline constexpr uint32_t kMaxCaseBytes = 192u << 20;
inline constexpr uint64_t kMaxCaseTriangles = 8u << 20;
inline constexpr size_t kMaxCaseObjects = 64;
inline constexpr size_t kMaxObjectParts = 256;

struct ObjectState {
  uint32_t generation = 0;
  uint16_t object = 0;
  uint32_t owner = 0;  ///< participant id; 0: nobody holds it
  uint32_t sequence = 0;
  int64_t time_us = 0;  ///< server clock
  Pose pose;            ///< room_from_object
};

/// A request about one object (0x0a Grab: no pose; 0x0b, 0x0c: with one).
struct ObjectRequest {
  uint32_t generation = 0;
  uint16_t object = 0;
  Pose pose;
};

std::vector<uint8_t> serialize(const SharedCase& c);
/// Throws Error("malformed case: ...") on truncation, trailing bytes, counts over the limits or
/// the bytes left, an index out of range, a non-finite or non-unit value; never reads past `p`.
SharedCase parse_case(std::span<const uint8_t> p);
std::vector<uint8_t> serialize(const ObjectState& s);
ObjectState parse_object_state(std::span<const uint8_t> p);
std::vector<uint8_t> serialize(const MonitorState& s);
MonitorState parse_monitor_state(std::span<const uint8_t> p);
/// 0x0d: the state without `by`.
std::vector<uint8_t> serialize_set_monitor(const MonitorState& s);
MonitorState parse_set_monitor(std::span<const uint8_t> p);
/// 0x0a (with_pose false), 0x0b and 0x0c (true).
std::vector<uint8_t> serialize(const ObjectRequest& r, bool with_pose);
ObjectRequest parse_object_request(std::span<const uint8_t> p, bool with_pose);

}  // namespace volcast::session
