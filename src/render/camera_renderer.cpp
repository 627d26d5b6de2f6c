#include "volcast/render/camera_renderer.hpp"

#include <epoxy/gl.h>
#include <fmt/format.h>

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <utility>
#include <vector>

#include "gl_util.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/ray_table.hpp"
#include "volcast/reconstruct/point_cloud.hpp"
#include "volcast/render/colour_balance.hpp"
#include "volcast/render/glsl.hpp"

namespace volcast {
namespace {

constexpr const char* kPass = "camera renderer";
constexpr float kEdgeStep = 0.05f;      // a 4-neighbour this much of the depth away is an edge
constexpr int kUploadsPerBalance = 15;  // new images between colour balance estimates

// One camera: its textures, where it sits, and its mesh's kept triangles.
struct GpuCamera {
  Intrinsics intrinsics;  // what `rays` was made from
  int width = 0, height = 0;
  GLuint rays = 0, depth = 0, color = 0;
  bool uploaded = false, has_color = false;
  Eigen::Matrix4f world_from_camera = Eigen::Matrix4f::Identity();
  float radius_per_metre = 0;
  // The mesh (glsl/mesh_indices.comp): up to 6 indices per 2x2 pixel quad, and the indirect draw
  // command whose count the compute pass sets. Made again when the images, the avatar filter, the
  // pose (the filter is in the world) or the edge threshold change.
  GLuint mesh_indices = 0, mesh_command = 0;
  bool mesh_current = false;
  float mesh_edge_ratio = 0;
  AvatarFilter filter;  // this camera's (set_avatar_filter)
  // Blending's reliability (glsl/edges.frag, edge_rows.frag, reliability.frag): made again with
  // each new image.
  GLuint edges = 0, across = 0, reliability = 0;
  bool reliability_current = false;
  int reliability_radius = 0;
  ColourSamples samples;  // colour balance's, taken at upload
  Eigen::Vector3f gain = Eigen::Vector3f::Ones();
};

// DrawElementsIndirectCommand (OpenGL 4.5 §10.4).
struct IndirectCommand {
  uint32_t count, instance_count, first_index;
  int32_t base_vertex;
  uint32_t base_instance;
};

// Uniform locations every camera program has.
struct CameraUniforms {
  GLint has_color = -1, size = -1, view_from_camera = -1, clip_from_view = -1, tint = -1,
        depth_push = -1, accumulate = -1, weighting = -1, erode_push = -1, gain = -1,
        viewport_size = -1, blend_push = -1;
  gl::FilterUniforms filter;
  CameraUniforms() = default;
  explicit CameraUniforms(GLuint p)
      : has_color(glGetUniformLocation(p, "has_color")),
        size(glGetUniformLocation(p, "size")),
        view_from_camera(glGetUniformLocation(p, "view_from_camera")),
        clip_from_view(glGetUniformLocation(p, "clip_from_view")),
        tint(glGetUniformLocation(p, "tint")),
        depth_push(glGetUniformLocation(p, "depth_push")),
        accumulate(glGetUniformLocation(p, "accumulate")),
        weighting(glGetUniformLocation(p, "weighting")),
        erode_push(glGetUniformLocation(p, "erode_push")),
        gain(glGetUniformLocation(p, "gain")),
        viewport_size(glGetUniformLocation(p, "viewport_size")),
        blend_push(glGetUniformLocation(p, "blend_push")),
        filter(p) {}
};

}  // namespace

struct CameraRenderer::Impl {
  GLuint splat_program = 0, mesh_program = 0, resolve_program = 0, mesh_index_program = 0,
         edges_program = 0, edge_rows_program = 0, reliability_program = 0, empty_vao = 0;
  CameraUniforms splat, mesh;
  GLint size_mode = -1, fixed_px = -1, radius_per_metre = -1, splat_scale = -1,
        pixels_per_unit = -1, half_viewport = -1;  // splats
  GLint index_size = -1, index_edge_ratio = -1;    // the mesh's triangle pass
  gl::FilterUniforms index_filter;
  GLint resolve_origin = -1, resolve_weighting = -1, resolve_viewport = -1,
        resolve_view_from_clip = -1, resolve_clip_from_view = -1;
  GLint edges_size = -1, edges_step = -1, rows_size = -1, rows_radius = -1, reliability_size = -1,
        reliability_radius = -1;
  GLuint reliability_fbo = 0;  // the reliability passes draw into each image in turn
  // time_passes: timestamps before the updates, after them, then after each pass.
  bool timing = false, timed_blend = false, timed = false;
  GLuint stamps[6] = {};
  void stamp(int i) const {
    if (timing) glQueryCounter(stamps[i], GL_TIMESTAMP);
  }
  int uploads_since_balance = kUploadsPerBalance;
  std::vector<GpuCamera> cameras;
  size_t ray_tables_uploaded = 0;  // set_cameras
  AvatarFilter filter;
  // The blending pass's own framebuffer: accumulated color (RGBA16F), accumulated view depth
  // (RG32F) and the prepass's depth, with a copy of it the blending pass reads.
  GLuint blend_fbo = 0, accumulated = 0, blended_depth = 0, front_depth = 0, front_copy = 0;
  int blend_width = 0, blend_height = 0;

  static void delete_camera(const GpuCamera& c) {
    const GLuint t[6] = {c.rays, c.depth, c.color, c.edges, c.across, c.reliability};
    glDeleteTextures(6, t);
    const GLuint b[2] = {c.mesh_indices, c.mesh_command};
    glDeleteBuffers(2, b);
  }
  void delete_cameras() {
    for (const GpuCamera& c : cameras) delete_camera(c);
    cameras.clear();
  }

  // Makes camera c's kept triangles again if what they depend on changed (see GpuCamera).
  void update_mesh(GpuCamera& c, float max_edge_ratio) {
    if (c.mesh_current && c.mesh_edge_ratio == max_edge_ratio) return;
    if (!c.mesh_indices) {
      const auto quads = static_cast<GLsizeiptr>(c.width - 1) * (c.height - 1);
      glCreateBuffers(1, &c.mesh_indices);
      glNamedBufferStorage(c.mesh_indices, std::max<GLsizeiptr>(quads, 1) * 6 * 4, nullptr, 0);
      glCreateBuffers(1, &c.mesh_command);
      glNamedBufferStorage(c.mesh_command, sizeof(IndirectCommand), nullptr,
                           GL_DYNAMIC_STORAGE_BIT);
    }
    const IndirectCommand reset{0, 1, 0, 0, 0};
    glNamedBufferSubData(c.mesh_command, 0, sizeof reset, &reset);
    glUseProgram(mesh_index_program);
    glUniform2i(index_size, c.width, c.height);
    glUniform1f(index_edge_ratio, max_edge_ratio);
    index_filter.set(c.filter, c.world_from_camera);
    glBindTextureUnit(0, c.depth);
    glBindTextureUnit(1, c.rays);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 0, c.mesh_command);
    glBindBufferBase(GL_SHADER_STORAGE_BUFFER, 1, c.mesh_indices);
    glDispatchCompute(static_cast<GLuint>((c.width + 14) / 16),
                      static_cast<GLuint>((c.height + 14) / 16), 1);
    glMemoryBarrier(GL_ELEMENT_ARRAY_BARRIER_BIT | GL_COMMAND_BARRIER_BIT);
    c.mesh_current = true;
    c.mesh_edge_ratio = max_edge_ratio;
  }

  // Makes camera c's reliability texture again if its image or the radius changed: three
  // passes, each one triangle over the camera's image (glsl/README.md: the browser draws them
  // alike). Leaves the framebuffer, viewport and depth test for begin_target to set.
  void update_reliability(GpuCamera& c, int radius) {
    if (c.reliability_current && c.reliability_radius == radius) return;
    if (!c.edges) {
      c.edges = gl::make_texture(GL_R8UI, c.width, c.height);
      c.across = gl::make_texture(GL_R8UI, c.width, c.height);
      c.reliability = gl::make_texture(GL_RG16F, c.width, c.height);
    }
    if (!reliability_fbo) glCreateFramebuffers(1, &reliability_fbo);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, reliability_fbo);
    glViewport(0, 0, c.width, c.height);
    glDisable(GL_SCISSOR_TEST);
    glDisable(GL_DEPTH_TEST);
    glDisable(GL_BLEND);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    const auto draw_into = [&](GLuint image) {
      glNamedFramebufferTexture(reliability_fbo, GL_COLOR_ATTACHMENT0, image, 0);
      glDrawArrays(GL_TRIANGLES, 0, 3);
      glNamedFramebufferTexture(reliability_fbo, GL_COLOR_ATTACHMENT0, 0, 0);
    };
    glBindTextureUnit(0, c.depth);
    glBindTextureUnit(1, c.rays);
    glUseProgram(edges_program);
    glUniform2i(edges_size, c.width, c.height);
    glUniform1f(edges_step, kEdgeStep);
    draw_into(c.edges);
    glUseProgram(edge_rows_program);
    glUniform2i(rows_size, c.width, c.height);
    glUniform1i(rows_radius, radius);
    glBindTextureUnit(0, c.edges);
    draw_into(c.across);
    glUseProgram(reliability_program);
    glUniform2i(reliability_size, c.width, c.height);
    glUniform1i(reliability_radius, radius);
    glBindTextureUnit(0, c.depth);
    glBindTextureUnit(5, c.across);
    draw_into(c.reliability);
    c.reliability_current = true;
    c.reliability_radius = radius;
  }

  // Every kUploadsPerBalance new images, each camera's colour gain from the samples.
  void update_gains() {
    if (uploads_since_balance < kUploadsPerBalance) return;
    uploads_since_balance = 0;
    std::vector<ColourSamples> samples;
    samples.reserve(cameras.size());
    for (const GpuCamera& c : cameras) samples.push_back(c.uploaded ? c.samples : ColourSamples{});
    const std::vector<Eigen::Vector3f> gains = volcast::colour_gains(samples);
    for (size_t i = 0; i < cameras.size(); ++i) cameras[i].gain = gains[i];
  }

  void ensure_blend_target(int width, int height) {
    if (blend_fbo && blend_width == width && blend_height == height) return;
    if (blend_fbo) delete_blend_target();
    accumulated = gl::make_texture(GL_RGBA16F, width, height);
    blended_depth = gl::make_texture(GL_RG32F, width, height);
    front_depth = gl::make_texture(GL_DEPTH_COMPONENT32F, width, height);
    front_copy = gl::make_texture(GL_DEPTH_COMPONENT32F, width, height);
    glCreateFramebuffers(1, &blend_fbo);
    glNamedFramebufferTexture(blend_fbo, GL_COLOR_ATTACHMENT0, accumulated, 0);
    glNamedFramebufferTexture(blend_fbo, GL_COLOR_ATTACHMENT1, blended_depth, 0);
    glNamedFramebufferTexture(blend_fbo, GL_DEPTH_ATTACHMENT, front_depth, 0);
    const GLenum draw[2] = {GL_COLOR_ATTACHMENT0, GL_COLOR_ATTACHMENT1};
    glNamedFramebufferDrawBuffers(blend_fbo, 2, draw);
    blend_width = width;
    blend_height = height;
    if (const GLenum status = glCheckNamedFramebufferStatus(blend_fbo, GL_DRAW_FRAMEBUFFER);
        status != GL_FRAMEBUFFER_COMPLETE)
      throw Error(fmt::format("{}: blending framebuffer {}x{} is not complete (status {:#x})",
                              kPass, width, height, status));
  }

  void delete_blend_target() {
    glDeleteFramebuffers(1, &blend_fbo);
    const GLuint t[4] = {accumulated, blended_depth, front_depth, front_copy};
    glDeleteTextures(4, t);
    blend_fbo = 0;
  }

  // Draws every uploaded, visible camera once with the program in use.
  void draw_each(const CameraPassOptions& o, const View& view, bool as_mesh, float depth_push,
                 bool accumulate) {
    const CameraUniforms& u = as_mesh ? mesh : splat;
    const Eigen::Matrix4f view_from_world = view.world_from_view.inverse().matrix4f();
    glUniformMatrix4fv(u.clip_from_view, 1, GL_FALSE, view.clip_from_view.data());
    glUniform1f(u.depth_push, depth_push);
    glUniform1i(u.accumulate, accumulate ? 1 : 0);
    for (size_t i = 0; i < cameras.size(); ++i) {
      const GpuCamera& c = cameras[i];
      const CameraLook look = i < o.cameras.size() ? o.cameras[i] : CameraLook{};
      if (!c.uploaded || !look.visible) continue;
      const Eigen::Matrix4f view_from_camera = view_from_world * c.world_from_camera;
      glUniformMatrix4fv(u.view_from_camera, 1, GL_FALSE, view_from_camera.data());
      u.filter.set(c.filter, c.world_from_camera);
      glUniform2i(u.size, c.width, c.height);
      glUniform1i(u.has_color, c.has_color ? 1 : 0);
      glUniform4fv(u.tint, 1, look.tint.data());
      const Eigen::Vector3f gain = o.balance_colour ? c.gain : Eigen::Vector3f::Ones();
      glUniform3fv(u.gain, 1, gain.data());
      glBindTextureUnit(0, c.depth);
      glBindTextureUnit(1, c.rays);
      glBindTextureUnit(2, c.color);
      glBindTextureUnit(3, c.reliability);
      if (as_mesh) {
        glVertexArrayElementBuffer(empty_vao, c.mesh_indices);
        glBindBuffer(GL_DRAW_INDIRECT_BUFFER, c.mesh_command);
        glDrawElementsIndirect(GL_TRIANGLES, GL_UNSIGNED_INT, nullptr);
      } else {
        glUniform1f(radius_per_metre, c.radius_per_metre * o.splat_scale);
        glDrawArrays(GL_POINTS, 0, c.width * c.height);
      }
    }
  }
};

