// CameraRenderer: GPU reconstruction of live cameras as splats or a grid mesh, several cameras
// toggled, tinted and blended. Headless through EGL (Mesa llvmpipe without a GPU). No golden
// images: each test measures a property of the picture.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>

#include "support/test_data.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/reconstruct/point_cloud.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/render/headless_target.hpp"

namespace volcast {
namespace {

constexpr uint8_t kBackground[3] = {28, 23, 20};  // BGR of the clear colour (0.08, 0.09, 0.11)

bool covered(const ColorImage& image, int x, int y) {
  const uint8_t* p = image.pixel(x, y);
  return std::abs(p[0] - kBackground[0]) + std::abs(p[1] - kBackground[1]) +
             std::abs(p[2] - kBackground[2]) >
         12;
}

// The View that sees exactly what a pinhole camera at the world origin sees (camera frame: x
// right, y down, z forward), pixel (u, v) of a width x height image landing on the target pixel
// (u, v) counted from the top left: the tangents put the image's outer pixel edges (u = -0.5,
// u = width - 0.5) on the viewport's edges.
View view_of(const Intrinsics& k) {
  View v;
  v.world_from_view = look_at({0, 0, 0}, {0, 0, 1}, {0, -1, 0});
  v.clip_from_view = perspective_from_tangents(
      static_cast<float>(-(k.cx + 0.5) / k.fx), static_cast<float>((k.width - 0.5 - k.cx) / k.fx),
      static_cast<float>((k.cy + 0.5) / k.fy), static_cast<float>(-(k.height - 0.5 - k.cy) / k.fy),
      0.05f, 20.0f);
  return v;
}

CameraPassOptions options(Surface surface, SplatSize size, bool blend) {
  CameraPassOptions o;
  o.surface = surface;
  o.splat_size = size;
  o.blend = blend;
  return o;
}

TEST(CameraRenderer, APlaneAtKnownDepthLandsWithinAPixelOfWhereTheIntrinsicsSay) {
  // Synthetic (labelled): a 64x48 pinhole camera sees a plane at 1.5 m on pixels u 10..49,
  // v 8..39 and nothing elsewhere.
  CameraCalibration cal;
  cal.depth = {.width = 64, .height = 48, .fx = 50, .fy = 50, .cx = 31.5, .cy = 23.5};
  CameraFrame f;
  f.depth = DepthImage(64, 48);
  for (int v = 8; v <= 39; ++v)
    for (int u = 10; u <= 49; ++u) f.depth.pixels[static_cast<size_t>(v) * 64 + u] = 1500;
  HeadlessTarget target(64, 48);
  CameraRenderer renderer;
  renderer.set_cameras(std::span(&cal, 1));
  renderer.upload(0, f);
  for (Surface surface : {Surface::kSplats, Surface::kMesh})
    for (bool blend : {false, true}) {
      SCOPED_TRACE(std::string(to_string(surface)) + (blend ? ", blended" : ", depth-tested"));
      renderer.draw_cameras(view_of(cal.depth), target.target(),
                            options(surface, SplatSize::kFootprint, blend));
      ColorImage image;
      target.read_image(image);
      int x0 = 64, x1 = -1, y0 = 48, y1 = -1;
      for (int y = 0; y < 48; ++y)
        for (int x = 0; x < 64; ++x)
          if (covered(image, x, y)) {
            x0 = std::min(x0, x), x1 = std::max(x1, x);
            y0 = std::min(y0, y), y1 = std::max(y1, y);
          }
      EXPECT_NEAR(x0, 10, 1);
      EXPECT_NEAR(x1, 49, 1);
      EXPECT_NEAR(y0, 8, 1);
      EXPECT_NEAR(y1, 39, 1);
      EXPECT_TRUE(covered(image, 30, 24));
    }
}

TEST(CameraRenderer, MeshLeavesNoTriangleAcrossADepthStep) {
  // Synthetic (labelled): left half red at 1.0 m, right half blue at 1.3 m (a 300 mm step), seen
  // from the side where the step's wall would face the eye. A triangle across the step would
  // blend red into blue: count the pixels that are both.
  CameraCalibration cal;
  cal.depth = {.width = 80, .height = 60, .fx = 70, .fy = 70, .cx = 39.5, .cy = 29.5};
  CameraFrame f;
  f.depth = DepthImage(80, 60);
  f.color = ColorImage(80, 60);
  for (int v = 0; v < 60; ++v)
    for (int u = 0; u < 80; ++u) {
      const bool left = u < 40;
      f.depth.pixels[static_cast<size_t>(v) * 80 + u] = left ? 1000 : 1300;
      uint8_t* p = f.color.pixel(u, v);
      p[0] = left ? 0 : 255, p[1] = 0, p[2] = left ? 255 : 0, p[3] = 255;  // BGRA
    }
  HeadlessTarget target(320, 240);
  CameraRenderer renderer;
  renderer.set_cameras(std::span(&cal, 1));
  renderer.upload(0, f);
  ViewCamera side;
  side.eye = {0.9f, -0.2f, 0.3f};
  side.target = {0.0f, 0.0f, 1.15f};
  const View view = to_view(side, target.target().aspect());
  const auto mixed_pixels = [&](float max_edge_ratio) {
    CameraPassOptions o = options(Surface::kMesh, SplatSize::kAdaptive, false);
    o.max_edge_ratio = max_edge_ratio;
    renderer.draw_cameras(view, target.target(), o);
    ColorImage image;
    target.read_image(image);
    size_t mixed = 0, red = 0, blue = 0;
    for (int y = 0; y < image.height; ++y)
      for (int x = 0; x < image.width; ++x) {
        const uint8_t* p = image.pixel(x, y);
        mixed += p[0] > 40 && p[2] > 40;
        red += p[2] > 200 && p[0] < 40;
        blue += p[0] > 200 && p[2] < 40;
      }
    EXPECT_GT(red, 1000u);
    EXPECT_GT(blue, 1000u);
    return mixed;
  };
  EXPECT_EQ(mixed_pixels(0.05f), 0u) << "a triangle spans the 300 mm step";
  // The same mesh without the edge test draws the step's wall: the test can see one.
  EXPECT_GT(mixed_pixels(1e6f), 500u);
}

// Pixels the mesh covers (the object's surface, without holes between samples) that a splat pass
// leaves uncovered.
size_t holes_inside(const ColorImage& surface, const ColorImage& splats, size_t* inside) {
  size_t holes = 0;
  *inside = 0;
  for (int y = 0; y < surface.height; ++y)
    for (int x = 0; x < surface.width; ++x)
      if (covered(surface, x, y)) {
        ++*inside;
        holes += !covered(splats, x, y);
      }
  return holes;
}

TEST(CameraRenderer, AdaptiveSplatsLeaveFewerHolesInTheRealKinectFrameThanFixedPoints) {
  // The genuine Azure Kinect frame seen from 25 degrees to the side at 1280x720: more pixels than
  // the depth image has, so fixed-size points leave holes between them (the demo's moire).
  auto src = open_source(test::kinect_mkv());
  const CameraFrame f = src->next();
  const CameraCalibration cal = src->calibration();
  PointCloud cloud;
  CloudBuilder(cal).build(f.depth, f.color, cloud);
  const PointCloud* clouds[] = {&cloud};
  HeadlessTarget target(1280, 720);
  const View view =
      to_view(orbit_view(cal.world_from_camera, clouds, 25, 10), target.target().aspect());
  CameraRenderer renderer;
  renderer.set_cameras(std::span(&cal, 1));
  renderer.upload(0, f);
  const auto render = [&](CameraPassOptions o) {
    o.cameras = {{true, {1, 0, 1, 1}}};  // every drawn pixel magenta, dark objects included
    renderer.draw_cameras(view, target.target(), o);
    ColorImage image;
    target.read_image(image);
    return image;
  };
  const ColorImage surface = render(options(Surface::kMesh, SplatSize::kAdaptive, false));
  CameraPassOptions fixed = options(Surface::kSplats, SplatSize::kFixedPixels, false);
  fixed.fixed_point_px = 2;
  size_t inside = 0;
  const size_t fixed_holes = holes_inside(surface, render(fixed), &inside);
  const size_t footprint_holes = holes_inside(
      surface, render(options(Surface::kSplats, SplatSize::kFootprint, false)), &inside);
  const size_t adaptive_holes = holes_inside(
      surface, render(options(Surface::kSplats, SplatSize::kAdaptive, false)), &inside);
  const size_t blended_holes =
      holes_inside(surface, render(options(Surface::kSplats, SplatSize::kAdaptive, true)), &inside);
  const auto percent = [&](size_t n) {
    return 100.0 * static_cast<double>(n) / static_cast<double>(inside);
  };
  std::printf(
      "real Azure Kinect frame, 1280x720, 25 deg to the side: %zu pixels inside the surface; "
      "uncovered: fixed 2 px points %zu (%.2f %%), footprint splats %zu (%.2f %%), adaptive "
      "splats %zu (%.2f %%), adaptive + blended %zu (%.2f %%)\n",
      inside, fixed_holes, percent(fixed_holes), footprint_holes, percent(footprint_holes),
      adaptive_holes, percent(adaptive_holes), blended_holes, percent(blended_holes));
  ASSERT_GT(inside, 100000u);
  EXPECT_LT(adaptive_holes, fixed_holes);
  EXPECT_LE(adaptive_holes, footprint_holes);
}

// Synthetic depth noise (labelled) on a real frame: N(0, sigma) with sigma = 1.5 mm x (z / 1 m)^2,
// about an Azure Kinect's, drawn afresh for every frame.
DepthImage with_noise(const DepthImage& depth, std::mt19937& rng) {
  DepthImage out = depth;
  std::normal_distribution<double> n(0, 1);
  for (uint16_t& d : out.pixels)
    if (d) {
      const double z = d / 1000.0;
      d = static_cast<uint16_t>(std::clamp(d + n(rng) * 1.5 * z * z, 1.0, 65535.0));
    }
  return out;
}

// What a camera at `world_from_camera` with intrinsics `k` would measure of `cloud` (world
// frame): the nearest point per pixel, in mm. No lens distortion (pinhole `k`).
DepthImage depth_seen(const PointCloud& cloud, const Intrinsics& k,
                      const RigidTransform& world_from_camera) {
  DepthImage out(k.width, k.height);
  const RigidTransform camera_from_world = world_from_camera.inverse();
  for (const SplatPoint& s : cloud.points) {
    const Eigen::Vector3d p =
        camera_from_world * Eigen::Vector3d(s.position[0], s.position[1], s.position[2]);
    if (p.z() <= 0.1) continue;
    const long u = std::lround(k.fx * p.x() / p.z() + k.cx);
    const long v = std::lround(k.fy * p.y() / p.z() + k.cy);
    if (u < 0 || v < 0 || u >= k.width || v >= k.height) continue;
    uint16_t& d = out.pixels[static_cast<size_t>(v) * k.width + u];
    const auto mm = static_cast<uint16_t>(std::lround(p.z() * 1000));
    if (d == 0 || mm < d) d = mm;
  }
  return out;
}

TEST(CameraRenderer, BlendingFlickersLessThanDepthTestingWhereCamerasOverlap) {
  // Four cameras that see the same real surface: the genuine Azure Kinect frame's points, seen by
  // four pinhole cameras placed by known transforms around the original viewpoint (turned up to
  // 12 degrees about the scene's centre). Each frame gets fresh synthetic depth noise, as a real
  // sensor's frames do. Each camera is tinted its own colour; a pixel whose colour changes by
  // more than 48 of 255 from one frame to the next has flipped between cameras.
  auto src = open_source(test::kinect_mkv());
  const CameraFrame real = src->next();
  PointCloud cloud;
  CloudBuilder(src->calibration()).build(real.depth, real.color, cloud);
  std::vector<float> depths;
  for (const SplatPoint& p : cloud.points) depths.push_back(p.position[2]);
  std::nth_element(depths.begin(), depths.begin() + depths.size() / 2, depths.end());
  const Eigen::Vector3d centre(0, 0, depths[depths.size() / 2]);
  Intrinsics k{.width = 320, .height = 288, .fx = 252, .fy = 252, .cx = 159.5, .cy = 143.5};
  std::vector<CameraCalibration> cams(4);
  const double yaw[] = {-0.21, -0.07, 0.07, 0.21}, pitch[] = {0.05, -0.05, 0.05, -0.05};
  for (size_t i = 0; i < 4; ++i) {
    const Eigen::Matrix3d turn = (Eigen::AngleAxisd(yaw[i], Eigen::Vector3d::UnitY()) *
                                  Eigen::AngleAxisd(pitch[i], Eigen::Vector3d::UnitX()))
                                     .toRotationMatrix();
    cams[i].depth = k;
    cams[i].world_from_camera.rotation = turn;
    cams[i].world_from_camera.translation = centre - turn * centre;  // orbit the centre
  }
  std::vector<DepthImage> seen;
  for (const auto& c : cams) seen.push_back(depth_seen(cloud, k, c.world_from_camera));

  HeadlessTarget target(640, 576);
  CameraRenderer renderer;
  renderer.set_cameras(cams);
  CameraPassOptions o = options(Surface::kSplats, SplatSize::kAdaptive, false);
  const Eigen::Vector4f tints[] = {{1, 0, 0, 1}, {0, 1, 0, 1}, {0, 0, 1, 1}, {1, 1, 0, 1}};
  for (const auto& t : tints) o.cameras.push_back({true, t});
  ViewCamera eye;  // the original camera's viewpoint, between the four
  eye.vertical_fov_deg = 65;
  const View view = to_view(eye, target.target().aspect());
  const auto flips = [&](Surface surface, bool blend, size_t* drawn) {
    std::mt19937 rng(7);
    o.surface = surface;
    o.blend = blend;
    ColorImage before, after;
    size_t flipped = 0;
    *drawn = 0;
    for (int frame = 0; frame < 4; ++frame) {
      for (size_t i = 0; i < cams.size(); ++i) {
        CameraFrame f;
        f.depth = with_noise(seen[i], rng);
        renderer.upload(i, f);
      }
      renderer.draw_cameras(view, target.target(), o);
      target.read_image(after);
      if (frame > 0)
        for (int y = 0; y < after.height; ++y)
          for (int x = 0; x < after.width; ++x) {
            if (!covered(after, x, y) || !covered(before, x, y)) continue;
            ++*drawn;
            const uint8_t *a = before.pixel(x, y), *b = after.pixel(x, y);
            for (int c = 0; c < 3; ++c)
              if (std::abs(a[c] - b[c]) > 48) {
                ++flipped;
                break;
              }
          }
      std::swap(before, after);
    }
    return flipped;
  };
  for (Surface surface : {Surface::kSplats, Surface::kMesh}) {
    size_t drawn_plain = 0, drawn_blend = 0;
    const size_t plain = flips(surface, false, &drawn_plain);
    const size_t blended = flips(surface, true, &drawn_blend);
    std::printf(
        "4 overlapping cameras (real Kinect surface, synthetic noise), %s, 3 frame pairs: "
        "depth test %zu of %zu pixels flipped (%.2f %%), blended %zu of %zu (%.2f %%)\n",
        to_string(surface), plain, drawn_plain,
        100.0 * static_cast<double>(plain) / static_cast<double>(drawn_plain), blended, drawn_blend,
        100.0 * static_cast<double>(blended) / static_cast<double>(drawn_blend));
    ASSERT_GT(drawn_plain, 300000u);
    EXPECT_GT(plain, 10000u) << "the cameras do not overlap: nothing to measure";
    EXPECT_LT(blended * 4, plain) << to_string(surface);
  }
}

TEST(CameraRenderer, MeshTrianglesFollowNewImagesTheAvatarFilterAndThePose) {
  // The mesh's kept triangles are made once per image, filter, pose and threshold (not per draw):
  // each change must show in the next picture. Synthetic (labelled): a plane at 2 m.
  CameraCalibration cal;
  cal.depth = {.width = 32, .height = 24, .fx = 30, .fy = 30, .cx = 15.5, .cy = 11.5};
  CameraFrame f;
  f.depth = DepthImage(32, 24);
  std::fill(f.depth.pixels.begin(), f.depth.pixels.end(), uint16_t{2000});
  HeadlessTarget target(100, 100);
  CameraRenderer renderer;
  renderer.set_cameras(std::span(&cal, 1));
  renderer.upload(0, f);
  ViewCamera eye;
  eye.vertical_fov_deg = 50;
  const View view = to_view(eye, 1);
  const CameraPassOptions mesh = options(Surface::kMesh, SplatSize::kAdaptive, false);
  const auto centre_covered = [&] {
    renderer.draw_cameras(view, target.target(), mesh);
    ColorImage image;
    target.read_image(image);
    return covered(image, 50, 50);
  };
  EXPECT_TRUE(centre_covered());
  AvatarFilter far_away;
  far_away.keep = KeepSphere{{0, 0, 50}, 0.5f};
  renderer.set_avatar_filter(far_away);
  EXPECT_FALSE(centre_covered()) << "the filter did not reach the mesh";
  renderer.set_avatar_filter({});
  EXPECT_TRUE(centre_covered());
  std::fill(f.depth.pixels.begin(), f.depth.pixels.end(), uint16_t{0});
  renderer.upload(0, f);
  EXPECT_FALSE(centre_covered()) << "the mesh kept the old image's triangles";
  std::fill(f.depth.pixels.begin(), f.depth.pixels.end(), uint16_t{2000});
  renderer.upload(0, f);
  AvatarFilter around_origin;
  around_origin.keep = KeepSphere{{0, 0, 2}, 0.5f};  // world frame: the plane's centre
  renderer.set_avatar_filter(around_origin);
  EXPECT_TRUE(centre_covered());
  RigidTransform moved;
  moved.translation = {0, 0, 5};  // the camera moves 5 m back: its plane leaves the sphere
  renderer.set_world_from_camera(0, moved);
  EXPECT_FALSE(centre_covered()) << "the pose change did not reach the mesh's filter";
}

TEST(CameraRenderer, HidesAndTintsEachCameraOnDemand) {
  // Synthetic (labelled): two cameras side by side, each seeing a gray plane.
  CameraCalibration cal;
  cal.depth = {.width = 32, .height = 24, .fx = 30, .fy = 30, .cx = 15.5, .cy = 11.5};
  std::vector<CameraCalibration> cams(2, cal);
  cams[0].world_from_camera.translation = {-0.6, 0, 0};
  cams[1].world_from_camera.translation = {0.6, 0, 0};
  CameraFrame f;
  f.depth = DepthImage(32, 24);
  std::fill(f.depth.pixels.begin(), f.depth.pixels.end(), uint16_t{2000});
  HeadlessTarget target(200, 100);
  CameraRenderer renderer;
  renderer.set_cameras(cams);
  renderer.upload(0, f);
  renderer.upload(1, f);
  ViewCamera eye;
  eye.vertical_fov_deg = 50;
  const View view = to_view(eye, target.target().aspect());
  const auto draw = [&](const CameraPassOptions& o) {
    renderer.draw_cameras(view, target.target(), o);
    ColorImage image;
    target.read_image(image);
    return image;
  };
  // Camera 0 (world x < 0) lands on the left half, camera 1 on the right half.
  const auto left = [](const ColorImage& i) { return i.pixel(40, 50); };
  const auto right = [](const ColorImage& i) { return i.pixel(160, 50); };
  CameraPassOptions o;
  ColorImage both = draw(o);
  EXPECT_NEAR(left(both)[1], 160, 1);  // gray: no colour image
  EXPECT_NEAR(right(both)[1], 160, 1);
  CameraLook hidden;
  hidden.visible = false;
  o.cameras = {{true, {0, 1, 0, 1}}, hidden};
  const ColorImage green_left = draw(o);
  EXPECT_NEAR(left(green_left)[1], 255, 1);
  EXPECT_EQ(left(green_left)[2], 0);
  EXPECT_FALSE(covered(green_left, 160, 50)) << "a hidden camera was drawn";
  o.cameras = {{true, {1, 0, 0, 0.5f}}};  // camera 1 has no entry: visible, untinted
  const ColorImage half_red = draw(o);
  EXPECT_NEAR(half_red.pixel(40, 50)[2], (160 + 255) / 2, 2);
  EXPECT_NEAR(half_red.pixel(40, 50)[1], 80, 2);
  EXPECT_NEAR(right(half_red)[1], 160, 1);

  renderer.set_world_from_camera(1, cams[0].world_from_camera);  // a slider moved camera 1
  const ColorImage moved = draw(o);
  EXPECT_FALSE(covered(moved, 160, 50));
  EXPECT_THROW(renderer.set_world_from_camera(2, {}), Error);
}

// A session scene's cameras change as avatars come and go: the cameras whose index and intrinsics
// stay keep their ray tables (the lens model inverted at every pixel, the slow part) and draw as a
// fresh renderer's do once their images are uploaded again; a changed camera gets a new one.
TEST(CameraRenderer, CamerasKeptBySetCamerasKeepTheirRayTablesAndDrawAsNew) {
  // Synthetic (labelled): a Brown-Conrady camera and a pinhole one, side by side, on a plane.
  CameraCalibration lens;
  lens.depth = {.width = 32,
                .height = 24,
                .fx = 30,
                .fy = 30,
                .cx = 15.5,
                .cy = 11.5,
                .k1 = 0.3,
                .k2 = -0.05,
                .p1 = 0.001};
  lens.world_from_camera.translation = {-0.6, 0, 0};
  CameraCalibration pinhole = lens;
  pinhole.depth = {.width = 32, .height = 24, .fx = 30, .fy = 30, .cx = 15.5, .cy = 11.5};
  pinhole.world_from_camera.translation = {0.6, 0, 0};
  CameraFrame f;
  f.depth = DepthImage(32, 24);
  std::fill(f.depth.pixels.begin(), f.depth.pixels.end(), uint16_t{2000});
  HeadlessTarget target(200, 100);
  ViewCamera eye;
  eye.vertical_fov_deg = 50;
  const View view = to_view(eye, target.target().aspect());
  const auto draw = [&](CameraRenderer& r) {
    r.draw_cameras(view, target.target(), {});
    ColorImage image;
    target.read_image(image);
    return image;
  };
  CameraRenderer fresh;
  const std::vector<CameraCalibration> two = {lens, pinhole};
  fresh.set_cameras(two);
  fresh.upload(0, f);
  fresh.upload(1, f);
  const ColorImage expected = draw(fresh);

  CameraRenderer renderer;
  renderer.set_cameras(std::span(&lens, 1));
  renderer.upload(0, f);
  EXPECT_EQ(renderer.ray_tables_uploaded(), 1u);
  renderer.set_cameras(two);  // an avatar came: camera 0 kept, camera 1 new
  EXPECT_EQ(renderer.ray_tables_uploaded(), 2u);
  EXPECT_FALSE(covered(draw(renderer), 40, 50)) << "camera 0's old image is forgotten";
  renderer.upload(0, f);
  renderer.upload(1, f);
  EXPECT_EQ(draw(renderer).bgra, expected.bgra);
  CameraCalibration moved = lens;  // new intrinsics at index 0: a new table
  moved.depth.k1 = 0.1;
  renderer.set_cameras(std::vector{moved, pinhole});
  EXPECT_EQ(renderer.ray_tables_uploaded(), 3u);
  renderer.set_cameras(std::vector{pinhole});  // index 0 now the pinhole's intrinsics
  EXPECT_EQ(renderer.ray_tables_uploaded(), 4u);
  EXPECT_EQ(renderer.camera_count(), 1u);
}

TEST(CameraRenderer, RefusesOptionsOutOfRangeNamingThem) {
  HeadlessTarget target(16, 16);
  CameraRenderer renderer;
  const View view = to_view(ViewCamera{}, 1);
  CameraPassOptions o;
  o.fixed_point_px = 0;
  EXPECT_NE(test::error_of([&] {
              renderer.draw_cameras(view, target.target(), o);
            }).find("fixed_point_px"),
            std::string::npos);
  o = {};
  o.splat_scale = -1;
  EXPECT_NE(
      test::error_of([&] { renderer.draw_cameras(view, target.target(), o); }).find("splat_scale"),
      std::string::npos);
  o = {};
  o.max_edge_ratio = 0;
  EXPECT_NE(test::error_of([&] {
              renderer.draw_cameras(view, target.target(), o);
            }).find("max_edge_ratio"),
            std::string::npos);
  o = {};
  o.blend_depth_m = 5;
  EXPECT_NE(test::error_of([&] {
              renderer.draw_cameras(view, target.target(), o);
            }).find("blend_depth_m"),
            std::string::npos);
  CameraCalibration huge;
  huge.depth = {.width = 5000, .height = 10, .fx = 1, .fy = 1, .cx = 0, .cy = 0};
  EXPECT_THROW(renderer.set_cameras(std::span(&huge, 1)), Error);
  EXPECT_EQ(parse_surface("mesh"), Surface::kMesh);
  EXPECT_EQ(parse_surface("splats"), Surface::kSplats);
  EXPECT_THROW(parse_surface("voxels"), Error);
}

}  // namespace
}  // namespace volcast
