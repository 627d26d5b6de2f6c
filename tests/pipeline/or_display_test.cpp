// The OR display's camera pass: camera_view() looks through a real camera exactly, and
// BackdropRenderer puts the camera's colour and live depth behind PrimitiveRenderer's shapes so
// the real foreground hides what lies behind it. Headless through EGL (Mesa llvmpipe without a
// GPU); the genuine Azure Kinect frame, undistorted by the filter chain's pixel map.
#include <gtest/gtest.h>

#include <Eigen/Geometry>
#include <cmath>
#include <cstdio>
#include <numbers>

#include "support/test_data.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/filter/filters.hpp"
#include "volcast/pipeline/or_display.hpp"
#include "volcast/pipeline/session_scene.hpp"
#include "volcast/render/annotation_scene.hpp"
#include "volcast/render/backdrop_renderer.hpp"
#include "volcast/render/headless_target.hpp"
#include "volcast/render/primitive_renderer.hpp"
#include "volcast/render/view.hpp"

namespace volcast {
namespace {

// The real frame and its camera, undistorted (pinhole with the factory fx, fy, cx, cy), the
// camera placed in the world by a non-trivial pose so that world_from_camera is exercised.
struct PinholeCamera {
  CameraCalibration calibration;
  CameraFrame frame;
};

PinholeCamera undistorted_kinect() {
  auto src = open_source(test::kinect_mkv());
  const CameraFrame f = src->next();
  const PixelMap map = make_pixel_map(src->calibration().depth, true, std::nullopt);
  PinholeCamera c;
  c.calibration.depth = map.output;
  c.calibration.world_from_camera.rotation = (Eigen::AngleAxisd(0.4, Eigen::Vector3d::UnitY()) *
                                              Eigen::AngleAxisd(-0.25, Eigen::Vector3d::UnitX()))
                                                 .toRotationMatrix();
  c.calibration.world_from_camera.translation = {0.7, 1.6, -2.1};
  apply_pixel_map(map, f.depth, c.frame.depth);
  apply_pixel_map(map, f.color, c.frame.color);
  return c;
}

// The point that depth pixel (u, v) measured, world frame, metres (pinhole intrinsics).
Eigen::Vector3d measured_point(const PinholeCamera& c, int u, int v) {
  const Intrinsics& k = c.calibration.depth;
  const double z = c.frame.depth.at(u, v) * 0.001;
  return c.calibration.world_from_camera *
         Eigen::Vector3d((u - k.cx) / k.fx * z, (v - k.cy) / k.fy * z, z);
}

// The nearest pixel in the central half of the image (in the recording: the mug, about 27 cm
// away, before walls 0.6 to 2 m away) whose (2 r + 1)^2 neighbourhood is all valid, no nearer
// than it by more than 6 cm and no deeper by more than 5 cm (a patch of real surface that would
// hide a small shape 20 cm behind it).
bool foreground_pixel(const DepthImage& depth, int r, int* u_out, int* v_out) {
  uint16_t best = 0xffff;
  for (int v = depth.height / 4; v < depth.height * 3 / 4; v += 2)
    for (int u = depth.width / 4; u < depth.width * 3 / 4; u += 2) {
      const uint16_t d = depth.at(u, v);
      if (d == 0 || d >= best) continue;
      bool flat = true;
      for (int dv = -r; dv <= r && flat; ++dv)
        for (int du = -r; du <= r && flat; ++du) {
          const uint16_t n = depth.at(u + du, v + dv);
          flat = n != 0 && n + 60 > d && n < d + 50;
        }
      if (flat) best = d, *u_out = u, *v_out = v;
    }
  return best != 0xffff;
}

Primitive sphere(const Eigen::Vector3d& centre, double diameter_m, const Eigen::Vector4f& rgba) {
  Primitive p;
  p.shape = Primitive::Shape::kSphere;
  p.world_from_shape =
      (Eigen::Translation3f(centre.cast<float>()) * Eigen::Scaling(static_cast<float>(diameter_m)))
          .matrix();
  p.color = rgba;
  p.emissive = 1;  // unlit: exactly its colour
  return p;
}

bool same_pixel(const ColorImage& a, const ColorImage& b, int x, int y) {
  return std::equal(a.pixel(x, y), a.pixel(x, y) + 3, b.pixel(x, y));
}

// Renders the backdrop, then `shapes` over it, through the camera's own view.
ColorImage render(HeadlessTarget& target, BackdropRenderer& backdrop, PrimitiveRenderer& shapes,
                  const PinholeCamera& c, std::span<const Primitive> primitives) {
  const View view = camera_view(c.calibration, 0.1f, 20);
  backdrop.draw(view, target.target(), c.frame);
  shapes.draw(view, target.target(), primitives);
  ColorImage image;
  target.read_image(image);
  return image;
}

TEST(CameraView, ProjectsWorldPointsToTheCalibrationsPixels) {
  // Synthetic points (labelled) in front of a posed pinhole camera: clip_from_world, divided by
  // w and mapped to the viewport as OpenGL does (window x = (ndc + 1) / 2 * width, pixel centres
  // at + 0.5, window row 0 at the bottom), lands on the pixel the intrinsics give.
  CameraCalibration cal;
  cal.depth = {.width = 640, .height = 576, .fx = 504.2, .fy = 504.9, .cx = 321.3, .cy = 330.8};
  cal.world_from_camera.rotation =
      Eigen::AngleAxisd(0.7, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  cal.world_from_camera.translation = {1, -2, 0.5};
  const View view = camera_view(cal, 0.1f, 20);
  const Eigen::Matrix4f clip_from_world = view.clip_from_world();
  for (const Eigen::Vector3d& p_camera :
       {Eigen::Vector3d(0, 0, 1), Eigen::Vector3d(-0.4, 0.3, 1.2), Eigen::Vector3d(0.9, -0.7, 2.5),
        Eigen::Vector3d(-1.3, -1.0, 3.0)}) {
    const double u = cal.depth.fx * p_camera.x() / p_camera.z() + cal.depth.cx;
    const double v = cal.depth.fy * p_camera.y() / p_camera.z() + cal.depth.cy;
    const Eigen::Vector3d p_world = cal.world_from_camera * p_camera;
    const Eigen::Vector4f clip = clip_from_world * p_world.cast<float>().homogeneous();
    const double window_x = (clip.x() / clip.w() + 1.0) / 2 * cal.depth.width;
    const double window_y = (clip.y() / clip.w() + 1.0) / 2 * cal.depth.height;
    EXPECT_NEAR(window_x - 0.5, u, 1e-3);
    EXPECT_NEAR(cal.depth.height - window_y - 0.5, v, 1e-3);
    EXPECT_NEAR(clip.w(), p_camera.z(), 1e-5);  // w is the depth along the optical axis
  }
}

TEST(CameraView, RefusesLensDistortionAndBadClipDistances) {
  auto src = open_source(test::kinect_mkv());
  const std::string distorted = test::error_of([&] { camera_view(src->calibration(), 0.1f, 20); });
  EXPECT_NE(distorted.find("distortion"), std::string::npos) << distorted;
  CameraCalibration pinhole;
  pinhole.depth = {.width = 64, .height = 48, .fx = 50, .fy = 50, .cx = 31.5, .cy = 23.5};
  EXPECT_NO_THROW(camera_view(pinhole, 0.1f, 20));
  EXPECT_THROW(camera_view(pinhole, 0, 20), Error);
  EXPECT_THROW(camera_view(pinhole, 2, 1), Error);
}

TEST(BackdropRenderer, ShowsTheFramesColourPixelForPixelTopRowFirst) {
  const PinholeCamera c = undistorted_kinect();
  const Intrinsics& k = c.calibration.depth;
  HeadlessTarget target(k.width, k.height);
  BackdropRenderer backdrop;
  PrimitiveRenderer shapes;
  const ColorImage image = render(target, backdrop, shapes, c, {});
  size_t coloured = 0, wrong = 0;
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const uint8_t* f = c.frame.color.pixel(x, y);
      const uint8_t* p = image.pixel(x, y);
      if (f[3] == 0) {
        wrong += p[0] != 0 || p[1] != 0 || p[2] != 0;  // no colour registered: black
      } else {
        ++coloured;
        wrong += !same_pixel(image, c.frame.color, x, y);
      }
    }
  EXPECT_GT(coloured, static_cast<size_t>(k.width * k.height / 4));
  EXPECT_EQ(wrong, 0u);
  // A few pixels named, top row first (a flipped picture fails here).
  for (const auto& [x, y] : {std::pair{k.width / 2, k.height / 4},
                             {k.width / 3, k.height * 3 / 4},
                             {k.width * 3 / 4, k.height / 2}})
    if (c.frame.color.pixel(x, y)[3] != 0) {
      EXPECT_TRUE(same_pixel(image, c.frame.color, x, y));
    }
}

TEST(BackdropRenderer, AShapeInFrontOfTheRealSurfaceLandsOnItsPixelAndOneBehindIsHidden) {
  PinholeCamera c = undistorted_kinect();
  const Intrinsics& k = c.calibration.depth;
  int u = 0, v = 0;
  ASSERT_TRUE(foreground_pixel(c.frame.depth, 14, &u, &v));
  const Eigen::Vector3d p = measured_point(c, u, v);
  const Eigen::Vector3d to_camera = (c.calibration.world_from_camera.translation - p).normalized();
  std::printf("foreground pixel (%d, %d) at %d mm\n", u, v, c.frame.depth.at(u, v));

  HeadlessTarget target(k.width, k.height);
  BackdropRenderer backdrop;
  PrimitiveRenderer shapes;
  const ColorImage plain = render(target, backdrop, shapes, c, {});
  const Eigen::Vector4f green{0, 1, 0, 1};
  const auto drawn = [&](const ColorImage& image, double* cx, double* cy) {
    size_t n = 0;
    double sx = 0, sy = 0;
    for (int y = 0; y < k.height; ++y)
      for (int x = 0; x < k.width; ++x)
        if (!same_pixel(image, plain, x, y)) ++n, sx += x, sy += y;
    if (n) *cx = sx / static_cast<double>(n), *cy = sy / static_cast<double>(n);
    return n;
  };

  // (a) 10 cm in front of the surface, towards the camera: a disc centred on the pixel.
  const Primitive in_front = sphere(p + 0.10 * to_camera, 0.02, green);
  const ColorImage a = render(target, backdrop, shapes, c, std::span(&in_front, 1));
  double cx = -1, cy = -1;
  const size_t n_front = drawn(a, &cx, &cy);
  const double radius_px = k.fx * 0.01 / (c.frame.depth.at(u, v) * 0.001 - 0.10);
  std::printf("in front: %zu pixels (a disc of radius %.1f px has %.0f), centroid (%.2f, %.2f)\n",
              n_front, radius_px, std::numbers::pi * radius_px * radius_px, cx, cy);
  EXPECT_GT(n_front, 0.6 * std::numbers::pi * radius_px * radius_px);
  EXPECT_LT(n_front, 1.4 * std::numbers::pi * radius_px * radius_px);
  EXPECT_NEAR(cx, u, 2.0);
  EXPECT_NEAR(cy, v, 2.0);
  EXPECT_EQ(a.pixel(u, v)[1], 255);  // green over the measured pixel

  // The picture: that sphere, and a red bar (a stroke) 20 cm behind the surface, 50 cm long
  // along the camera's x axis: hidden where the real foreground is nearer, shown over the wall.
  const Eigen::Vector3d x_axis = c.calibration.world_from_camera.rotation.col(0);
  Primitive bar = sphere(p - 0.20 * to_camera, 1, {1, 0, 0, 1});
  bar.shape = Primitive::Shape::kBox;
  Eigen::Matrix3d axes;
  axes.col(0) = x_axis * 0.5;
  axes.col(1) = c.calibration.world_from_camera.rotation.col(1) * 0.01;
  axes.col(2) = c.calibration.world_from_camera.rotation.col(2) * 0.01;
  bar.world_from_shape.topLeftCorner<3, 3>() = axes.cast<float>();
  const Primitive both[] = {in_front, bar};
  const ColorImage picture = render(target, backdrop, shapes, c, both);
  // The bar lies at one depth along the optical axis; red shows only where the real surface is
  // deeper (or not measured), never over a nearer one.
  const double bar_z =
      (c.calibration.world_from_camera.inverse() * (p - 0.20 * to_camera)).z() * 1000;
  size_t red = 0, red_over_nearer = 0;
  for (int y = 0; y < k.height; ++y)
    for (int x = 0; x < k.width; ++x) {
      const uint8_t* px = picture.pixel(x, y);
      if (px[2] != 255 || px[1] != 0 || px[0] != 0) continue;
      ++red;
      const int mm = c.frame.depth.at(x, y);
      red_over_nearer += mm != 0 && mm < bar_z - 6;
    }
  std::printf("red bar at %.0f mm: %zu pixels, %zu over a nearer surface\n", bar_z, red,
              red_over_nearer);
  EXPECT_GT(red, 500u);
  EXPECT_EQ(red_over_nearer, 0u);
  const auto dir = test::temp_dir("or_display");
  write_color_png(dir / "or_backdrop_test.png", picture);
  std::printf("picture: %s\n", (dir / "or_backdrop_test.png").c_str());
  {
    PinholeCamera filled = c;
    HoleFiller filler;
    filler.iterations = 30;
    filler.apply(filled.frame.depth);
    write_color_png(dir / "or_backdrop_filled.png", render(target, backdrop, shapes, filled, both));
  }

  // (b) 20 cm behind the surface on the same ray: every pixel is the backdrop's, which is the
  // frame's colour.
  const Primitive behind = sphere(p - 0.20 * to_camera, 0.02, green);
  const ColorImage b = render(target, backdrop, shapes, c, std::span(&behind, 1));
  EXPECT_EQ(drawn(b, &cx, &cy), 0u);
  EXPECT_TRUE(same_pixel(b, c.frame.color, u, v));
  // The control: with the depth taken away (all invalid: the far plane) the same sphere shows,
  // so it was the live depth that hid it.
  c.frame.depth.pixels.assign(c.frame.depth.pixels.size(), 0);
  EXPECT_GT(drawn(render(target, backdrop, shapes, c, std::span(&behind, 1)), &cx, &cy), 20u);
}

TEST(BackdropRenderer, WithoutColourShowsDepthAsGreyAndInvalidAsBlack) {
  // Synthetic (labelled): left half at 0.5 m, right half invalid.
  CameraCalibration cal;
  cal.depth = {.width = 32, .height = 24, .fx = 30, .fy = 30, .cx = 15.5, .cy = 11.5};
  CameraFrame f;
  f.depth = DepthImage(32, 24);
  for (int y = 0; y < 24; ++y)
    for (int x = 0; x < 16; ++x) f.depth.at(x, y) = 500;
  HeadlessTarget target(32, 24);
  BackdropRenderer backdrop;
  backdrop.draw(camera_view(cal, 0.1f, 20), target.target(), f);
  ColorImage image;
  target.read_image(image);
  EXPECT_NEAR(image.pixel(3, 5)[0], 0.9 * 255, 1.5);
  EXPECT_EQ(image.pixel(3, 5)[0], image.pixel(3, 5)[2]);
  EXPECT_EQ(image.pixel(20, 5)[1], 0);
  EXPECT_THROW(backdrop.draw(camera_view(cal, 0.1f, 20), target.target(),
                             CameraFrame{DepthImage(32, 24), ColorImage(16, 12), 0}),
               Error);
}

}  // namespace
}  // namespace volcast

