#pragma once
// Lit solid shapes -- the virtual operating room's furniture, mesh avatars, teleport effects --
// drawn with OpenGL 4.5 core into a RenderTarget on top of what is there (it does not clear):
// CameraRenderer::draw_cameras clears and draws the point clouds first and leaves their depth, so
// clouds and furniture occlude each other. Like the other passes it creates no context and reads
// nothing back.
//
// Shading: Lambert diffuse from a directional key light and a point light (the OR lamp, smooth
// falloff to zero at point_range_m) plus ambient, in linear RGB; `emissive` mixes toward the
// unlit colour. Opaque shapes (alpha 1) are drawn first with depth writes; then the others back to
// front (by distance of their origin to the eye), blended (src alpha, 1 - src alpha), depth-tested
// without depth writes.
#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <span>

#include "volcast/render/render_target.hpp"
#include "volcast/render/view.hpp"

namespace volcast {

/// One shape. The unit shapes, in their own frame (metres): box = cube [-0.5, 0.5]^3; sphere =
/// radius 0.5 about the origin; cylinder = radius 0.5 about +y, y in [-0.5, 0.5], capped; ring =
/// flat annulus in the xz plane (y = 0), radius 0.4 to 0.5, seen from both sides.
struct Primitive {
  enum class Shape : uint8_t { kBox, kSphere, kCylinder, kRing };
  Shape shape = Shape::kBox;
  /// Places (and scales) the unit shape in the world: p_world = world_from_shape * p_shape.
  Eigen::Matrix4f world_from_shape = Eigen::Matrix4f::Identity();
  Eigen::Vector4f color{1, 1, 1, 1};  ///< linear RGB 0..1, alpha 0..1 (< 1: blended)
  float emissive = 0;                 ///< 0 lit, 1 unlit (the lamp's glow, effects)
};

/// World-frame lights (metres, linear RGB).
struct Lighting {
  Eigen::Vector3f to_key_light{0.3f, 1.0f, 0.2f};  ///< direction towards the key light
  Eigen::Vector3f key_color{0.75f, 0.75f, 0.72f};
  Eigen::Vector3f ambient{0.28f, 0.30f, 0.33f};
  bool point_light = true;
  Eigen::Vector3f point_position{0, 2.2f, 0};
  Eigen::Vector3f point_color{0.6f, 0.6f, 0.55f};
  float point_range_m = 4;
};

/// A box primitive: centre (world, metres), full size along its axes (metres), turned yaw_rad
/// about +y.
Primitive box(const Eigen::Vector3f& center, const Eigen::Vector3f& size,
              const Eigen::Vector4f& rgba, float yaw_rad = 0, float emissive = 0);

class PrimitiveRenderer {
 public:
  /// Builds the program and the four unit meshes in the OpenGL 4.5 context current on this
  /// thread. Throws Error if none is current, it is older than 4.5, or a shader fails.
  PrimitiveRenderer();
  ~PrimitiveRenderer();
  PrimitiveRenderer(const PrimitiveRenderer&) = delete;
  PrimitiveRenderer& operator=(const PrimitiveRenderer&) = delete;
  /// Draws `primitives` through `view` into `target` without clearing it (see the top of this
  /// file). Leaves the scissor test off, depth test LESS with writes on and blending off. Throws
  /// Error if the viewport is empty, the framebuffer incomplete or OpenGL reports an error.
  void draw(const View& view, const RenderTarget& target, std::span<const Primitive> primitives,
            const Lighting& lighting = {});

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast
