// Draw passes into render targets they are given; headless through EGL (Mesa llvmpipe on machines
// without a GPU).
#include <epoxy/egl.h>
#include <epoxy/gl.h>
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <future>
#include <thread>
#include <type_traits>

#include "support/test_data.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/render/drawn_depth.hpp"
#include "volcast/render/headless_target.hpp"
#include "volcast/render/primitive_renderer.hpp"
#include "volcast/render/shader_throughput.hpp"
#include "volcast/render/splat_renderer.hpp"

namespace volcast {
namespace {

constexpr uint32_t kRed = 0xff0000ffu, kGreen = 0xff00ff00u;  // SplatPoint::rgba, R lowest
// CameraRenderer drawing what CloudBuilder + SplatRenderer draw: footprint splats, no blending.
const CameraPassOptions kPlainSplats = [] {
  CameraPassOptions o;
  o.surface = Surface::kSplats;
  o.splat_size = SplatSize::kFootprint;
  o.blend = false;
  return o;
}();

// Where p_view lands in a viewport, in GL window coordinates (pixels from the framebuffer's lower
// left), as the OpenGL pipeline computes it: clip, divide by w, viewport transform.
Eigen::Vector2f window_from_view(const Eigen::Matrix4f& clip_from_view, const Eigen::Vector3f& p,
                                 const RenderTarget& t) {
  const Eigen::Vector4f clip = clip_from_view * p.homogeneous();
  const Eigen::Vector2f ndc = clip.head<2>() / clip.w();
  return {static_cast<float>(t.x) + (ndc.x() + 1) / 2 * static_cast<float>(t.width),
          static_cast<float>(t.y) + (ndc.y() + 1) / 2 * static_cast<float>(t.height)};
}

// An RGBA8 + depth framebuffer made by the test itself, read back with glReadPixels.
struct TestFramebuffer {
  GLuint framebuffer = 0, color = 0, depth = 0;
  int width, height;
  TestFramebuffer(int w, int h) : width(w), height(h) {
    glCreateRenderbuffers(1, &color);
    glNamedRenderbufferStorage(color, GL_RGBA8, w, h);
    glCreateRenderbuffers(1, &depth);
    glNamedRenderbufferStorage(depth, GL_DEPTH_COMPONENT24, w, h);
    glCreateFramebuffers(1, &framebuffer);
    glNamedFramebufferRenderbuffer(framebuffer, GL_COLOR_ATTACHMENT0, GL_RENDERBUFFER, color);
    glNamedFramebufferRenderbuffer(framebuffer, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth);
  }
  ~TestFramebuffer() {
    glDeleteFramebuffers(1, &framebuffer);
    glDeleteRenderbuffers(1, &color);
    glDeleteRenderbuffers(1, &depth);
  }
  // RGBA, GL's row order: row 0 is the bottom one.
  std::vector<uint8_t> read() const {
    std::vector<uint8_t> rgba(static_cast<size_t>(width) * height * 4);
    glBindFramebuffer(GL_READ_FRAMEBUFFER, framebuffer);
    glPixelStorei(GL_PACK_ALIGNMENT, 1);
    glReadnPixels(0, 0, width, height, GL_RGBA, GL_UNSIGNED_BYTE, static_cast<GLsizei>(rgba.size()),
                  rgba.data());
    return rgba;
  }
};

// A ColorImage pixel (BGRA, top row first) as RGBA.
std::array<uint8_t, 4> rgba_of(const ColorImage& image, int x, int y_from_top) {
  const uint8_t* p = image.pixel(x, y_from_top);
  return {p[2], p[1], p[0], p[3]};
}

bool is_red(const uint8_t* rgba) {
  return rgba[0] > 200 && rgba[1] < 50 && rgba[2] < 50;
}
bool is_green(const uint8_t* rgba) {
  return rgba[1] > 200 && rgba[0] < 50 && rgba[2] < 50;
}
bool is_red(const std::array<uint8_t, 4>& rgba) {
  return is_red(rgba.data());
}
bool is_green(const std::array<uint8_t, 4>& rgba) {
  return is_green(rgba.data());
}

// Two headless targets on two threads share one EGL display (EGL gives every context of a
// platform the same one): the first to go must leave the other's context working. It did not
// (its eglTerminate ended the display for both): libepoxy, which asks EGL about the current
// context before it loads a GL function, then aborted the other thread ("Couldn't find current
// GLX or EGL context"), as the demo's participants did ending on a loaded machine.
TEST(HeadlessTarget, OneGoingLeavesAnotherThreadsContextWorking) {
  auto first = std::make_unique<HeadlessTarget>(8, 8);
  std::promise<void> made, first_gone;
  std::future<void> gone = first_gone.get_future();
  std::future<bool> queried = std::async(std::launch::async, [&] {
    HeadlessTarget second(8, 8);
    made.set_value();
    gone.wait();
    EGLint api = 0;  // what libepoxy asks before it loads a GL function
    const EGLBoolean ok = eglQueryContext(eglGetCurrentDisplay(), eglGetCurrentContext(),
                                          EGL_CONTEXT_CLIENT_TYPE, &api);
    ColorImage image;
    second.read_image(image);  // and it still draws and reads back
    return ok == EGL_TRUE && api == EGL_OPENGL_API && image.width == 8;
  });
  made.get_future().wait();
  first.reset();
  first_gone.set_value();
  EXPECT_TRUE(queried.get()) << "the context of the target still there works";
}

TEST(SplatRenderer, DrawsAPointWhereItProjectsInItsColor) {
  HeadlessTarget target(160, 120);
  SplatRenderer renderer;
  EXPECT_NE(renderer.gl_description().find("4."), std::string::npos) << renderer.gl_description();
  // Synthetic cloud (labelled): one red point straight ahead, one green point up and to the left.
  PointCloud cloud;
  cloud.points.push_back({{0, 0, 2}, 0.05f, kRed});
  cloud.points.push_back({{-0.5f, -0.4f, 2}, 0.05f, kGreen});
  const PointCloud* clouds[] = {&cloud};
  ViewCamera camera;  // at the origin looking down +z, up = -y
  renderer.draw(clouds, to_view(camera, target.target().aspect()), target.target());
  ColorImage image;
  target.read_image(image);
  ASSERT_EQ(image.width, 160);
  ASSERT_EQ(image.height, 120);
  const uint8_t* centre = image.pixel(80, 60);
  EXPECT_GT(centre[2], 200);  // red (BGRA)
  EXPECT_LT(centre[1], 50);
  // (-0.5, -0.4, 2) is left of the axis and, with -y up, above it: the upper-left quadrant.
  bool green_upper_left = false;
  for (int y = 0; y < 60; ++y)
    for (int x = 0; x < 80; ++x) green_upper_left |= image.pixel(x, y)[1] > 200;
  EXPECT_TRUE(green_upper_left);
  const uint8_t* corner = image.pixel(159, 119);
  EXPECT_LT(corner[0] + corner[1] + corner[2], 100);  // background
}

// The window's mouse ray (DrawnDepth, one of the two SurfaceHits): where it meets what the view
// drew, read back from the depth buffer. Synthetic scene (labelled): a box 1 m wide whose front
// face is 1.95 m ahead.
TEST(DrawnDepth, AnEyeRayMeetsWhatTheViewDrewAndNothingElse) {
  HeadlessTarget target(80, 60);
  PrimitiveRenderer primitives;
  glBindFramebuffer(GL_FRAMEBUFFER, target.target().framebuffer);
  glClearDepth(1);
  glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
  Primitive box;
  box.world_from_shape =
      (Eigen::Translation3f(0, 0, 2) * Eigen::Scaling(Eigen::Vector3f(1, 1, 0.1f))).matrix();
  const View view = to_view(ViewCamera{}, target.target().aspect());  // origin, looking down +z
  primitives.draw(view, target.target(), std::span<const Primitive>(&box, 1));
  const DrawnDepth drawn(view, target.target());
  const Eigen::Vector3f eye = Eigen::Vector3f::Zero();
  const auto ahead = drawn.hit(eye, {0, 0, 1});
  ASSERT_TRUE(ahead.has_value());
  EXPECT_NEAR(ahead->z(), 1.95f, 0.002f);
  EXPECT_LT(ahead->head<2>().norm(), 0.03f) << "within the pixel the ray passes through";
  // An oblique ray meets the face where it crosses it, on the ray (within its pixel).
  const auto oblique = drawn.hit(eye, {0.2f, 0.1f, 1});
  ASSERT_TRUE(oblique.has_value());
  EXPECT_NEAR(oblique->z(), 1.95f, 0.002f);
  EXPECT_NEAR(oblique->x(), 0.39f, 0.03f);
  EXPECT_NEAR(oblique->y(), 0.195f, 0.03f);
  EXPECT_EQ(drawn.hit(eye, {0.5f, 0, 1}), std::nullopt) << "past the box: nothing drawn there";
  EXPECT_EQ(drawn.hit(eye, {2, 0, 1}), std::nullopt) << "outside the viewport";
  EXPECT_EQ(drawn.hit(eye, {0, 0, -1}), std::nullopt) << "behind the view";
  EXPECT_EQ(drawn.hit({0.1f, 0, 0}, {0, 0, 1}), std::nullopt)
      << "a ray from elsewhere: the depth buffer knows only the eye's rays";
  EXPECT_TRUE(drawn.ready());
}

TEST(SplatRenderer, RendersARealFrameFromItsCamera) {
  auto src = open_source(test::kinect_mkv());
  const CameraFrame f = src->next();
  PointCloud cloud;
  CloudBuilder(src->calibration()).build(f.depth, f.color, cloud);
  HeadlessTarget target(320, 288);
  SplatRenderer renderer;
  ViewCamera camera;
  camera.vertical_fov_deg = 65;
  const PointCloud* clouds[] = {&cloud};
  renderer.draw(clouds, to_view(camera, target.target().aspect()), target.target());
  ColorImage image;
  target.read_image(image);
  size_t covered = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) {
      const uint8_t* p = image.pixel(x, y);
      covered += (p[0] + p[1] + p[2]) > 90;
    }
  // The NFOV depth image covers most of a view from its own camera with a similar field of view.
  EXPECT_GT(static_cast<double>(covered) / (image.width * image.height), 0.4);
}

// Pixels whose colour differs by more than `tolerance` in some channel, as a fraction of all.
double fraction_differing(const ColorImage& a, const ColorImage& b, int tolerance) {
  size_t differing = 0;
  for (size_t i = 0; i < a.bgra.size(); i += 4)
    for (size_t c = 0; c < 3; ++c)
      if (std::abs(int{a.bgra[i + c]} - int{b.bgra[i + c]}) > tolerance) {
        ++differing;
        break;
      }
  return static_cast<double>(differing) / static_cast<double>(a.bgra.size() / 4);
}

double fraction_covered(const ColorImage& image) {
  size_t covered = 0;
  for (size_t i = 0; i < image.bgra.size(); i += 4)
    covered += image.bgra[i] + image.bgra[i + 1] + image.bgra[i + 2] > 90;
  return static_cast<double>(covered) / static_cast<double>(image.bgra.size() / 4);
}

TEST(CameraRendererOnGpu, GpuReconstructionDrawsWhatTheCpuCloudDraws) {
  // The real Azure Kinect frame (lens model with distortion: the rays come from the ray table),
  // placed away from the world origin and turned, seen from the side.
  auto src = open_source(test::kinect_mkv());
  const CameraFrame f = src->next();
  CameraCalibration cal = src->calibration();
  cal.world_from_camera.rotation =
      Eigen::AngleAxisd(0.5, Eigen::Vector3d(0.2, 1, 0.1).normalized()).toRotationMatrix();
  cal.world_from_camera.translation = Eigen::Vector3d(0.4, -0.2, 1.5);
  PointCloud cloud;
  CloudBuilder(cal).build(f.depth, f.color, cloud);
  const PointCloud* clouds[] = {&cloud};
  HeadlessTarget target(320, 288);
  SplatRenderer renderer;
  CameraRenderer gpu;
  const View view =
      to_view(orbit_view(cal.world_from_camera, clouds, 25, 10), target.target().aspect());

  renderer.draw(clouds, view, target.target());
  ColorImage from_cpu, from_gpu;
  target.read_image(from_cpu);
  gpu.set_cameras(std::span(&cal, 1));
  gpu.draw_cameras(view, target.target(), kPlainSplats);
  ColorImage nothing_uploaded;
  target.read_image(nothing_uploaded);
  EXPECT_LT(fraction_covered(nothing_uploaded), 0.001) << "a camera drew before any upload";
  gpu.upload(0, f);
  gpu.draw_cameras(view, target.target(), kPlainSplats);
  target.read_image(from_gpu);

  EXPECT_GT(fraction_covered(from_cpu), 0.2);
  // Same points, same sizes: only float rounding (R p + t, then P, against (P M) p) can move a
  // splat edge by a pixel.
  EXPECT_LT(fraction_differing(from_cpu, from_gpu, 12), 0.01);
}

// The avatar filter in the vertex shaders drops the points the CPU filter drops: a sphere around a
// point of the real scene, with a headset box inside it, drawn both ways.
TEST(CameraRendererOnGpu, GpuAvatarFilterDrawsWhatTheCpuFilteredCloudDraws) {
  auto src = open_source(test::kinect_mkv());
  const CameraFrame f = src->next();
  CameraCalibration cal = src->calibration();
  cal.world_from_camera.rotation =
      Eigen::AngleAxisd(-0.4, Eigen::Vector3d::UnitY()).toRotationMatrix();
  cal.world_from_camera.translation = Eigen::Vector3d(-0.3, 0.1, 0.8);
  PointCloud cloud;
  CloudBuilder(cal).build(f.depth, f.color, cloud);
  const SplatPoint& mid = cloud.points[cloud.points.size() / 2];
  const Eigen::Vector3f head(mid.position[0], mid.position[1], mid.position[2]);
  AvatarFilter filter;
  filter.keep = KeepSphere{head, 0.5f};
  HideBox box;
  box.world_from_headset.rotation =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d::UnitY()).toRotationMatrix();
  box.world_from_headset.translation = head.cast<double>();
  filter.hide = box;
  PointCloud filtered = cloud;
  const size_t removed = apply_avatar_filter(filter, filtered);
  ASSERT_GT(removed, cloud.points.size() / 4);
  ASSERT_GT(filtered.points.size(), 2000u);

