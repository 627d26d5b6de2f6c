#pragma once
// What the draw passes share (internal to src/render): shader building, textures, and the avatar
// filter's GLSL and uniforms.
#include <epoxy/gl.h>

#include <Eigen/Core>
#include <string>
#include <string_view>

#include "volcast/reconstruct/avatar_filter.hpp"
#include "volcast/render/render_target.hpp"

namespace volcast::gl {

/// Compiles and links a program from the given stages (geometry may be null). Throws Error
/// starting with `pass` and carrying the driver's log if a stage does not compile or link.
GLuint link_program(const char* pass, const char* vertex, const char* geometry,
                    const char* fragment);

/// Compiles and links a compute program; throws as link_program does.
GLuint link_compute(const char* pass, const char* compute);

/// A 2D texture with one level of `format`, nearest filtering, clamped to its edges.
GLuint make_texture(GLenum format, int width, int height);

/// Throws Error starting with `pass` unless an OpenGL 4.5 desktop context is current on this
/// thread (every pass's constructor calls it).
void require_gl45(const char* pass);

/// Binds `target` for drawing without clearing it: checks it (Error starting with `pass` if the
/// viewport is empty or the framebuffer incomplete), binds its framebuffer, sets the viewport and
/// a scissor to it.
void bind_target(const char* pass, const RenderTarget& target);

/// Starts a pass in `target`: binds its framebuffer, sets the viewport and a scissor to it, clears
/// it (colour dark grey-blue, depth far) and sets depth test LESS, no blending, program point
/// size. Throws Error starting with `pass` if the viewport is empty or the framebuffer incomplete.
void begin_target(const char* pass, const RenderTarget& target);

/// Throws Error("<pass>: OpenGL error 0x... <what>") if glGetError() reports one.
void check(const char* pass, const char* what);

/// `body` (GLSL without a #version line: src/render/glsl/README.md) as GLSL 4.50 core, with
/// BINDING(n) meaning layout(binding = n). The avatar filter's GLSL (avatar_hidden(p), for points
/// in the frame of the pass's points) is glsl::kAvatarFilterGlsl.
std::string glsl450(std::string_view body);

/// The filter's uniform locations in one program.
struct FilterUniforms {
  GLint keep_sphere = -1, headset_from_points = -1, hide_half_extent = -1;
  explicit FilterUniforms(GLuint program = 0);
  /// Sets them (program in use) for points in a frame placed by `world_from_points`.
  void set(const AvatarFilter& filter, const Eigen::Matrix4f& world_from_points) const;
};

}  // namespace volcast::gl