CameraRenderer::CameraRenderer() {
  gl::require_gl45(kPass);
  impl_ = std::make_unique<Impl>();
  Impl& r = *impl_;
  // The shaders are glsl/*, shared with the browser's renderer (glsl/README.md).
  const auto program = [](const char* pass, const char* vertex, const char* fragment) {
    return gl::link_program(pass, gl::glsl450(vertex).c_str(), nullptr,
                            gl::glsl450(fragment).c_str());
  };
  try {
    r.splat_program = program("camera renderer (splats)", glsl::kSplatVert, glsl::kSplatFrag);
    r.mesh_program = program("camera renderer (mesh)", glsl::kMeshVert, glsl::kMeshFrag);
    r.mesh_index_program = gl::link_compute("camera renderer (mesh triangles)",
                                            gl::glsl450(glsl::kMeshIndicesComp).c_str());
    r.resolve_program =
        program("camera renderer (blend resolve)", glsl::kFullscreenVert, glsl::kResolveFrag);
    r.edges_program =
        program("camera renderer (depth edges)", glsl::kFullscreenVert, glsl::kEdgesFrag);
    r.edge_rows_program =
        program("camera renderer (edge distance)", glsl::kFullscreenVert, glsl::kEdgeRowsFrag);
    r.reliability_program =
        program("camera renderer (reliability)", glsl::kFullscreenVert, glsl::kReliabilityFrag);
  } catch (...) {
    for (GLuint p : {r.splat_program, r.mesh_program, r.resolve_program, r.mesh_index_program,
                     r.edges_program, r.edge_rows_program, r.reliability_program})
      glDeleteProgram(p);
    throw;
  }
  r.splat = CameraUniforms(r.splat_program);
  r.mesh = CameraUniforms(r.mesh_program);
  r.size_mode = glGetUniformLocation(r.splat_program, "size_mode");
  r.fixed_px = glGetUniformLocation(r.splat_program, "fixed_px");
  r.radius_per_metre = glGetUniformLocation(r.splat_program, "radius_per_metre");
  r.pixels_per_unit = glGetUniformLocation(r.splat_program, "pixels_per_unit");
  r.splat_scale = glGetUniformLocation(r.splat_program, "splat_scale");
  r.half_viewport = glGetUniformLocation(r.splat_program, "half_viewport");
  r.index_size = glGetUniformLocation(r.mesh_index_program, "size");
  r.index_edge_ratio = glGetUniformLocation(r.mesh_index_program, "max_edge_ratio");
  r.index_filter = gl::FilterUniforms(r.mesh_index_program);
  r.resolve_origin = glGetUniformLocation(r.resolve_program, "origin");
  r.resolve_weighting = glGetUniformLocation(r.resolve_program, "weighting");
  r.resolve_viewport = glGetUniformLocation(r.resolve_program, "viewport_size");
  r.resolve_view_from_clip = glGetUniformLocation(r.resolve_program, "view_from_clip");
  r.resolve_clip_from_view = glGetUniformLocation(r.resolve_program, "clip_from_view");
  r.edges_size = glGetUniformLocation(r.edges_program, "size");
  r.edges_step = glGetUniformLocation(r.edges_program, "edge_step");
  r.rows_size = glGetUniformLocation(r.edge_rows_program, "size");
  r.rows_radius = glGetUniformLocation(r.edge_rows_program, "radius");
  r.reliability_size = glGetUniformLocation(r.reliability_program, "size");
  r.reliability_radius = glGetUniformLocation(r.reliability_program, "radius");
  glCreateVertexArrays(1, &r.empty_vao);  // the passes read textures, not attributes
}