  HeadlessTarget target(320, 288);
  SplatRenderer renderer;
  CameraRenderer gpu;
  const PointCloud* all[] = {&cloud};
  const View view =
      to_view(orbit_view(cal.world_from_camera, all, 20, 15), target.target().aspect());
  ColorImage unfiltered, from_cpu, from_gpu, from_gpu_cloud;
  renderer.draw(all, view, target.target());
  target.read_image(unfiltered);
  const PointCloud* cpu[] = {&filtered};
  renderer.draw(cpu, view, target.target());
  target.read_image(from_cpu);
  renderer.set_avatar_filter(filter);
  gpu.set_avatar_filter(filter);
  gpu.set_cameras(std::span(&cal, 1));
  gpu.upload(0, f);
  gpu.draw_cameras(view, target.target(), kPlainSplats);
  target.read_image(from_gpu);
  renderer.draw(all, view, target.target());  // the unfiltered cloud, filtered by the shader
  target.read_image(from_gpu_cloud);

  EXPECT_GT(fraction_covered(from_cpu), 0.02);
  EXPECT_LT(fraction_covered(from_cpu), 0.8 * fraction_covered(unfiltered));
  EXPECT_LT(fraction_differing(from_cpu, from_gpu, 12), 0.01);
  EXPECT_LT(fraction_differing(from_cpu, from_gpu_cloud, 12), 0.01);
  renderer.set_avatar_filter({});  // off again: everything back
  renderer.draw(all, view, target.target());
  target.read_image(from_gpu_cloud);
  EXPECT_LT(fraction_differing(unfiltered, from_gpu_cloud, 12), 0.001);
}

