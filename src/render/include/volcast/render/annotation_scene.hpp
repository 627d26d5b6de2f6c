#pragma once
// What pointing and drawing look like: a participant's laser pointer and strokes, arrows and
// labels, from plain points (pipeline/session_scene.hpp draws the session's annotations with
// them), as primitives for PrimitiveRenderer. Room frame,
// metres. Everything glows (emissive) in its owner's colour, so that it reads on the live clouds
// under any light, and is depth-tested, so that what stands in front of it hides it.
#include <span>
#include <vector>

#include "volcast/render/primitive_renderer.hpp"

namespace volcast {

/// A participant's colour (linear RGB 0..1) by id: its mesh avatar, effects, pointer and drawings
/// (six colours, repeating).
Eigen::Vector3f participant_color(uint32_t id);

/// `p` moved towards `eye` on the line from the eye through it by 2 cm + `lift_per_m` of their
/// distance (default 1 %; at most half of it; room frame, metres): it projects where p does for
/// that eye, and a mark on a measured surface drawn there is not buried in it -- depth noise (about
/// 1 cm at 3 m for a time-of-flight camera) and the cameras' registration error (a few cm between
/// cameras) -- while anything more than that in front of it (a hand over the patient) still hides
/// it.
Eigen::Vector3f toward_eye(const Eigen::Vector3f& p, const Eigen::Vector3f& eye,
                           float lift_per_m = 0.01f);

/// A laser pointer from `origin`: a beam 5 mm wide to `hit`, and there a dot 3 cm across and 4 mm
/// thick facing `eye` (the viewer's eye), at toward_eye(hit, eye, lift_per_m): it projects exactly
/// where the
/// hit does and stands out of the surface it lies on. Without a hit (`has_hit` false) the beam runs
/// 3 m towards `hit` and has no dot. Empty if origin and hit coincide.
std::vector<Primitive> pointer_primitives(const Eigen::Vector3f& origin, bool has_hit,
                                          const Eigen::Vector3f& hit, const Eigen::Vector3f& rgb,
                                          const Eigen::Vector3f& eye, float lift_per_m = 0.01f);

/// The marks (their points as they are: lift them with toward_eye first to keep them out of the
/// surface they were drawn on). A stroke: a tube 8 mm wide through `points` (a ball at each
/// joint).
std::vector<Primitive> stroke_primitives(std::span<const Eigen::Vector3f> points,
                                         const Eigen::Vector3f& rgb);
/// An arrow: a tube 1 cm wide from `tail` with a cone-like head 6 cm long (at most the arrow's
/// length) at `head`. Empty if they are less than 0.1 mm apart.
std::vector<Primitive> arrow_primitives(const Eigen::Vector3f& tail, const Eigen::Vector3f& head,
                                        const Eigen::Vector3f& rgb);
/// A label's pin: a ball 2.5 cm wide at `pin` and a stick up to a flag 6 x 4 cm at
/// label_anchor(pin); its text is drawn by the viewer's overlay.
std::vector<Primitive> label_pin_primitives(const Eigen::Vector3f& pin, const Eigen::Vector3f& rgb);

/// Where a label's text goes: the top of its pin's stick, 12 cm above `pin` (room frame, metres).
Eigen::Vector3f label_anchor(const Eigen::Vector3f& pin);

}  // namespace volcast
