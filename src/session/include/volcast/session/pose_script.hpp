#pragma once
// Scripted motion for a headless participant (tests, recorded demos): key poses in the
// participant's play area frame, linearly interpolated, and teleports at given times.
//
// A script is JSON:
//   {"loop": true,                      // start again after the last key (default true)
//    "keys": [                          // at least one, times increasing
//      {"t": 0.0,                       // seconds from the start
//       "head": [0, 1.6, 0],            // metres, play area frame (y up, floor y = 0)
//       "yaw_deg": 0, "pitch_deg": 0,   // the head's turn about +y, then about its x (optional)
//       "left": [-0.2, 1.1, -0.3], "right": [0.2, 1.1, -0.3]},   // hands (optional, both or none)
//      ...],
//    "teleports": [{"t": 2.0, "to": [1.5, 1.0], "yaw_deg": 90}],  // room floor spot x, z
//    "grabs": [{"t": 1.0, "object": "liver",       // the case's object (objects.hpp) by name
//               "for_s": 3.0,                      // held this long, then released
//               "turn_deg_per_s": 60}],            // turned about the room's +y while held
//    "monitor": [{"t": 0.5, "slice": 1,            // the CT slice (optional)
//                 "preset": "liver",               // or "center"/"width" in HU (optional)
//                 "overlay": true}]}               // (optional)
//    "drawing": [{"t": 1.0, "kind": "point", "for_s": 2.0, "at": [x, y, z]},   // room frame
//                {"t": 3.5, "kind": "stroke", "for_s": 1.5, "path": [[x, y, z], ...]},
//                {"t": 5.5, "kind": "arrow", "from": [x, y, z], "to": [x, y, z]},
//                {"t": 6.0, "kind": "label", "at": [x, y, z], "text": "cut here"}]
//      the right hand's laser pointer (annotations.hpp), aimed from the hand at room-frame points:
//      "point" holds it on `at` for for_s; "stroke" sweeps its aim along `path` over for_s with
//      the pointer on, and draws what the ray met as a stroke; "arrow" and "label" are drawn where
//      the rays at their points meet what the participant sees (ScriptedPointing)
//    (teleports, grabs, monitor, drawing: optional, in time order, never repeated by "loop")
#include <filesystem>
#include <optional>
#include <string>
#include <vector>

#include "volcast/room/room.hpp"
#include "volcast/session/messages.hpp"

namespace volcast {

struct PoseKey {
  double t_s = 0;
  Eigen::Vector3f head{0, 1.6f, 0};
  float yaw_deg = 0, pitch_deg = 0;
  bool hands = false;
  Eigen::Vector3f left{-0.2f, 1.1f, -0.3f}, right{0.2f, 1.1f, -0.3f};
};

struct ScriptedTeleport {
  double t_s = 0;
  session::Spot to;
};

struct ScriptedGrab {
  double t_s = 0, for_s = 1;
  std::string object;
  float turn_deg_per_s = 0;
};

struct ScriptedMonitor {
  double t_s = 0;
  int slice = -1;  ///< -1: unchanged
  std::optional<float> center, width;
  std::optional<bool> overlay;
};

/// A pointing or drawing event (room frame, metres): see the script format above.
struct ScriptedDrawing {
  enum class Kind { kPoint, kStroke, kArrow, kLabel };
  Kind kind = Kind::kPoint;
  double t_s = 0, for_s = 0;  ///< kPoint, kStroke: how long; else 0
  /// kPoint, kLabel: the one aimed at; kStroke: the path (>= 2); kArrow: from, to.
  std::vector<Eigen::Vector3f> points;
  std::string text;  ///< kLabel
};

struct PoseScript {
  bool loop = true;
  std::vector<PoseKey> keys;
  std::vector<ScriptedTeleport> teleports;  ///< in time order; never repeated by `loop`
  std::vector<ScriptedGrab> grabs;          ///< likewise
  std::vector<ScriptedMonitor> monitor;     ///< likewise
  std::vector<ScriptedDrawing> drawing;     ///< likewise
  /// The body (play area frame) at `t_s` seconds: keys interpolated linearly (yaw and pitch
  /// too), held before the first and (without loop) after the last.
  BodyPose at(double t_s) const;
};

/// A standing participant looking ahead who sways slightly (a few cm, 0.5 Hz) and moves its
/// hands, so that its pose changes every frame.
PoseScript idle_pose_script();
/// Parses a script (format above). Throws Error naming the field that is missing or wrong.
PoseScript parse_pose_script(const std::string& json_text);
/// Reads and parses a script file. Throws Error naming the file.
PoseScript read_pose_script(const std::filesystem::path& path);

}  // namespace volcast
