#pragma once
// The desktop participant's laser pointer and drawing (internal to volcast_viewer_desktop; issue
// 36): hold L and the pointer follows the mouse, its dot where the mouse's ray meets what the
// window drew (render/drawn_depth.hpp: the live clouds, organs, monitor, room); drag
// with the left button while holding L or Shift to draw a stroke, with the right button (L held)
// or Alt + left for an arrow; N pins the panel's label text where the mouse points; Backspace
// erases your last annotation. The same keys as the browser page's. The panel's annotations
// section lists the session's annotations with an erase button each, and the label text.
#include <optional>
#include <string>
#include <vector>

#include "volcast/render/primitive_renderer.hpp"
#include "volcast/render/render_target.hpp"
#include "volcast/render/view.hpp"
#include "volcast/session/erase_last.hpp"
#include "volcast/session/participant.hpp"

namespace volcast {

struct PointingState {
  bool laser = false;                                ///< L held
  bool dragging = false;                             ///< a drawing drag (L, Shift or Alt) goes on
  bool drawing = false;                              ///< left button held with L: a stroke
  bool arrow = false;                                ///< right button held with L: an arrow
  bool pin_label = false;                            ///< N pressed: pin the label at the dot
  bool erase_pressed = false;                        ///< Backspace went down since the last frame
  session::EraseLast erase_last;                     ///< "erase my last" (erase_last.hpp)
  std::vector<Eigen::Vector3f> stroke;               ///< the stroke being drawn (room frame)
  std::optional<Eigen::Vector3f> arrow_tail;         ///< where the arrow began
  std::optional<Eigen::Vector3f> hit;                ///< the dot this frame (room frame)
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();  ///< the pointer's origin (room frame)
  char label[65] = "here";                           ///< the panel's label text
  std::string status;                                ///< the last refusal, for the panel
};

/// After the scene is drawn into `target` through `view` (its depth buffer current), before the
/// panel: reads the depth under the mouse (window pixel (x, y) from the top left, in framebuffer
/// pixels), moves the pointer and sends what the state asks (the pointer while L is held and once
/// put away; a stroke or arrow when its button is let go; a label; an erase once what was sent
/// before its press is back: session::EraseLast). Returns what to draw over the scene: the own
/// pointer and the stroke being drawn, in `rgb`. `now_us`: a steady clock, µs.
std::vector<Primitive> point_and_draw(PointingState& state, Participant& participant,
                                      const SessionSnapshot& snapshot, const View& view,
                                      const RenderTarget& target, double x, double y,
                                      const Eigen::Vector3f& rgb, int64_t now_us);

/// The labels' text over the scene (ImGui's background draw list, between NewFrame and Render),
/// each at its pin's top in its author's colour; `width` x `height` the window's size.
void draw_label_texts(const SessionSnapshot& snapshot, const View& view, float width, float height);

/// The panel's annotations section: the label text, the keys, the session's annotations (kind,
/// author) with an erase button each.
void draw_annotation_panel(PointingState& state, Participant& participant,
                           const SessionSnapshot& snapshot);

}  // namespace volcast
