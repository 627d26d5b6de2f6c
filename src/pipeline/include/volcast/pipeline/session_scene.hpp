#pragma once
// What a participant sees in the virtual operating room (Fischer et al. 2024, §3.4), drawn into
// any RenderTarget: the OR site's cameras placed by room_from_site, every other participant with
// a camera as a live point-cloud avatar (only points within keep_radius_m of that participant's
// interpolated head), its own camera likewise with its own headset hidden, a mesh avatar (head and
// hands) for each participant without a camera, everyone's pointers and the session's annotations,
// the room (floor, walls, table, lamp), teleport effects, the patient case's objects where the
// session has them (held ones brightened) and the wall monitor's CT slice. One GL context; every
// call with it current.
#include <memory>
#include <optional>
#include <span>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/pipeline/frame_feed.hpp"
#include "volcast/pipeline/live_surfaces.hpp"
#include "volcast/render/annotation_scene.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/render/primitive_renderer.hpp"
#include "volcast/render/render_target.hpp"
#include "volcast/render/view.hpp"
#include "volcast/session/participant.hpp"

namespace volcast {

struct ViewerOptions;  // receiver.hpp

struct SessionSceneOptions {
  CameraPassOptions pass;      ///< surface, splat size, blending (per-camera looks ignored)
  float keep_radius_m = 0.6f;  ///< the head-radius filter of the others' camera avatars
  /// Draw the own camera's points: those within keep_radius_m of the own head, the headset's
  /// hidden.
  bool show_own_camera = true;
  bool room = true;       ///< draw the room's furniture
  bool show_case = true;  ///< draw the case's objects and the monitor's CT slice
  float teleport_effect_s = 0.8f;
  /// Your own microphone is muted: a red ball over your left hand (muted_hand_primitives; the
  /// headset's sign, with tracked hands).
  bool own_muted = false;
  /// The headset wearer's head now (room frame; -z ahead, +y up), for what stays fixed in its
  /// view: while the session is recorded, a red ball up and to the left
  /// (recording_badge_primitives). Unset (a window, which draws its own badge): none.
  std::optional<RigidTransform> world_from_head;
  /// A voice's volume the headset wearer just stepped (voice::step_volume): a bar over where
  /// the voice comes from (volume_bar_primitives; room frame, metres, gain 0 to 4).
  struct VolumeShown {
    Eigen::Vector3f at = Eigen::Vector3f::Zero();
    float gain = 1;
  };
  std::optional<VolumeShown> volume_shown;
  /// Draw this participant's own pointer. A window that finds its pointer's hit in the depth
  /// under the mouse leaves it out (it would hit its own dot) and draws it after
  /// (SessionScene::draw_primitives).
  bool own_pointer = true;
};

/// The filter for another participant's camera avatar: keep the points within `radius_m` of its
/// (interpolated) head; none before its first pose.
AvatarFilter remote_avatar_filter(const RemoteParticipant& other, float radius_m);
/// The filter for the participant's own camera: its points within `radius_m` of its head (its
/// body, not the room behind it), without those of the headset (HideBox at the head); none
/// before its first pose.
AvatarFilter own_camera_filter(const SessionSnapshot& snapshot, float radius_m);

/// Which of the session's marks drawing_primitives draws, and how far out of their surface.
struct DrawingOptions {
  bool own_pointer = true;  ///< false: leave out this participant's own pointer
  /// false: leave out every annotation on the monitor (a view of the real OR, which has none)
  bool on_monitor = true;
  /// Each mark is lifted towards the eye by 2 cm + this much of its distance (toward_eye): 1 % for
  /// views of the fused clouds; more for one camera's own picture, whose depth differs from the
  /// other cameras' surface a stroke was drawn on by their registration error.
  float lift_per_m = 0.01f;
};

/// The session's pointers and annotations as the snapshot has them (annotation_scene.hpp, each in
/// its owner's colour; pointer dots facing `eye`, room frame; every mark lifted towards `eye` out
/// of the surface it was drawn on: toward_eye), added to `out`; an annotation on the monitor only
/// while it shows the CT slice (and case) it was drawn on.
void drawing_primitives(const SessionSnapshot& snapshot, const Eigen::Vector3f& eye,
                        std::vector<Primitive>& out, const DrawingOptions& options = {});

/// One annotation as render/annotation_scene.hpp draws its kind (its points as they are: lift them
/// with toward_eye first): a stroke through its points, an arrow from its tail to its head, a
/// label's pin. Empty for an arrow without two points or a label without one.
std::vector<Primitive> annotation_primitives(const session::Annotation& a,
                                             const Eigen::Vector3f& rgb);
/// Where a label's text goes: label_anchor of its pin (room frame, metres; zero without a point).
Eigen::Vector3f label_anchor(const session::Annotation& a);

/// The eye of a participant: its own head (OpenXR view space = our View frame), with a 90°
/// vertical field of view; before any pose, standing at its spot 1.6 m high, facing its yaw.
View participant_eye(const SessionSnapshot& snapshot, float aspect);

class SessionScene {
 public:
  /// Throws Error like CameraRenderer (no context, GL < 4.5).
  SessionScene();
  ~SessionScene();
  SessionScene(const SessionScene&) = delete;
  SessionScene& operator=(const SessionScene&) = delete;
  /// Draws the scene through `view` at local wall-clock time `now_us`. `site` and `site_frames`:
  /// the OR site's cameras (site frame, as the Welcome gave them) and their newest frames (null
  /// until one arrived). Decodes the others' new avatar frames (Participant::avatar_frame).
  /// Throws Error if a frame does not decode or OpenGL fails.
  void draw(const View& view, const RenderTarget& target, std::span<const CameraCalibration> site,
            std::span<const std::shared_ptr<const CameraFrame>> site_frames,
            Participant& participant, int64_t now_us, const SessionSceneOptions& options = {});
  /// Draws `primitives` (room frame) over what draw() drew, lit as the room is.
  void draw_primitives(const View& view, const RenderTarget& target,
                       std::span<const Primitive> primitives);
  /// How many cameras the last draw had: the site's, then the avatars'.
  size_t cameras_drawn() const;
  /// GL_RENDERER and GL_VERSION of the current context.
  std::string gl_description() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// The headless presenter of a participant: an EGL target of options.width x height that draws
/// the SessionScene from the participant's eye about `fps` times a second (the others move even
/// when the site's frames repeat), and writes options.screenshot (the eye's view) at the end.
/// `participant` returns the participant once joined (null before). `surfaces`, if given, is kept
/// up to date with the site's newest frames (a pose script's pointer meets them).
Presenter session_presenter(const ViewerOptions& options, std::function<Participant*()> participant,
                            SessionSceneOptions scene = {}, double fps = 30,
                            std::shared_ptr<LiveSurfaces> surfaces = nullptr);

}  // namespace volcast
