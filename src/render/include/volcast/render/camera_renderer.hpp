#pragma once
// GPU reconstruction and drawing of live RGB-D cameras, with OpenGL 4.5 core, into a RenderTarget
// it is given (the paper's two renderers, Fischer et al. 2024 §3.3, and a blending pass in the
// spirit of BlendPCR, Mühlenbrock et al. 2024). Like SplatRenderer it creates no context and no
// target framebuffer and reads nothing back.
//
// Each camera's depth (R16UI, mm) and color (RGBA8) are uploaded as textures once per frame
// (upload); its ray table (RG32F, X/Z and Y/Z per pixel, lens model included) once (set_cameras).
// The vertex shaders unproject depth pixel (u, v) to p_camera = (ray.x * z, ray.y * z, z), z in
// metres, and place it at world_from_camera * p_camera: no per-point CPU work, one draw per
// visible camera per pass.
//
// Surfaces (CameraPassOptions::surface):
//  - kSplats: one round splat per valid pixel, masked (discard outside the disc), depth-tested,
//    no sort. Its size (SplatSize): fixed pixels; the pixel's footprint (world radius
//    z * splat_radius_per_metre(intrinsics), projected); or adaptive: the disc's diameter is
//    sqrt(gx^2 + gy^2), gx and gy the screen distances to the nearest valid neighbours on the same
//    surface (within 10 % of its depth, searched 1..3 pixels away left/right and up/down; the
//    larger of each pair). So a splat grows where valid samples are sparse (holes, the Azure
//    Kinect's invalid pixels) and where the surface is seen obliquely, covering the gap to its
//    neighbours without overlapping them much; never smaller than the footprint, nor larger than
//    4x it (splat_scale multiplies both).
//  - kMesh: the depth grid as triangles, two per 2x2 pixel quad; a triangle is dropped when a
//    corner is invalid (depth 0, no ray, removed by the avatar filter) or an edge is longer than
//    max_edge_ratio x the depth of its nearer end (a depth step, not a surface). Which triangles
//    survive does not depend on the view, so a compute pass picks them once per new image (or
//    filter, pose, threshold) into the camera's index buffer and an indirect draw command; each
//    draw (each eye, each blending pass) then only transforms and shades the kept corners.
//
// Overlapping cameras (CameraPassOptions::blend): instead of letting the depth test pick whichever
// camera is nearest by noise (z-fighting: the color flickers between cameras from frame to frame),
// three passes: (1) depth of every visible camera, pushed blend_depth_m away from the eye;
// (2) every fragment that lies within blend_depth_m of that front surface adds color x weight into
// a float accumulation buffer, weight = w_angle * w_depth * w_disc, where w_angle is the cosine
// between the surface normal (from neighbouring depth pixels) and the ray to the camera, clamped
// to >= 0.05 (grazing samples are the noisiest), w_depth = 1 / z^2 (Azure Kinect depth noise grows
// with z^2) and w_disc = 1 - r^2 across a splat (1 for the mesh); (3) a full-viewport pass writes
// sum(color x weight) / sum(weight) and the front depth into the target.
//
// Blending weights (CameraPassOptions::blend_weights, issue 38; after BlendPCR's quality weights,
// edge-proximity blending and erosion of unreliable borders):
//  - kAngleDistance, the first method above (kept to measure against).
//  - kReliability, the default: three passes per new image (not per draw) give each pixel a
//    reliability = w_angle * w_depth (as above) * w_edge, where w_edge = smoothstep over the
//    chessboard distance d (pixels) to the nearest depth edge -- an invalid pixel, the image's
//    border, or a 4-neighbour more than 5 % of the depth away -- w_edge = smoothstep(0, 1,
//    d / (edge_px + 1)); a pixel the camera's colour did not reach (BGRA alpha 0: outside the
//    colour camera's view) counts as w_edge = 0 when the camera has colour. w_edge is floored at
//    0.02 in the weight, so no sample drops out. Erosion: in the prepass a pixel is pushed back a
//    further erode_depth_m * (1 - w_edge), so a border pixel (a flying pixel between foreground
//    and background) loses the front to another camera's surface behind it, but still covers
//    where nothing else does. Soft tolerance: a fragment's weight falls from 1
//    to 0 (smoothstep) between blend_depth_m / 3 and blend_depth_m behind the front surface,
//    floored at 1e-4. The target's depth is the blended surface's: the weighted mean view depth
//    of the fragments blended (kAngleDistance writes the front depth, pushed back).
//  - Colour balance (balance_colour): each camera's colour is multiplied by an RGB gain so that
//    cameras agree where they see the same surface (colour_balance.hpp): estimated on the CPU
//    from a fixed grid of samples per camera (about 6000, whatever the image size) every 15 new
//    images, not per frame.
//
// The GLSL is one source with the browser's renderer (web/page/renderer.js): src/render/glsl,
// written out by cmake/embed_glsl.cmake as volcast/render/glsl.hpp here and camera_glsl.js there
// (glsl/README.md). The browser has no compute shaders: it marks the mesh's kept triangles per
// quad in a fragment pass instead of compacting them (mesh_kept.frag, the same triangle_kept).
#include <Eigen/Core>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/reconstruct/avatar_filter.hpp"
#include "volcast/render/render_target.hpp"
#include "volcast/render/view.hpp"

namespace volcast {

/// Which surface the cameras' pixels become.
enum class Surface { kSplats, kMesh };
/// "splats", "mesh".
const char* to_string(Surface surface);
/// Parses "splats"/"splat" or "mesh"; throws Error naming the value otherwise.
Surface parse_surface(const std::string& name);

/// How big a splat is drawn.
enum class SplatSize {
  kFixedPixels,  ///< fixed_point_px pixels wide, whatever the depth (plain GL points)
  kFootprint,    ///< the pixel's footprint at its depth, x splat_scale
  kAdaptive,     ///< covers the gap to the nearest valid neighbours (see the top of this file)
};

/// How blended cameras are weighted (see the top of this file).
enum class BlendWeights {
  kAngleDistance,  ///< the first method: angle and distance, a hard tolerance, the front depth
  kReliability,    ///< angle, distance and distance to a depth edge; erosion; soft tolerance
};

/// How one camera is drawn.
struct CameraLook {
  bool visible = true;
  /// RGB 0..1 and strength 0..1 (alpha): drawn color = mix(color, tint.rgb, tint.a). Default: none.
  Eigen::Vector4f tint{1, 1, 1, 0};
};

/// Everything draw_cameras() may vary from frame to frame (a viewer's panel edits it).
struct CameraPassOptions {
  /// The mesh by default: it scores best in leave-one-camera-out view synthesis on the four
  /// real Azure Kinects (volcast bench --quality; docs/benchmarks.md), at about half the splats'
  /// draw time.
  Surface surface = Surface::kMesh;
  SplatSize splat_size = SplatSize::kAdaptive;
  float fixed_point_px = 2;  ///< SplatSize::kFixedPixels: point width, pixels, 1..64
  float splat_scale = 1;     ///< multiplies the footprint radius, > 0
  /// kMesh: a triangle is dropped when an edge's length (metres) exceeds this x the depth of its
  /// nearer corner (metres). 0.05 keeps slanted surfaces and drops steps of a few cm at 1 m.
  float max_edge_ratio = 0.05f;
  bool blend = true;            ///< blend overlapping cameras (see the top of this file)
  float blend_depth_m = 0.03f;  ///< fragments this close behind the front surface are blended
  BlendWeights blend_weights = BlendWeights::kReliability;  ///< with blend
  int edge_px = 4;             ///< kReliability: w_edge reaches 1 this many pixels from an edge
  float erode_depth_m = 0.1f;  ///< kReliability: the prepass's push of an edge pixel, metres
  bool balance_colour = true;  ///< per-camera colour gains from the overlap (colour_balance.hpp)
  /// Per camera (index as in set_cameras); a camera without an entry is visible and untinted.
  std::vector<CameraLook> cameras;
};

/// Throws Error("camera renderer: <field> <value> is outside <range>") for the first option out of
/// its range: fixed_point_px 1..64 px, splat_scale (0, 16], max_edge_ratio > 0, blend_depth_m
/// (0, 1] m, edge_px 1..16 px, erode_depth_m [0, 1] m. draw_cameras() calls it first.
void check_pass_options(const CameraPassOptions& o);

/// GPU time (milliseconds, OpenGL timestamp queries) of one draw_cameras() call's passes, for
/// benchmarks (CameraRenderer::time_passes). updates: the per-image passes (the mesh's triangles,
/// reliability), zero when no camera had new images; then either plain (one draw of every camera)
/// or the blending passes: prepass (depth), copy (of that depth), weighted (colour and depth x
/// weight), resolve (into the target).
struct CameraPassTimes {
  double updates_ms = 0, plain_ms = 0, prepass_ms = 0, copy_ms = 0, weighted_ms = 0, resolve_ms = 0;
};

class CameraRenderer {
 public:
  /// Builds the programs in the OpenGL context current on the calling thread; every later call
  /// must be made with that context current. Throws Error if no context is current, it is older
  /// than OpenGL 4.5, or a shader does not compile or link.
  CameraRenderer();
  /// Deletes the GL objects; the same context must still be current.
  ~CameraRenderer();
  CameraRenderer(const CameraRenderer&) = delete;
  CameraRenderer& operator=(const CameraRenderer&) = delete;