namespace volcast {
namespace {

// The OR display (pipeline/or_display.hpp) of the real Kinect frame, distorted as recorded (it
// undistorts it itself): a stroke drawn at a known 3D point lands within 2 px of where the camera
// projects that point; the same stroke 20 cm behind the real foreground surface is hidden.
TEST(OrDisplay, AStrokeLandsOnItsPixelOfTheCamerasImageAndTheForegroundHidesOneBehindIt) {
  auto src = open_source(test::kinect_mkv());
  CameraCalibration camera = src->calibration();
  // The same frame as the display undistorts it and fills its holes (the mug's dark print).
  PinholeCamera c = undistorted_kinect();
  HoleFiller holes;
  holes.iterations = 10;
  holes.apply(c.frame.depth);
  camera.world_from_camera = c.calibration.world_from_camera;
  const CameraFrame frame = src->next();
  int u = 0, v = 0;
  ASSERT_TRUE(foreground_pixel(c.frame.depth, 24, &u, &v));
  EXPECT_LT(c.frame.depth.at(u, v), 400) << "the mug, about 27 cm away";
  const Eigen::Vector3d p = measured_point(c, u, v);
  const Eigen::Vector3d eye = c.calibration.world_from_camera.translation;
  const Eigen::Vector3d ray = (p - eye).normalized();
  const Eigen::Vector3d across =
      c.calibration.world_from_camera.rotation * Eigen::Vector3d::UnitX();
  const auto stroke_at = [&](const Eigen::Vector3d& q) {
    session::Annotation a;
    a.id = 1;
    a.author = 2;
    a.kind = session::AnnotationKind::kStroke;
    for (double dx : {-0.01, 0.0, 0.01}) a.points.push_back((q + across * dx).cast<float>());
    return a;
  };
  const auto size = or_display_size(camera);
  HeadlessTarget target(size.width, size.height);
  OrDisplay display;
  SessionSnapshot snapshot;  // room frame = site frame
  ColorImage before, in_front, behind;
  const auto draw = [&](ColorImage& image) {
    display.draw(target.target(), camera, frame, snapshot, 0);
    target.read_image(image);
  };
  draw(before);
  EXPECT_EQ(display.room_camera().depth.fx, c.calibration.depth.fx);
  const Eigen::Vector3d q = p - ray * 0.10;  // 10 cm in front of the surface
  snapshot.annotations = {stroke_at(q)};
  draw(in_front);
  snapshot.annotations = {stroke_at(p + ray * 0.20)};  // 20 cm behind it
  draw(behind);
  ColorImage on_surface;  // drawn on the surface itself, as a pointer's hits are: not buried
  snapshot.annotations = {stroke_at(p)};
  draw(on_surface);
  // The same with no live depth at all (nothing hides it), and its backdrop: its whole size.
  CameraFrame no_depth = frame;
  std::fill(no_depth.depth.pixels.begin(), no_depth.depth.pixels.end(), uint16_t{0});
  ColorImage free_backdrop, free_stroke;
  snapshot.annotations.clear();
  display.draw(target.target(), camera, no_depth, snapshot, 0);
  target.read_image(free_backdrop);
  snapshot.annotations = {stroke_at(p)};
  display.draw(target.target(), camera, no_depth, snapshot, 0);
  target.read_image(free_stroke);
  const std::filesystem::path dir = test::temp_dir("or_display");
  write_color_png(dir / "or_display_stroke.png", in_front);
  std::printf("picture: %s\n", (dir / "or_display_stroke.png").c_str());
  Eigen::Vector2d sum = Eigen::Vector2d::Zero();
  int stroke = 0, shown_behind = 0, shown_on = 0, whole = 0;
  for (int y = 0; y < size.height; ++y)
    for (int x = 0; x < size.width; ++x) {
      if (!same_pixel(in_front, before, x, y)) sum += Eigen::Vector2d(x, y), ++stroke;
      shown_behind += !same_pixel(behind, before, x, y);
      shown_on += !same_pixel(on_surface, before, x, y);
      whole += !same_pixel(free_stroke, free_backdrop, x, y);
    }
  EXPECT_GT(shown_on, whole * 9 / 10) << "a stroke on the surface shows (nearly) whole";
  ASSERT_GT(stroke, 100);
  const Intrinsics& k = c.calibration.depth;
  const Eigen::Vector3d q_camera = c.calibration.world_from_camera.inverse() * q;
  const Eigen::Vector2d expected(k.fx * q_camera.x() / q_camera.z() + k.cx,
                                 k.fy * q_camera.y() / q_camera.z() + k.cy);
  const Eigen::Vector2d centre = sum / stroke;
  std::printf(
      "stroke: %d px, centre %.2f px from the point's projection; behind: %d px shown; on the "
      "surface: %d px shown of %d\n",
      stroke, (centre - expected).norm(), shown_behind, shown_on, whole);
  EXPECT_LT((centre - expected).norm(), 2.0)
      << centre.transpose() << " vs " << expected.transpose();
  EXPECT_EQ(shown_behind, 0);

  // A label's text (drawn by the window over its pin's top): listed at the projection of its
  // stick's top when its pin is on the surface, not at all when the pin is 20 cm behind it.
  session::Annotation label;
  label.id = 3;
  label.author = 2;
  label.kind = session::AnnotationKind::kLabel;
  label.text = "cut here";
  label.points = {p.cast<float>()};
  snapshot.annotations = {label};
  display.draw(target.target(), camera, frame, snapshot, 0);
  const std::vector<OrDisplayLabel> listed = display.labels(snapshot);
  ASSERT_EQ(listed.size(), 1u);
  EXPECT_EQ(listed[0].text, "cut here");
  EXPECT_EQ(listed[0].rgb, participant_color(2));
  const Eigen::Vector3d top =
      c.calibration.world_from_camera.inverse() * label_anchor(label).cast<double>();
  const Eigen::Vector2d top_px(k.fx * top.x() / top.z() + k.cx, k.fy * top.y() / top.z() + k.cy);
  if (top_px.y() >= 0) {  // else kept on the picture's edge
    EXPECT_LT((listed[0].pixel.cast<double>() - top_px).norm(), 0.01) << top_px.transpose();
  }
  label.points = {(p + ray * 0.20).cast<float>()};
  snapshot.annotations = {label};
  EXPECT_TRUE(display.labels(snapshot).empty()) << "its pin is behind the mug";
}

// A camera mounted on its side: the wall display turns its picture so that the room's up is up
// (synthetic: a 3x2 image whose pixel values say where they were).
TEST(OrDisplay, ACameraOnItsSideIsShownUpright) {
  ColorImage image(3, 2);
  for (int y = 0; y < 2; ++y)
    for (int x = 0; x < 3; ++x) image.pixel(x, y)[0] = static_cast<uint8_t>(10 * y + x);
  const ColorImage left = turned(image, 1);  // counter-clockwise: the right column on top
  ASSERT_EQ(left.width, 2);
  ASSERT_EQ(left.height, 3);
  EXPECT_EQ(left.pixel(0, 0)[0], 2);
  EXPECT_EQ(left.pixel(1, 0)[0], 12);
  EXPECT_EQ(left.pixel(0, 2)[0], 0);
  EXPECT_EQ(turned(left, -1), image);
  EXPECT_EQ(turned(turned(image, 2), 2), image);
  // turned_point takes a pixel's centre to the centre of the pixel turned() moves it to.
  for (int k = 0; k < 4; ++k) {
    const ColorImage t = turned(image, k);
    for (int y = 0; y < 2; ++y)
      for (int x = 0; x < 3; ++x) {
        const Eigen::Vector2f q =
            turned_point(Eigen::Vector2f(float(x) + 0.5f, float(y) + 0.5f), 3, 2, k);
        EXPECT_EQ(t.pixel(int(q.x()), int(q.y()))[0], image.pixel(x, y)[0])
            << k << ": " << x << ", " << y;
      }
  }
  // Camera frame: x right, y down, z forward. Level (y down = room down): no turn. Rolled so
  // that the image's right is the room's up: one turn counter-clockwise.
  RigidTransform level;
  level.rotation << 1, 0, 0, 0, -1, 0, 0, 0, -1;
  EXPECT_EQ(upright_quarter_turns(level), 0);
  RigidTransform rolled = level;
  rolled.rotation =
      level.rotation * Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ()).toRotationMatrix();
  const Eigen::Vector3d up_in_image = rolled.rotation.transpose() * Eigen::Vector3d::UnitY();
  EXPECT_EQ(upright_quarter_turns(rolled), up_in_image.x() > 0 ? 1 : 3);
  EXPECT_GT(std::abs(up_in_image.x()), 0.99);
}

}  // namespace
}  // namespace volcast
