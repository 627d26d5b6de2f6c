#pragma once
// A tracked controller's laser pointer and freehand drawing (issue 36; a headset's right
// controller, xr_controllers.hpp): while its point or draw button is held, the pointer is shown
// to everyone from the controller's aim ray (room frame, metres), its dot where the ray first
// meets the live clouds (LiveSurfaces: the site cameras' newest depth, what the headset draws of
// them) or no dot where it meets nothing; letting go of both puts it away (sent once). While the
// draw button is held each hit at least 3 mm from the stroke's last point is added (at most
// session::kMaxStrokePoints); letting go sends the stroke if it has 2 points or more (one the
// participant refuses to send, past a limit, is logged and dropped). A label press pins one of
// the preset labels (kHeadsetLabels, the browser's headset presets) where the ray meets a
// surface; an erase press erases this participant's newest annotation as the window's Backspace
// does (session/erase_last.hpp: one it sent that has not come back numbered yet is waited for).
#include <array>
#include <optional>
#include <string_view>
#include <vector>

#include "volcast/reconstruct/surface_hit.hpp"
#include "volcast/session/erase_last.hpp"
#include "volcast/session/participant.hpp"

namespace volcast {

/// One frame of a pointing controller: its aim ray (room frame, metres; `direction` any length)
/// and its buttons.
struct PointerInput {
  bool tracked = false;  ///< the aim pose was located (else the pointer is put away)
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();
  Eigen::Vector3f direction = Eigen::Vector3f(0, 0, -1);
  bool point = false;  ///< the point button is held
  bool draw = false;   ///< the draw button is held
  /// The label button went down this frame: the index in kHeadsetLabels of the preset to pin
  /// (labeled_preset: where the stick leans), -1 for none.
  int label = -1;
  bool erase = false;  ///< the erase button went down this frame
};

/// The preset labels a headset pins, as the browser's headset mode (web/page/app.js XR_LABELS):
/// the stick at rest, leaned up (forward), right, down, left.
inline constexpr std::array<std::string_view, 5> kHeadsetLabels = {"here", "cut here", "careful",
                                                                   "not here", "look"};

/// Which of kHeadsetLabels a thumbstick at (x, y) picks (OpenXR: x right, y up, each -1..1):
/// within 0.5 of rest "here", else the axis it leans along the most.
int labeled_preset(float x, float y);

class HandPointing {
 public:
  /// Acts on `participant` for this frame: where `in`'s ray meets `surfaces` (null: nothing), the
  /// pointer sent while a button is held, the stroke drawn so far, sent when draw is let go. Call
  /// once per frame (the session's pose rate limit, 150 a second, is above a headset's 90 Hz).
  /// A label press pins its preset at the hit (nothing where the ray meets no surface: logged);
  /// an erase press erases the newest annotation in `snapshot` that this participant drew, once
  /// those it sent are back. `now_us`: a steady clock, µs.
  void update(Participant& participant, const SessionSnapshot& snapshot, const SurfaceHit* surfaces,
              const PointerInput& in, int64_t now_us);
  /// The dot this frame (room frame), if the ray met a surface while a button was held (point,
  /// draw, or a label pressed this frame).
  const std::optional<Eigen::Vector3f>& hit() const { return hit_; }
  /// The stroke being drawn (room frame), empty when none.
  const std::vector<Eigen::Vector3f>& stroke() const { return stroke_; }

 private:
  bool shown_ = false;  // the pointer was last sent on
  bool drawing_ = false;
  std::optional<Eigen::Vector3f> hit_;
  Eigen::Vector3f last_origin_ = Eigen::Vector3f::Zero();
  std::vector<Eigen::Vector3f> stroke_;
  session::EraseLast erase_last_;
  void send(Participant& p, session::Annotation a, int64_t now_us);
};

}  // namespace volcast