  /// The cameras draw_cameras() unprojects (replacing earlier ones, which are forgotten with their
  /// images). Uploads each camera's ray table and makes its textures (the mesh's index buffer,
  /// 24 bytes per pixel, when first drawn as a mesh); a camera at the same index with the same
  /// intrinsics as before keeps its ray table (the lens model inverted at every pixel by Newton
  /// iteration), so a session scene whose list of cameras grows by an avatar does not upload the
  /// site's again; the tables themselves come from shared_ray_table (ray_table.hpp), made once
  /// per process for each camera's intrinsics. Throws Error if a camera has no pixels or
  /// more than 4096 per side, or OpenGL reports an error.
  void set_cameras(std::span<const CameraCalibration> cameras);
  /// Moves camera `camera` (a registration slider): its new world_from_camera, images kept.
  /// Throws Error if `camera` is out of range.
  void set_world_from_camera(size_t camera, const RigidTransform& world_from_camera);
  /// Number of cameras set_cameras() gave.
  size_t camera_count() const;
  /// Ray tables set_cameras() has uploaded so far (a kept camera's is not uploaded again).
  size_t ray_tables_uploaded() const;

  /// Uploads camera `camera`'s images: depth in mm (0 = invalid) at the calibration's size, and
  /// color BGRA registered to it (same size) or empty (drawn gray, as CloudBuilder does). Throws
  /// Error if `camera` is out of range or a size differs from the calibration.
  void upload(size_t camera, const CameraFrame& frame);

  /// Clears the target's viewport (colour dark grey-blue, depth far) and draws every uploaded,
  /// visible camera as seen through `view`. Touches no pixel outside the viewport; leaves
  /// `target.framebuffer` bound for drawing and the scissor test off. A camera not uploaded yet
  /// draws nothing. Throws Error if the viewport is empty, the framebuffer incomplete, an option
  /// out of range (naming it) or OpenGL reports an error.
  void draw_cameras(const View& view, const RenderTarget& target,
                    const CameraPassOptions& options = {});

  /// The avatar filter (avatar_filter.hpp) every surface applies from now on to every camera (and
  /// to cameras set_cameras gives later), on the GPU: a pixel it does not keep is not drawn (a
  /// mesh triangle with such a corner is dropped). The default keeps every point.
  void set_avatar_filter(const AvatarFilter& filter);
  /// The avatar filter for camera `camera` alone, in the world frame (a remote participant's
  /// camera keeps a sphere around that participant's head; the own camera hides the own
  /// headset). Replaces what set_avatar_filter(filter) gave it, until that is called again
  /// (which sets every camera's). Throws Error if `camera` is out of range.
  void set_avatar_filter(size_t camera, const AvatarFilter& filter);

  /// Each camera's colour gain (RGB, index as in set_cameras) as draw_cameras last estimated it
  /// with balance_colour on; 1 for a camera never balanced.
  std::vector<Eigen::Vector3f> colour_gains() const;

  /// Times each draw_cameras() call's passes on the GPU (off by default; for `volcast bench
  /// --render`). last_pass_times() waits for the GPU to finish the last call and returns them
  /// (zeros while timing is off).
  void time_passes(bool on);
  CameraPassTimes last_pass_times() const;

  /// GL_RENDERER and GL_VERSION of the current context.
  std::string gl_description() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

/// Uploads each camera i (below both sizes) whose frame is not uploaded[i] -- the same pointer is
/// the same images, already on the GPU (a frame the caller still holds cannot have been reused by
/// the receiver's pool) -- and keeps it in uploaded[i]; a null frame is skipped. What the window,
/// the headset, the headless viewer and the session scene do with each new frame set. Returns how
/// many cameras it uploaded. Throws what CameraRenderer::upload throws.
size_t upload_changed(CameraRenderer& renderer,
                      std::span<const std::shared_ptr<const CameraFrame>> frames,
                      std::span<std::shared_ptr<const CameraFrame>> uploaded);

}  // namespace volcast