CameraRenderer::~CameraRenderer() {
  Impl& r = *impl_;
  r.delete_cameras();
  if (r.blend_fbo) r.delete_blend_target();
  glDeleteFramebuffers(1, &r.reliability_fbo);
  if (r.stamps[0]) glDeleteQueries(6, r.stamps);
  glDeleteVertexArrays(1, &r.empty_vao);
  for (GLuint p : {r.splat_program, r.mesh_program, r.resolve_program, r.mesh_index_program,
                   r.edges_program, r.edge_rows_program, r.reliability_program})
    glDeleteProgram(p);
}

void CameraRenderer::set_cameras(std::span<const CameraCalibration> cameras) {
  Impl& r = *impl_;
  std::vector<GpuCamera> before = std::move(r.cameras);
  r.cameras.clear();
  // Those of `before` not taken over are deleted, whether this returns or throws.
  struct DeleteRest {
    std::vector<GpuCamera>& cameras;
    ~DeleteRest() {
      for (const GpuCamera& c : cameras) Impl::delete_camera(c);
    }
  } delete_rest{before};
  for (const CameraCalibration& cal : cameras) {
    const Intrinsics& k = cal.depth;
    if (k.width <= 0 || k.height <= 0 || k.width > 4096 || k.height > 4096)
      throw Error(fmt::format("{}: camera {} is {}x{} pixels (1..4096 per side)", kPass,
                              r.cameras.size(), k.width, k.height));
    const size_t at = r.cameras.size();
    if (at < before.size() && before[at].intrinsics == k) {  // its textures, as if new
      GpuCamera c = std::exchange(before[at], GpuCamera{});
      c.world_from_camera = cal.world_from_camera.matrix4f();
      c.uploaded = c.has_color = c.mesh_current = c.reliability_current = false;
      c.samples.world_from_camera = cal.world_from_camera;
      c.filter = r.filter;
      r.cameras.push_back(c);
      continue;
    }
    GpuCamera c;
    c.intrinsics = k;
    c.width = k.width;
    c.height = k.height;
    c.world_from_camera = cal.world_from_camera.matrix4f();
    c.radius_per_metre = splat_radius_per_metre(k);
    const std::shared_ptr<const RayTable> rays = shared_ray_table(k);
    c.samples.intrinsics = k;
    c.samples.world_from_camera = cal.world_from_camera;
    c.samples.rays = rays;
    ++r.ray_tables_uploaded;
    std::vector<float> xy(rays->x.size() * 2);
    for (size_t i = 0; i < rays->x.size(); ++i) {
      xy[2 * i] = rays->x[i];
      xy[2 * i + 1] = rays->y[i];
    }
    c.rays = gl::make_texture(GL_RG32F, c.width, c.height);
    c.depth = gl::make_texture(GL_R16UI, c.width, c.height);
    c.color = gl::make_texture(GL_RGBA8, c.width, c.height);
    r.cameras.push_back(c);              // owned from here: deleted with the others on error
    r.cameras.back().filter = r.filter;  // the filter for every camera, until one gets its own
    glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
    glTextureSubImage2D(c.rays, 0, 0, 0, c.width, c.height, GL_RG, GL_FLOAT, xy.data());
  }
  gl::check(kPass, "making camera textures");
}

