#pragma once
// A participant's moving parts around its connection: a thread that publishes its body pose at
// the display rate (from a pose script for a headless participant) and performs the script's
// teleports, and a thread that reads its own RGB-D camera (any source Volcast reads) at the
// camera's rate and uploads each frame as its avatar stream (session/participant.hpp).
#include <atomic>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <thread>
#include <vector>

#include "volcast/capture/source.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/reconstruct/surface_hit.hpp"
#include "volcast/session/participant.hpp"
#include "volcast/session/pose_script.hpp"

namespace volcast {

struct SessionClientOptions {
  ParticipantConfig participant;  ///< its `camera` is filled in from `camera_source`
  PoseScript script = idle_pose_script();
  /// Poses published per second (the display rate): at most the server's limit, 150
  /// (session/rate_limit.hpp), else Error.
  double pose_rate_hz = 60;
  /// false: the caller publishes poses (a window from its eye, a test by hand); the thread only
  /// sends heartbeats (2 Hz) so the participant stays present.
  bool drive_poses = true;
  std::filesystem::path camera_source;  ///< the avatar camera; empty: a mesh avatar
  SourceOptions camera_options;         ///< intrinsics etc. for the camera source
  /// Where the camera stands in the play area; default: auto_playarea_from_camera.
  std::optional<RigidTransform> playarea_from_camera;
  std::string upload_depth_codec = "volcast", upload_color_codec = "jpeg";
  /// Where the script's pointer rays meet the live clouds (ScriptedPointing); the presenter that
  /// draws the site's frames keeps it up to date (session_presenter). Null: they meet nothing.
  std::shared_ptr<const SurfaceHit> surfaces;
};

/// Where a participant's own camera stands when nobody registered it: facing the participant
/// (looking along +z of the play area, level), 1.3 m above the floor, so that the median depth
/// of `first` (its first frame, mm) lands 0.3 m in front of a participant standing at the origin
/// -- the hands and chest of someone facing it. play area frame, metres.
RigidTransform auto_playarea_from_camera(const DepthImage& first);

/// One thing a pose script asks its participant to do now (ScriptedObjects::due).
struct ScriptAction {
  enum class Kind { kGrab, kMove, kRelease, kMonitor };
  Kind kind = Kind::kGrab;
  uint16_t object = 0;   ///< kGrab, kMove, kRelease: index into the shared case
  Pose pose;             ///< kMove, kRelease: room_from_object (room frame, metres)
  MonitorState monitor;  ///< kMonitor: the whole state to set
};

/// The object and monitor events of a pose script, performed by a participant as time goes: at a
/// grab's time it asks to hold the object; once the server hands it over, it turns it (about +y,
/// room frame, from where it was) by turn_deg_per_s x for_s in kMovesPerSecond x for_s equal
/// steps, a move each (the first, at the start pose, when it is handed over), then releases it at
/// the end pose (given up if the server does not hand it over within for_s + 10 s); monitor
/// changes are set at their times. Step k is due k / kMovesPerSecond s after the hand-over and
/// is sent only once the move before it has left the participant's queue, so none is coalesced
/// with the next: every step reaches the server, on a loaded machine later than its time. An
/// event waits for what it needs: every event for the case, a grab for the objects' state and a
/// monitor change for the monitor's state (both follow the case, and on a loaded machine the case
/// takes a while); a change to a case without a CT series is dropped.
class ScriptedObjects {
 public:
  static constexpr double kMovesPerSecond = 10;  ///< a scripted turn's steps (moves) per second

  explicit ScriptedObjects(PoseScript script) : script_(std::move(script)) {}
  /// The actions due by `t_s` seconds into the script, given the case and what the participant
  /// sees now (`shared_case` null: none yet), and whether a move of the held object still waits in
  /// the participant's queue (Participant::object_request_queued: the next step waits for it).
  /// Advances the script past what it returns.
  std::vector<ScriptAction> due(const SharedCase* shared_case, const SessionSnapshot& now,
                                double t_s, bool move_queued = false);
  /// Performs the actions due by `t_s` on `participant`.
  void step(Participant& participant, double t_s);
  /// Whether every grab and monitor change of the script was performed (or given up) and nothing
  /// is held.
  bool done() const {
    return !holding_ && next_grab_ == script_.grabs.size() &&
           next_monitor_ == script_.monitor.size();
  }