TEST(CameraRendererOnGpu, GpuReconstructionSkipsInvalidPixelsAndDrawsColourlessOnesGray) {
  // Synthetic (labelled): a 4x2 pinhole camera at the origin looking down +z; two valid pixels,
  // red at (0, 0) and green at (3, 1), the rest depth 0 with a blue colour that must not appear.
  CameraCalibration cal;
  cal.depth = {.width = 4, .height = 2, .fx = 4, .fy = 4, .cx = 2, .cy = 1};
  CameraFrame f;
  f.depth = DepthImage(4, 2);
  f.color = ColorImage(4, 2);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 4; ++x) {
      uint8_t* p = f.color.pixel(x, y);
      p[0] = 255, p[1] = 0, p[2] = 0, p[3] = 255;  // BGRA blue
    }
  f.depth.pixels[0] = 2000;
  f.color.pixel(0, 0)[0] = 0, f.color.pixel(0, 0)[2] = 255;  // red
  f.depth.pixels[7] = 2500;
  f.color.pixel(3, 1)[0] = 0, f.color.pixel(3, 1)[1] = 255;  // green
  PointCloud cloud;
  CloudBuilder(cal).build(f.depth, f.color, cloud);
  ASSERT_EQ(cloud.points.size(), 2u);

  HeadlessTarget target(160, 120);
  SplatRenderer renderer;
  CameraRenderer gpu;
  ViewCamera camera;  // at the origin looking down +z, up = -y: the camera's own view
  const View view = to_view(camera, target.target().aspect());
  gpu.set_cameras(std::span(&cal, 1));
  gpu.upload(0, f);
  gpu.draw_cameras(view, target.target(), kPlainSplats);
  ColorImage image;
  target.read_image(image);
  const auto image_pixel = [&](const SplatPoint& p) {
    // GL window coordinates to image rows (top row first).
    const Eigen::Vector3d p_world(p.position[0], p.position[1], p.position[2]);
    const Eigen::Vector3f p_view = (view.world_from_view.inverse() * p_world).cast<float>();
    const Eigen::Vector2f w = window_from_view(view.clip_from_view, p_view, target.target());
    return rgba_of(image, static_cast<int>(w.x()), image.height - 1 - static_cast<int>(w.y()));
  };
  EXPECT_TRUE(is_red(image_pixel(cloud.points[0])));
  EXPECT_TRUE(is_green(image_pixel(cloud.points[1])));
  size_t blue = 0;
  for (int y = 0; y < image.height; ++y)
    for (int x = 0; x < image.width; ++x) blue += rgba_of(image, x, y)[2] > 200;
  EXPECT_EQ(blue, 0u) << "pixels with depth 0 were drawn";

  f.color = ColorImage();  // no colour: gray, as CloudBuilder draws it
  gpu.upload(0, f);
  gpu.draw_cameras(view, target.target(), kPlainSplats);
  target.read_image(image);
  EXPECT_EQ(image_pixel(cloud.points[0]), (std::array<uint8_t, 4>{160, 160, 160, 255}));

  f.depth = DepthImage(3, 2);
  EXPECT_THROW(gpu.upload(0, f), Error);  // not the calibration's size
  EXPECT_THROW(gpu.upload(1, f), Error);  // no such camera
}

TEST(SplatRenderer, DrawsIntoAFramebufferItDidNotCreateOnlyInsideTheViewport) {
  EglContext context;  // the caller's context, as a window or an OpenXR session would have
  TestFramebuffer fb(200, 150);
  ASSERT_EQ(glCheckNamedFramebufferStatus(fb.framebuffer, GL_FRAMEBUFFER),
            GLenum{GL_FRAMEBUFFER_COMPLETE});
  const float magenta[] = {1, 0, 1, 1};
  glClearNamedFramebufferfv(fb.framebuffer, GL_COLOR, 0, magenta);
  const RenderTarget target{fb.framebuffer, 30, 20, 120, 90};

  View view;  // the eye at the world origin, looking down -z with y up
  view.clip_from_view = perspective(60, target.aspect(), 0.1f, 10);
  // Red: up and to the right of the axis. Green: on the viewport's right edge, a big splat that
  // straddles it (its far half must not spill out of the viewport).
  const Eigen::Vector3f red_at(0.3f, 0.2f, -2),
      green_at(0.98f * 2 / view.clip_from_view(0, 0), 0, -2);
  PointCloud cloud;
  cloud.points.push_back({{red_at.x(), red_at.y(), red_at.z()}, 0.06f, kRed});
  cloud.points.push_back({{green_at.x(), green_at.y(), green_at.z()}, 0.15f, kGreen});
  const PointCloud* clouds[] = {&cloud};
  SplatRenderer renderer;
  renderer.draw(clouds, view, target);

  const std::vector<uint8_t> rgba = fb.read();
  const auto pixel = [&](int x, int y) { return &rgba[(static_cast<size_t>(y) * 200 + x) * 4]; };
  const Eigen::Vector2f red_px = window_from_view(view.clip_from_view, red_at, target);
  EXPECT_NEAR(red_px.x(), 30 + (1 + 0.15f * view.clip_from_view(0, 0)) / 2 * 120, 1e-3f);
  EXPECT_TRUE(is_red(pixel(static_cast<int>(red_px.x()), static_cast<int>(red_px.y()))))
      << "at " << red_px.transpose();
  const Eigen::Vector2f green_px = window_from_view(view.clip_from_view, green_at, target);
  ASSERT_GT(green_px.x(), 148);  // within two pixels of the right edge at x = 150
  EXPECT_TRUE(is_green(pixel(149, static_cast<int>(green_px.y()))));
  EXPECT_LT(pixel(31, 21)[0] + pixel(31, 21)[1] + pixel(31, 21)[2], 100);  // cleared background
  size_t outside = 0, untouched = 0;
  for (int y = 0; y < fb.height; ++y)
    for (int x = 0; x < fb.width; ++x) {
      if (x >= 30 && x < 150 && y >= 20 && y < 110) continue;
      ++outside;
      const uint8_t* p = pixel(x, y);
      untouched += p[0] == 255 && p[1] == 0 && p[2] == 255;
    }
  EXPECT_EQ(untouched, outside) << "pixels outside the viewport were drawn over";
}