void CameraRenderer::set_world_from_camera(size_t camera, const RigidTransform& world_from_camera) {
  Impl& r = *impl_;
  if (camera >= r.cameras.size())
    throw Error(
        fmt::format("{}: no camera {} (set_cameras gave {})", kPass, camera, r.cameras.size()));
  r.cameras[camera].world_from_camera = world_from_camera.matrix4f();
  r.cameras[camera].samples.world_from_camera = world_from_camera;
  r.cameras[camera].mesh_current = false;        // the avatar filter is in the world frame
  r.uploads_since_balance = kUploadsPerBalance;  // balance again with the new pose
}

size_t CameraRenderer::ray_tables_uploaded() const {
  return impl_->ray_tables_uploaded;
}

size_t CameraRenderer::camera_count() const {
  return impl_->cameras.size();
}

void CameraRenderer::upload(size_t camera, const CameraFrame& frame) {
  Impl& r = *impl_;
  if (camera >= r.cameras.size())
    throw Error(
        fmt::format("{}: no camera {} (set_cameras gave {})", kPass, camera, r.cameras.size()));
  GpuCamera& c = r.cameras[camera];
  if (frame.depth.width != c.width || frame.depth.height != c.height)
    throw Error(fmt::format("{}: camera {} depth is {}x{}, its calibration {}x{}", kPass, camera,
                            frame.depth.width, frame.depth.height, c.width, c.height));
  c.has_color = !frame.color.empty();
  if (c.has_color && (frame.color.width != c.width || frame.color.height != c.height))
    throw Error(fmt::format("{}: camera {} color is {}x{}, not registered to depth", kPass, camera,
                            frame.color.width, frame.color.height));
  glPixelStorei(GL_UNPACK_ALIGNMENT, 1);
  glTextureSubImage2D(c.depth, 0, 0, 0, c.width, c.height, GL_RED_INTEGER, GL_UNSIGNED_SHORT,
                      frame.depth.pixels.data());
  if (c.has_color)
    glTextureSubImage2D(c.color, 0, 0, 0, c.width, c.height, GL_BGRA, GL_UNSIGNED_BYTE,
                        frame.color.bgra.data());
  c.uploaded = true;
  c.mesh_current = c.reliability_current = false;
  take_colour_samples(frame, c.samples);
  ++r.uploads_since_balance;
}

