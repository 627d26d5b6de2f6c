// The OR display's window (viewer/or_display_window.hpp) under Xvfb against the real hands site:
// a remote expert's stroke and label reach the wall display, which goes full screen (F11) and
// shows the camera's picture upright and letterboxed, the stroke where its 3D points project, the
// label's text over its pin and the expert in the legend, in the expert's colour.
#include <gtest/gtest.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>

#include <thread>

#include "support/session_site.hpp"
#include "support/test_data.hpp"
#include "support/xvfb.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/pipeline/or_display.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/session_scene.hpp"
#include "volcast/render/annotation_scene.hpp"
#include "volcast/viewer/or_display_window.hpp"

namespace volcast {
namespace {
namespace fs = std::filesystem;

// How many pixels of `shot` inside the box [x0, x1) x [y0, y1) are of colour `rgb` (0..255 each,
// within `tolerance` in every channel).
int pixels_of(const ColorImage& shot, int x0, int y0, int x1, int y1, const Eigen::Vector3i& rgb,
              int tolerance) {
  int n = 0;
  for (int y = std::max(0, y0); y < std::min(shot.height, y1); ++y)
    for (int x = std::max(0, x0); x < std::min(shot.width, x1); ++x) {
      const uint8_t* p = shot.pixel(x, y);  // BGRA
      n += std::abs(p[2] - rgb.x()) <= tolerance && std::abs(p[1] - rgb.y()) <= tolerance &&
           std::abs(p[0] - rgb.z()) <= tolerance;
    }
  return n;
}

TEST(OrDisplayWindow, ShowsTheExpertsStrokeAndLabelOnTheCamerasPictureFullScreen) {
  const test::Xvfb xvfb;  // 1280x1024
  ASSERT_TRUE(xvfb.running()) << xvfb.error();
  const test::ScopedEnv display("DISPLAY", xvfb.display().c_str());
  const fs::path dir = test::temp_dir("or_display_window");
  test::SessionSite s(test::patient_hub());
  const CameraCalibration camera = s.site.player.cameras()[0].calibration;
  test::TestParticipant expert(s, test::named("Dr. Remote"));
  ASSERT_TRUE(test::eventually([&] { return expert.now().joined; }, std::chrono::seconds(30)));
  const SessionSnapshot joined = expert.now();
  // A stroke across the picture's centre 35 cm in front of the camera and a label beside it 50 cm
  // away (nearer than the table and the hands), room frame.
  const RigidTransform room_from_camera = joined.room_from_site * camera.world_from_camera;
  const auto room = [&](double x, double y, double z) -> Eigen::Vector3f {
    return (room_from_camera * Eigen::Vector3d(x, y, z)).cast<float>();
  };
  session::Annotation stroke;
  stroke.kind = session::AnnotationKind::kStroke;
  for (int i = -4; i <= 4; ++i) stroke.points.push_back(room(0.01 * i, 0.0, 0.35));
  session::Annotation label;
  label.kind = session::AnnotationKind::kLabel;
  label.points = {room(-0.12, 0.0, 0.5)};
  label.text = "cut here";
  expert.p().annotate(stroke);
  expert.p().annotate(label);
  ASSERT_TRUE(test::eventually([&] { return expert.now().annotations.size() == 2; },
                               std::chrono::seconds(30)));

  SessionClientOptions wall_options = test::named("OR wall display");
  wall_options.drive_poses = false;  // it watches
  SessionClient wall(wall_options);
  ViewerOptions opt;
  opt.client = client_config_from_link(s.link());
  opt.seconds = 300;  // a safety net only: the window closes itself after max_frames
  opt.on_connected = [&](Client& c) { wall.start(c); };
  opt.on_finished = [&](ViewerResult&) { wall.stop(); };
  OrDisplayWindowOptions w;
  w.width = 800;
  w.height = 450;
  w.participant = [&] { return wall.participant(); };
  w.screenshot = dir / "wall.png";
  // Full screen at once; the screenshot once the annotations have surely arrived (joining gives
  // them with the session's state, before the first frame drawn with the camera's picture).
  w.script = {{2, GLFW_KEY_F11}, {12, GLFW_KEY_F12}};
  w.max_frames = 14;
  opt.presenter = or_display_window_presenter(w);
  const ViewerResult r = run_viewer(opt);
  EXPECT_EQ(r.ended, ViewerEnd::kClosed) << r.error;
  EXPECT_EQ(r.frames_rendered, 14u);
  ASSERT_TRUE(fs::exists(w.screenshot));
  const ColorImage shot = read_color_png(w.screenshot);
  std::printf("picture: %s\n", w.screenshot.c_str());
  ASSERT_EQ(shot.width, 1280) << "full screen on Xvfb's 1280x1024 screen";
  ASSERT_EQ(shot.height, 1024);

  // Where the picture lies: the camera's 640x360 image turned upright, as large as fits, centred.
  const int turns = upright_quarter_turns(room_from_camera);
  const int w0 = camera.depth.width, h0 = camera.depth.height;
  const int shown_w = turns % 2 ? h0 : w0, shown_h = turns % 2 ? w0 : h0;
  const float scale = std::min(1280.0f / float(shown_w), 1024.0f / float(shown_h));
  const float left = (1280 - float(shown_w) * scale) / 2;
  const float top = (1024 - float(shown_h) * scale) / 2;
  const auto window_at = [&](const Eigen::Vector3f& room_point) {
    const Eigen::Vector3d c = room_from_camera.inverse() * room_point.cast<double>();
    const Eigen::Vector2f pixel(float(camera.depth.fx * c.x() / c.z() + camera.depth.cx),
                                float(camera.depth.fy * c.y() / c.z() + camera.depth.cy));
    const Eigen::Vector2f t = turned_point(pixel, w0, h0, turns);
    return Eigen::Vector2f(left + t.x() * scale, top + t.y() * scale);
  };
  // Bars outside the picture are black, the picture is the camera's (many colours).
  const Eigen::Vector3i black(0, 0, 0);
  if (top >= 8) {
    const int bottom_bar = pixels_of(shot, 0, int(1024 - top) + 2, 1280, 1024, black, 2);
    EXPECT_EQ(bottom_bar, 1280 * (1024 - (int(1024 - top) + 2))) << "the bar under the picture";
  }
  const int inside_black = pixels_of(shot, int(left) + 4, int(top) + 4, int(1280 - left) - 4,
                                     int(1024 - top) - 4, black, 8);
  EXPECT_LT(inside_black, int((1280 - 2 * left) * (1024 - 2 * top) / 4)) << "the camera's image";

  const Eigen::Vector3f rgb = participant_color(joined.id);
  const Eigen::Vector3i exact = (rgb * 255).array().round().cast<int>();
  // The stroke: pixels of the expert's colour (glowing, shaded) around its centre's projection.
  const Eigen::Vector2f centre = window_at(stroke.points[4]);
  const int stroke_px = pixels_of(shot, int(centre.x()) - 30, int(centre.y()) - 30,
                                  int(centre.x()) + 30, int(centre.y()) + 30, exact, 60);
  std::printf("stroke centre at (%.0f, %.0f): %d px of the expert's colour near it\n", centre.x(),
              centre.y(), stroke_px);
  EXPECT_GT(stroke_px, 200);
  // The label's text: Dear ImGui's exact colour over its pin's top, and nowhere near the corner
  // opposite to it.
  const Eigen::Vector2f pin = window_at(label_anchor(expert.now().annotations[1]));
  const int text_px = pixels_of(shot, int(pin.x()) - 150, int(pin.y()) - 90, int(pin.x()) + 150,
                                int(pin.y()) + 5, exact, 2);
  std::printf("label pin top at (%.0f, %.0f): %d px of its text\n", pin.x(), pin.y(), text_px);
  EXPECT_GT(text_px, 150);
  // The legend (top left) names the expert in its colour.
  const int legend_px = pixels_of(shot, 0, 0, 600, 200, exact, 2);
  EXPECT_GT(legend_px, 60) << "the expert's row in the legend";
  expert.end();
}

}  // namespace
}  // namespace volcast