TEST(SplatRenderer, AsymmetricProjectionShiftsThePictureAsTheTangentsSay) {
  HeadlessTarget target(160, 120);
  SplatRenderer renderer;
  // An eye that sees 3x farther to the right than to the left (like a headset's right eye, whose
  // outer side is the wider one): tangents 0.8 wide and 0.6 high, so square pixels in 160 x 120.
  View view;
  view.clip_from_view = perspective_from_tangents(-0.2f, 0.6f, 0.3f, -0.3f, 0.1f, 10);
  // On the axis: x_ndc = -(right + left) / (right - left) = -0.5, a quarter of the way across.
  // At tangents (0.4, 0.15): x_ndc = (0.8 - 0.4) / 0.8 = 0.5, y_ndc = 0.3 / 0.6 = 0.5.
  PointCloud cloud;
  cloud.points.push_back({{0, 0, -2}, 0.03f, kRed});
  cloud.points.push_back({{0.8f, 0.3f, -2}, 0.03f, kGreen});
  const PointCloud* clouds[] = {&cloud};
  renderer.draw(clouds, view, target.target());
  ColorImage image;
  target.read_image(image);
  // GL pixel (40, 60) -> image row 120 - 1 - 60 = 59 (the splat is centred on the boundary).
  EXPECT_TRUE(is_red(rgba_of(image, 40, 59)));
  EXPECT_FALSE(is_red(rgba_of(image, 80, 59)));  // the picture's centre is not the axis any more
  // GL pixel (120, 90) -> image row 29.
  EXPECT_TRUE(is_green(rgba_of(image, 120, 29)));
}