 private:
  PoseScript script_;
  size_t next_grab_ = 0, next_monitor_ = 0;
  bool holding_ = false;
  uint16_t object_ = 0;
  static constexpr double kGrantWait_s = 10;  // a grab the server never hands over is given up
  ScriptedGrab grab_;
  std::optional<double> granted_s_;  // when the server made the grabbed object ours
  int steps_ = 0;                    // the held turn's steps after its first move
  int moved_ = -1;                   // the last step sent (0: the start pose), -1: none yet
  Pose start_pose_;
};

/// The pointing and drawing of a pose script (PoseScript::drawing), performed by a participant
/// as time goes, the right hand's laser pointer aimed from the hand at the script's room-frame
/// points: a "point" shows the pointer on its point for its time; a "stroke" sweeps the aim along
/// its path (at constant speed along it) with the pointer shown, a ray every 1/60 s of script
/// time however seldom step() runs (from the hand of the step that casts it: a loaded machine may
/// not run the pose thread for the stroke's whole time), and, when it ends, draws the
/// points where the rays met the live clouds (one within 3 mm of the last is skipped; at most
/// kMaxStrokePoints, evenly thinned; none drawn if fewer than 2 met anything); an "arrow" and a
/// "label" are drawn at once where the rays at their points meet the clouds, or at the points
/// themselves where they meet nothing. A pointer's dot is where its ray meets the clouds (none
/// where it meets nothing). With `surfaces`, the drawing's times count from when the first frame
/// of the site came (SurfaceHit::ready): a script that starts before the stream has nothing to
/// point at (a loaded machine's first frame sets may take seconds), as a person would wait to see
/// the scene before pointing.
class ScriptedPointing {
 public:
  ScriptedPointing(PoseScript script, std::shared_ptr<const SurfaceHit> surfaces)
      : script_(std::move(script)), surfaces_(std::move(surfaces)) {}
  /// Performs what is due by `t_s` seconds into the script on `participant`, the pointer from
  /// `hand` (room frame, metres).
  void step(Participant& participant, const Eigen::Vector3f& hand, double t_s);
  /// Whether the whole drawing was drawn and the pointer put away.
  bool done() const { return next_ == script_.drawing.size() && !active_; }

 private:
  std::optional<Eigen::Vector3f> hit(const Eigen::Vector3f& hand, const Eigen::Vector3f& at) const;
  // Casts the active stroke's rays due from swept_s_ up to `until_s` (at most its end).
  void sweep(const Eigen::Vector3f& hand, double until_s);
  void finish(Participant& participant, const Eigen::Vector3f& hand);
  static constexpr double kSweepStep_s = 1.0 / 60;  // a stroke's ray per pose at 60 Hz
  PoseScript script_;
  std::shared_ptr<const SurfaceHit> surfaces_;
  size_t next_ = 0;
  std::optional<ScriptedDrawing> active_;
  std::vector<Eigen::Vector3f> stroke_;  // the active stroke's hits
  double swept_s_ = 0;                   // script time its rays were cast up to (exclusive)
  std::optional<double> began_s_;        // the script's time when the site's clouds came
};

class SessionClient {
 public:
  /// Opens the camera source (if any), so that a bad one fails before connecting. Throws Error.
  explicit SessionClient(SessionClientOptions options);
  ~SessionClient();
  SessionClient(const SessionClient&) = delete;
  SessionClient& operator=(const SessionClient&) = delete;
  /// Joins the session over `client` (connected, not yet receiving) and starts the threads.
  void start(Client& client);
  /// Moves the participant to `client`, a new connection after a cut (not yet receiving), and
  /// rejoins its session there (Participant::reattach: its own place back if the server kept
  /// it); the threads go on. Call on the thread that receives, between receives.
  void reattach(Client& client);
  /// Stops the threads and lets go of the client (Participant::detach; no Leave is sent: call
  /// participant()->leave() first for that); the Participant stays readable. Idempotent.
  void stop();
  /// The participant (null before start()).
  Participant* participant() { return participant_.get(); }
  /// Whether the pose script's teleports, grabs, monitor changes and drawing were all performed
  /// (ScriptedObjects::done, ScriptedPointing::done); true at once when the caller drives the
  /// poses. Its body's motion goes on after. Thread-safe.
  bool script_done() const { return script_done_; }

 private:
  void run_poses();
  void run_camera();
  SessionClientOptions options_;
  std::unique_ptr<FrameSource> camera_;
  std::unique_ptr<Participant> participant_;
  std::atomic<bool> stopping_{false}, script_done_{false};
  std::thread poses_, frames_;
};

/// What a participant does around its life in a viewer (live_in_viewer), beyond joining, rejoining
/// and leaving.
struct ParticipantLife {
  std::string session_name;  ///< written to ViewerResult::session_name when it leaves
  /// Once joined on the first connection (not again after a cut): e.g. its voice starts.
  std::function<void(SessionClient&)> joined;
  /// Once receiving has ended, before it stops: e.g. its voice stops and reports.
  std::function<void(SessionClient&, ViewerResult&)> leaving;
};

/// The one lifecycle of a participant that watches the stream through run_viewer (the window, the
/// headset, the OR display, the demo's participants and OR display): sets `viewer`'s
/// on_connected (SessionClient::start, then life.joined), on_reconnected (reattach: after a cut it
/// rejoins as itself on the new connection, when viewer.reconnect is on) and on_finished
/// (life.leaving, stop, and the participant's session figures into the result). `client` must
/// outlive run_viewer; `viewer`'s other fields are left as they are.
void live_in_viewer(SessionClient& client, ViewerOptions& viewer, ParticipantLife life = {});

}  // namespace volcast
