#pragma once
// The demo session's scripted people (demo_participants.cpp): the two remote participants and the
// OR's wall display, each a SessionClient with its viewer's options, its life (join, voice,
// rejoin after a cut, leave) given to live_in_viewer. run_demo_session runs them; a test cuts
// their path (tests/demo/demo_participants_test.cpp).
#include <Eigen/Core>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/demo/demo.hpp"
#include "volcast/io/site_config.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/session_client.hpp"
#include "volcast/session/pose_script.hpp"
#include "volcast/voice/voice_link.hpp"

namespace volcast::demo {

struct Exchange;  // demo_voice.hpp: the spoken exchange

/// Where Dr. Mesh teleports (room frame): across the table, between the liver over it and the
/// wall monitor.
inline constexpr session::Spot kMeshSpot{0.9f, -1.8f, 1.9f};

/// Dr. Mesh's right hand once it has teleported to kMeshSpot and stands still (its script's keys):
/// where its pointer's rays start. Room frame, metres.
Eigen::Vector3f drawing_hand();

/// Where Dr. Mesh points and draws: a point `at` on a surface, and two directions in it: `right`
/// (camera 0's image right, laid into the surface) and `up` (across it). Room frame, metres.
struct DrawingSpot {
  Eigen::Vector3f at = Eigen::Vector3f::Zero(), right = Eigen::Vector3f::UnitX(),
                  up = Eigen::Vector3f::UnitY();
};

/// A surface camera 0 of `site` (read from `config`, placed in the room by `room_from_site`) sees
/// near the middle of its image that `hand` (room frame) also sees -- the ray from the hand meets
/// nothing of the cameras' first frames before it, nor before any point of the drawing -- and that
/// faces both (normal within 60 degrees of each). Throws Error when none is found.
DrawingSpot find_drawing_spot(const std::vector<SiteCamera>& site,
                              const std::filesystem::path& config,
                              const RigidTransform& room_from_site, const Eigen::Vector3f& hand);

/// Dr. Mesh's pointing and drawing at `spot`: the pointer on it, a circle of 12 cm radius around
/// it, an arrow towards the circle and the label "cut here" above it (times in its script's s).
std::vector<ScriptedDrawing> drawing_at(const DrawingSpot& spot);

/// One scripted person of the demo's session: its client, its viewer's options, how it ended and,
/// while it is joined with the spoken exchange, its voice.
struct Person {
  std::string name;  ///< display name
  std::string file;  ///< stem of its files in the output folder (screenshot, figures, voice)
  std::unique_ptr<SessionClient> session;
  ViewerOptions opt;  ///< run_viewer(opt) runs it; its life is already set (live_in_viewer)
  ViewerResult result;
  std::string error;
  std::unique_ptr<voice::VoiceLink> voice;  ///< with the spoken exchange, while joined
  voice::VoiceStats heard;                  ///< what it heard, kept when it leaves
};

/// Runs each person's viewer on a thread of its own (run_viewer(opt)), its result kept in
/// `result`, or what failed in `error`; join the threads to wait for them.
std::vector<std::thread> start(const std::vector<std::unique_ptr<Person>>& people);

/// The two remote participants joining session "OR" through `link` (a join link): "Dr. Hands
/// (camera)" (a camera avatar from data's hands sequence, who grabs the liver and turns it 150
/// degrees) and "Dr. Mesh" (a mesh avatar who teleports to kMeshSpot, sets the monitor, then
/// points and draws at `spot`), each writing a screenshot and figures into `out`; with `talk`
/// (may be null) each says its line. Each rejoins as itself after a cut (ViewerOptions::reconnect).
std::vector<std::unique_ptr<Person>> participants(const DemoArgs& a,
                                                  const std::filesystem::path& data,
                                                  const std::filesystem::path& out,
                                                  const std::string& link, const Exchange* talk,
                                                  const DrawingSpot& spot);

/// The OR's wall display of camera 0: joins as "OR wall display" (no pose, no avatar) for
/// `seconds` and writes out/or_display.png, the camera's image with the remote participants,
/// pointers and drawing in it.
std::unique_ptr<Person> or_display(const DemoArgs& a, const std::filesystem::path& out,
                                   const std::string& link, double seconds);

}  // namespace volcast::demo