void CameraRenderer::draw_cameras(const View& view, const RenderTarget& target,
                                  const CameraPassOptions& options) {
  Impl& r = *impl_;
  check_pass_options(options);
  const bool mesh = options.surface == Surface::kMesh;
  r.stamp(0);
  glBindVertexArray(r.empty_vao);
  const bool reliable = options.blend && options.blend_weights == BlendWeights::kReliability;
  for (size_t i = 0; i < r.cameras.size(); ++i) {
    if (!r.cameras[i].uploaded || (i < options.cameras.size() && !options.cameras[i].visible))
      continue;
    if (mesh) r.update_mesh(r.cameras[i], options.max_edge_ratio);
    if (reliable) r.update_reliability(r.cameras[i], options.edge_px);
  }
  gl::begin_target(kPass, target);
  r.stamp(1);
  if (options.balance_colour) r.update_gains();
  glUseProgram(mesh ? r.mesh_program : r.splat_program);
  const CameraUniforms& u = mesh ? r.mesh : r.splat;
  glUniform1i(u.weighting, reliable ? 1 : 0);
  glUniform1f(u.erode_push, options.erode_depth_m);
  glUniform1f(u.blend_push, options.blend_depth_m);
  const Eigen::Matrix4f view_from_clip = view.clip_from_view.inverse();
  glUniform2f(u.viewport_size, static_cast<float>(target.width), static_cast<float>(target.height));
  if (!mesh) {
    glUniform1i(r.size_mode, static_cast<int>(options.splat_size));
    glUniform1f(r.fixed_px, options.fixed_point_px);
    glUniform1f(r.pixels_per_unit,
                0.5f * static_cast<float>(target.height) * view.clip_from_view(1, 1));
    glUniform1f(r.splat_scale, options.splat_scale);
    glUniform2f(r.half_viewport, 0.5f * static_cast<float>(target.width),
                0.5f * static_cast<float>(target.height));
  }
  r.timed = r.timing;
  r.timed_blend = options.blend;
  if (!options.blend) {
    r.draw_each(options, view, mesh, 0, false);
    r.stamp(2);
  } else {
    // (1) the front surface's depth, pushed back; (2) what lies within blend_depth_m of it,
    // weighted, summed; (3) the weighted mean into the target.
    r.ensure_blend_target(target.width, target.height);
    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, r.blend_fbo);
    glViewport(0, 0, target.width, target.height);
    glDisable(GL_SCISSOR_TEST);
    glClearColor(0, 0, 0, 0);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    glColorMask(GL_FALSE, GL_FALSE, GL_FALSE, GL_FALSE);
    r.draw_each(options, view, mesh, options.blend_depth_m, false);
    r.stamp(2);
    glColorMask(GL_TRUE, GL_TRUE, GL_TRUE, GL_TRUE);
    if (reliable) {  // the blending pass reads the front depth: a copy, not its own attachment
      glCopyImageSubData(r.front_depth, GL_TEXTURE_2D, 0, 0, 0, 0, r.front_copy, GL_TEXTURE_2D, 0,
                         0, 0, 0, target.width, target.height, 1);
      glBindTextureUnit(4, r.front_copy);
    }
    r.stamp(3);
    glDepthMask(GL_FALSE);
    glDepthFunc(GL_LEQUAL);
    glEnable(GL_BLEND);
    glBlendFunc(GL_ONE, GL_ONE);
    r.draw_each(options, view, mesh, 0, true);
    r.stamp(4);
    glDisable(GL_BLEND);

    glBindFramebuffer(GL_DRAW_FRAMEBUFFER, target.framebuffer);
    glViewport(target.x, target.y, target.width, target.height);
    glEnable(GL_SCISSOR_TEST);
    glDepthMask(GL_TRUE);
    glDepthFunc(GL_ALWAYS);
    glUseProgram(r.resolve_program);
    glUniform2i(r.resolve_origin, target.x, target.y);
    glUniform1i(r.resolve_weighting, reliable ? 1 : 0);
    glUniform2f(r.resolve_viewport, static_cast<float>(target.width),
                static_cast<float>(target.height));
    glUniformMatrix4fv(r.resolve_view_from_clip, 1, GL_FALSE, view_from_clip.data());
    glUniformMatrix4fv(r.resolve_clip_from_view, 1, GL_FALSE, view.clip_from_view.data());
    glBindTextureUnit(0, r.accumulated);
    glBindTextureUnit(1, r.front_depth);
    glBindTextureUnit(2, r.blended_depth);
    glDrawArrays(GL_TRIANGLES, 0, 3);
    r.stamp(5);
    glDepthFunc(GL_LESS);
  }
  glDisable(GL_SCISSOR_TEST);
  gl::check(kPass, fmt::format("drawing {} cameras into framebuffer {}", r.cameras.size(),
                               target.framebuffer)
                       .c_str());
}

