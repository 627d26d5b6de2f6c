#pragma once
// The patient case in the virtual OR (room/patient_case.hpp): its organ meshes, each object placed
// by its room_from_object, lit like the room (primitive_renderer.hpp's shading), half-transparent
// parts (the liver's shell, the skin) blended over what is inside them; and the virtual monitor, a
// quad showing the CT slice the session's monitor state asks for. OpenGL 4.5 core, drawn into a
// RenderTarget over what is there (no clear), depth-tested against it; creates no context.
//
// Transparent parts are drawn after the opaque ones, far to near by their centre, each twice:
// back faces, then front faces, blended (src alpha, 1 - src alpha) without depth writes.
#include <Eigen/Core>
#include <memory>
#include <span>

#include "volcast/render/primitive_renderer.hpp"
#include "volcast/render/render_target.hpp"
#include "volcast/render/view.hpp"
#include "volcast/room/patient_case.hpp"

namespace volcast {

/// Where an object is drawn (room_from_object) and whether to brighten it (someone holds it).
struct PlacedObject {
  Pose pose;
  float highlight = 0;  ///< 0..1 mixed toward the unlit colour
};

class CaseRenderer {
 public:
  /// Builds the programs in the OpenGL 4.5 context current on this thread. Throws Error if none
  /// is current, it is older than 4.5, or a shader fails.
  CaseRenderer();
  ~CaseRenderer();
  CaseRenderer(const CaseRenderer&) = delete;
  CaseRenderer& operator=(const CaseRenderer&) = delete;
  /// Clears `target` (a dark background, depth far): for a picture of the case alone.
  void clear(const RenderTarget& target);
  /// Draws the objects of `c` at `placed` (one per object, same order; extra objects are not
  /// drawn). A case seen for the first time (another address or generation) is uploaded first.
  /// Throws Error if OpenGL fails.
  void draw(const View& view, const RenderTarget& target, const SharedCase& c,
            std::span<const PlacedObject> placed, const Lighting& lighting = {});
  /// Draws the monitor: slice state.slice of `series` in its window, with the overlay when
  /// state.overlay, on the unit quad [-0.5, 0.5]^2 (z = 0, facing +z, image up = +y) placed by
  /// `world_from_quad`. The slice is made again only when the state or series changes.
  void draw_monitor(const View& view, const RenderTarget& target, const MonitorSeries& series,
                    const MonitorState& state, const Eigen::Matrix4f& world_from_quad);

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast
