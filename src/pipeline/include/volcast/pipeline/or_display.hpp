#pragma once
// The OR's view of the remote experts (issue 36, item 3): what the local team, who wear no
// headset, see on the OR's wall monitor -- a real OR camera's own colour image, from that camera's
// exact viewpoint (its intrinsics and world_from_camera), with the remote participants' avatars,
// their pointers and the session's annotations drawn into it, hidden by the live depth where a
// real surface stands in front of them (a stroke behind the surgeon's hand is hidden by the hand).
//
// The camera's frame is undistorted first (filter/filters.hpp make_pixel_map: a pinhole with the
// factory fx, fy, cx, cy) and its depth holes filled (HoleFiller, so that a hand's dark glove
// still hides what is behind it), then drawn as the backdrop (render/backdrop_renderer.hpp);
// avatars are mesh avatars (head and hands) in their colours, with the voice badge of whoever
// speaks; the OR display's own participant (it joins to see the session) is not drawn.
#include <functional>
#include <memory>
#include <string>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/pipeline/frame_feed.hpp"
#include "volcast/render/render_target.hpp"
#include "volcast/session/participant.hpp"

namespace volcast {

struct ViewerOptions;  // receiver.hpp

/// The picture size of the OR display of `camera` (its depth image's: the backdrop is drawn
/// pixel for pixel).
struct OrDisplaySize {
  int width = 0, height = 0;
};
OrDisplaySize or_display_size(const CameraCalibration& camera);

/// How far the OR display lifts each mark towards its camera: 2 cm + this much of the distance
/// (toward_eye; the fused clouds' views lift 1 %), against the cameras' registration error.
inline constexpr float kOrDisplayLiftPerM = 0.03f;

/// A label's text as the OR display shows it (the window draws it over the picture; the
/// headless picture has the pin and flag only).
struct OrDisplayLabel {
  std::string text;  ///< sanitised by the hub (session/annotations.hpp check_label_text)
  /// Where the top of its pin's stick (label_anchor) lands in the camera's undistorted picture,
  /// moved onto the picture's edge if beyond it: pixels from the top-left corner, x right, y down
  /// (the unturned picture).
  Eigen::Vector2f pixel = Eigen::Vector2f::Zero();
  Eigen::Vector3f rgb = Eigen::Vector3f::Ones();  ///< its author's colour, linear 0..1
};

class OrDisplay {
 public:
  /// Throws Error like the render passes (no GL 4.5 context current).
  OrDisplay();
  ~OrDisplay();
  OrDisplay(const OrDisplay&) = delete;
  OrDisplay& operator=(const OrDisplay&) = delete;
  /// Draws the OR display of site camera `camera` (site frame, as the Welcome gave it) over its
  /// frame `frame` into `target` (of or_display_size(camera)), with what `snapshot` has (room
  /// frame; placed through its room_from_site), at local wall-clock time `now_us`. Throws Error
  /// if the frame's size is not the camera's or OpenGL fails.
  void draw(const RenderTarget& target, const CameraCalibration& camera, const CameraFrame& frame,
            const SessionSnapshot& snapshot, int64_t now_us);
  /// The camera's undistorted calibration in the room frame that the last draw used: a room point
  /// p shows at the pixel this pinhole projects it to.
  const CameraCalibration& room_camera() const;
  /// The labels of `snapshot` (as last drawn) whose pin (their point) lies in front of the
  /// camera, inside its picture and not behind the live depth there (a real surface nearer than
  /// the pin's lift, kOrDisplayLiftPerM, hides it, as it hides the pin); empty before the first
  /// draw.
  std::vector<OrDisplayLabel> labels(const SessionSnapshot& snapshot) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// How many quarter turns counter-clockwise show the picture of a camera at `room_from_camera`
/// with the room's up (+y) upwards (0..3: a camera mounted on its side gives 1 or 3).
int upright_quarter_turns(const RigidTransform& room_from_camera);
/// `image` turned `quarter_turns` quarter turns counter-clockwise (negative: clockwise).
ColorImage turned(const ColorImage& image, int quarter_turns);
/// Where the point `pixel` (pixels from the top left, x right, y down) of a `width` x `height`
/// picture lands in that picture turned `quarter_turns` quarter turns counter-clockwise (as
/// turned() turns it); continuous coordinates: the corner (0, 0) of pixel (0, 0) maps to a corner.
Eigen::Vector2f turned_point(const Eigen::Vector2f& pixel, int width, int height,
                             int quarter_turns);

/// The headless presenter of an OR display: an EGL target of the camera's size drawing the OR
/// display of site camera `camera` (an index into the Welcome's cameras) about `fps` times a
/// second, and writing options.screenshot at the end, turned upright (upright_quarter_turns).
/// `participant` returns the OR display's participant once joined (null before). Throws Error (from
/// the render thread) if the site has no camera `camera`.
Presenter or_display_presenter(const ViewerOptions& options, size_t camera,
                               std::function<Participant*()> participant, double fps = 15);

}  // namespace volcast