void CameraRenderer::set_avatar_filter(const AvatarFilter& filter) {
  impl_->filter = filter;
  for (GpuCamera& c : impl_->cameras) {
    c.filter = filter;
    c.mesh_current = false;
  }
}

void CameraRenderer::set_avatar_filter(size_t camera, const AvatarFilter& filter) {
  Impl& r = *impl_;
  if (camera >= r.cameras.size())
    throw Error(
        fmt::format("{}: no camera {} (set_cameras gave {})", kPass, camera, r.cameras.size()));
  GpuCamera& c = r.cameras[camera];
  const auto same_sphere = [](const std::optional<KeepSphere>& a,
                              const std::optional<KeepSphere>& b) {
    return a.has_value() == b.has_value() &&
           (!a || (a->center == b->center && a->radius_m == b->radius_m));
  };
  const auto same_box = [](const std::optional<HideBox>& a, const std::optional<HideBox>& b) {
    return a.has_value() == b.has_value() &&
           (!a || (a->world_from_headset.rotation == b->world_from_headset.rotation &&
                   a->world_from_headset.translation == b->world_from_headset.translation &&
                   a->half_extent_m == b->half_extent_m));
  };
  if (same_sphere(c.filter.keep, filter.keep) && same_box(c.filter.hide, filter.hide)) return;
  c.filter = filter;
  c.mesh_current = false;  // the mesh's triangles depend on it
}

std::vector<Eigen::Vector3f> CameraRenderer::colour_gains() const {
  std::vector<Eigen::Vector3f> gains;
  for (const GpuCamera& c : impl_->cameras) gains.push_back(c.gain);
  return gains;
}

void CameraRenderer::time_passes(bool on) {
  Impl& r = *impl_;
  if (on && !r.stamps[0]) glCreateQueries(GL_TIMESTAMP, 6, r.stamps);
  r.timing = on;
  r.timed = false;
}

CameraPassTimes CameraRenderer::last_pass_times() const {
  const Impl& r = *impl_;
  CameraPassTimes t;
  if (!r.timed) return t;
  GLuint64 ns[6] = {};
  const int n = r.timed_blend ? 6 : 3;
  for (int i = 0; i < n; ++i) glGetQueryObjectui64v(r.stamps[i], GL_QUERY_RESULT, &ns[i]);
  const auto ms = [&](int a, int b) { return static_cast<double>(ns[b] - ns[a]) * 1e-6; };
  t.updates_ms = ms(0, 1);
  if (!r.timed_blend) {
    t.plain_ms = ms(1, 2);
  } else {
    t.prepass_ms = ms(1, 2);
    t.copy_ms = ms(2, 3);
    t.weighted_ms = ms(3, 4);
    t.resolve_ms = ms(4, 5);
  }
  return t;
}

std::string CameraRenderer::gl_description() const {
  return std::string(reinterpret_cast<const char*>(glGetString(GL_RENDERER))) + ", OpenGL " +
         reinterpret_cast<const char*>(glGetString(GL_VERSION));
}

size_t upload_changed(CameraRenderer& renderer,
                      std::span<const std::shared_ptr<const CameraFrame>> frames,
                      std::span<std::shared_ptr<const CameraFrame>> uploaded) {
  size_t count = 0;
  for (size_t i = 0; i < frames.size() && i < uploaded.size(); ++i)
    if (frames[i] && frames[i] != uploaded[i]) {
      renderer.upload(i, *frames[i]);
      uploaded[i] = frames[i];
      ++count;
    }
  return count;
}

}  // namespace volcast