TEST(SplatRenderer, DrawingDoesNotReadBackReadImageDoes) {
  // The pass has no way to hand back pixels: the only read-back is HeadlessTarget::read_image.
  using Clouds = std::span<const PointCloud* const>;
  static_assert(std::is_invocable_v<decltype(&SplatRenderer::draw), SplatRenderer&, Clouds,
                                    const View&, const RenderTarget&>);
  static_assert(!std::is_invocable_v<decltype(&SplatRenderer::draw), SplatRenderer&, Clouds,
                                     const View&, const RenderTarget&, ColorImage&>);
  HeadlessTarget target(64, 48);
  SplatRenderer renderer;
  const View view = to_view(ViewCamera{}, target.target().aspect());
  PointCloud red, green;
  red.points.push_back({{0, 0, 2}, 0.1f, kRed});
  green.points.push_back({{0, 0, 2}, 0.1f, kGreen});
  const PointCloud* first[] = {&red};
  const PointCloud* second[] = {&green};

  renderer.draw(first, view, target.target());
  ColorImage picture;
  target.read_image(picture);
  const ColorImage first_picture = picture;
  EXPECT_GT(picture.pixel(32, 24)[2], 200);  // red
  renderer.draw(second, view, target.target());
  renderer.draw(second, view, target.target());
  EXPECT_EQ(picture, first_picture) << "drawing changed the last picture read";
  target.read_image(picture);
  EXPECT_GT(picture.pixel(32, 24)[1], 200);  // green: the newest frame, read on request
  EXPECT_LT(picture.pixel(32, 24)[2], 50);
}

TEST(SplatRenderer, RefusesAnEmptyViewportAndAnIncompleteFramebuffer) {
  HeadlessTarget target(32, 32);
  SplatRenderer renderer;
  const View view = to_view(ViewCamera{}, 1);
  RenderTarget empty = target.target();
  empty.height = 0;
  EXPECT_THROW(renderer.draw({}, view, empty), Error);
  // A surfaceless EGL context has no default framebuffer: framebuffer 0 is incomplete.
  try {
    renderer.draw({}, view, {0, 0, 0, 32, 32});
    ADD_FAILURE() << "drew into framebuffer 0 of a surfaceless context";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("framebuffer 0 is not complete"), std::string::npos)
        << e.what();
  }
  renderer.draw({}, view, target.target());  // still usable
}

TEST(SplatRenderer, NeedsACurrentContext) {
  std::string message;
  std::thread([&] {  // a fresh thread has no current context
    try {
      SplatRenderer renderer;
    } catch (const Error& e) {
      message = e.what();
    }
  })
      .join();
  EXPECT_NE(message.find("no OpenGL context is current"), std::string::npos) << message;
}

TEST(RenderView, LookAtPutsTheTargetDownMinusZWithUpAlongY) {
  const Eigen::Vector3d eye(1, 2, 3), target(1, 2, 5);
  const RigidTransform world_from_view = look_at(eye, target, {0, -1, 0});
  EXPECT_TRUE(world_from_view.translation.isApprox(eye));
  EXPECT_NEAR(world_from_view.rotation.determinant(), 1, 1e-12);
  EXPECT_TRUE((world_from_view.rotation.transpose() * world_from_view.rotation)
                  .isApprox(Eigen::Matrix3d::Identity()));
  EXPECT_TRUE((world_from_view.inverse() * target).isApprox(Eigen::Vector3d(0, 0, -2)));
  EXPECT_TRUE(
      (world_from_view.rotation * Eigen::Vector3d::UnitY()).isApprox(Eigen::Vector3d(0, -1, 0)));
  // Camera frames have x right, y down: looking along a camera's +z with up = -y keeps x right.
  EXPECT_TRUE(
      (world_from_view.rotation * Eigen::Vector3d::UnitX()).isApprox(Eigen::Vector3d(1, 0, 0)));
  EXPECT_THROW(look_at(eye, eye, {0, 1, 0}), Error);
  EXPECT_THROW(look_at(eye, target, {0, 0, 1}), Error);  // up along the line of sight
}

TEST(RenderView, PerspectiveIsTheSymmetricCaseOfTangents) {
  const float t = std::tan(30.0f * 3.14159265f / 180);  // half of 60 degrees
  const Eigen::Matrix4f p = perspective(60, 1.5f, 0.1f, 20);
  EXPECT_TRUE(p.isApprox(perspective_from_tangents(-1.5f * t, 1.5f * t, t, -t, 0.1f, 20), 1e-5f));
  EXPECT_NEAR(p(1, 1), 1 / t, 1e-5);
  // The near and far planes map to -1 and 1.
  for (const auto& [z, ndc] : {std::pair{-0.1f, -1.0f}, std::pair{-20.0f, 1.0f}}) {
    const Eigen::Vector4f clip = p * Eigen::Vector4f(0, 0, z, 1);
    EXPECT_NEAR(clip.z() / clip.w(), ndc, 1e-4);
  }
  // Each tangent edge maps to its side of the viewport.
  const Eigen::Matrix4f q = perspective_from_tangents(-0.2f, 0.6f, 0.3f, -0.1f, 0.1f, 20);
  const Eigen::Vector4f left_bottom = q * Eigen::Vector4f(-0.2f * 3, -0.1f * 3, -3, 1);
  const Eigen::Vector4f right_top = q * Eigen::Vector4f(0.6f * 3, 0.3f * 3, -3, 1);
  EXPECT_TRUE((left_bottom.head<2>() / left_bottom.w()).isApprox(Eigen::Vector2f(-1, -1)));
  EXPECT_TRUE((right_top.head<2>() / right_top.w()).isApprox(Eigen::Vector2f(1, 1)));
}

TEST(RenderView, ProjectionsRefuseParametersOutOfRange) {
  EXPECT_THROW(perspective(0, 1, 0.1f, 10), Error);
  EXPECT_THROW(perspective(180, 1, 0.1f, 10), Error);
  EXPECT_THROW(perspective(60, 0, 0.1f, 10), Error);
  EXPECT_THROW(perspective(60, 1, 0, 10), Error);
  EXPECT_THROW(perspective(60, 1, 1, 1), Error);
  EXPECT_THROW(perspective_from_tangents(0.5f, -0.5f, 0.5f, -0.5f, 0.1f, 10), Error);
  EXPECT_THROW(perspective_from_tangents(-0.5f, 0.5f, -0.5f, 0.5f, 0.1f, 10), Error);
  try {
    perspective(60, 1, 0.1f, 0.05f);
    ADD_FAILURE();
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("near_m"), std::string::npos) << e.what();
  }
}

TEST(RenderView, ViewCameraBecomesTheViewItDescribes) {
  ViewCamera camera;  // the origin, looking down +z, up -y
  camera.vertical_fov_deg = 90;
  const View view = to_view(camera, 2);
  EXPECT_TRUE(view.clip_from_view.isApprox(perspective(90, 2, camera.near_m, camera.far_m)));
  // Tangents of the half angles: 2 across (aspect 2), 1 up. (0.5, -0.5, 1) is right by 0.5 and,
  // y down, up by 0.5: x_ndc = 0.5 / 2, y_ndc = 0.5 / 1.
  const Eigen::Vector4f clip = view.clip_from_world() * Eigen::Vector4f(0.5f, -0.5f, 1, 1);
  EXPECT_TRUE((clip.head<2>() / clip.w()).isApprox(Eigen::Vector2f(0.25f, 0.5f), 1e-5f));
}

// The hash both passes of measure_shader_throughput run per pixel, on the CPU.
uint32_t pixel_hash(uint32_t x, uint32_t y, int rounds) {
  uint32_t h = x * 1973u + y * 9277u + 26699u;
  for (int i = 0; i < rounds; ++i) {
    h ^= h >> 15;
    h *= 0x2c1b3c6du;
    h ^= h >> 12;
    h += 0x297a2d39u;
  }
  return h;
}

TEST(ShaderThroughput, BothPathsDrawTheHashOfEveryPixelAndTheirTimesAreMeasured) {
  HeadlessTarget context(4, 4);
  const int width = 37, height = 21, rounds = 9;  // sides not multiples of the 8 x 8 work groups
  std::vector<uint8_t> picture;
  const ShaderThroughput t = measure_shader_throughput(width, height, rounds, 3, &picture);
  EXPECT_TRUE(t.same_picture);  // the compute pass wrote the same bytes, to the last pixel
  EXPECT_GT(t.fragment_ms, 0.0);
  EXPECT_GT(t.compute_ms, 0.0);
  ASSERT_EQ(picture.size(), size_t{width * height * 4});
  size_t wrong = 0;
  for (uint32_t y = 0; y < uint32_t{height}; ++y)
    for (uint32_t x = 0; x < uint32_t{width}; ++x) {
      const uint32_t h = pixel_hash(x, y, rounds);
      const uint8_t* p = &picture[(y * uint32_t{width} + x) * 4];
      wrong += p[0] != uint8_t(h) || p[1] != uint8_t(h >> 8) || p[2] != uint8_t(h >> 16) ||
               p[3] != uint8_t(h >> 24);
    }
  EXPECT_EQ(wrong, 0u);
  // Another number of rounds is another picture: the rounds are run, not folded away.
  std::vector<uint8_t> fewer;
  measure_shader_throughput(width, height, rounds - 1, 1, &fewer);
  EXPECT_NE(fewer, picture);
  for (const std::array<int, 4>& a : {std::array{0, 8, 1, 1}, std::array{8, 9000, 1, 1},
                                      std::array{8, 8, -1, 1}, std::array{8, 8, 1, 0}})
    EXPECT_NE(test::error_of([&] {
                measure_shader_throughput(a[0], a[1], a[2], a[3]);
              }).find("shader throughput:"),
              std::string::npos)
        << a[0] << "x" << a[1] << " " << a[2] << " " << a[3];
}

TEST(ShaderThroughput, NeedsACurrentContext) {
  std::string message;
  std::thread([&] {  // a fresh thread has no current context
    message = test::error_of([] { measure_shader_throughput(8, 8, 1, 1); });
  })
      .join();
  EXPECT_NE(message.find("shader throughput: no OpenGL context is current"), std::string::npos)
      << message;
}

}  // namespace
}  // namespace volcast
