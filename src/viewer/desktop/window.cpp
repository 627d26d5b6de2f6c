// The desktop presenter: GLFW window and context, input, the frame loop.
#include <epoxy/gl.h>  // before GLFW, which then includes no GL header of its own
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <fmt/format.h>
#include <imgui.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cctype>
#include <chrono>

#include "case_panel.hpp"
#include "glfw_window.hpp"
#include "panel.hpp"
#include "pointing.hpp"
#include "screenshot.hpp"
#include "session_panel.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/io/site_config.hpp"
#include "volcast/pipeline/viewer_result.hpp"
#include "volcast/render/annotation_scene.hpp"
#include "volcast/render/frame_budget.hpp"
#include "volcast/viewer/desktop.hpp"
#include "volcast/viewer/navigation.hpp"
#include "volcast/viewer/voice_keys.hpp"

namespace volcast {
namespace {

// A steady clock, µs: when an erase key went down and when its erase is due (EraseLast).
int64_t steady_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

static_assert(kTalkKey == GLFW_KEY_V && kMuteKey == GLFW_KEY_M);

constexpr float kDegreesPerPixel = 0.3f;
constexpr int kRedrawFrames = 3;  // frames drawn after an input event (the panel settles)

// What the input callbacks change (reached through glfwGetWindowUserPointer).
struct Input {
  ViewerControls& controls;
  ViewCamera& camera;
  SessionPanelState* session = nullptr;  // in a session
  PointingState* pointing = nullptr;     // in a session
  bool click_pending = false;            // teleport mode: a left click to act on
  bool orbiting = false, looking = false;
  double mouse_x = 0, mouse_y = 0;
  int redraw = kRedrawFrames;
};

Input& input_of(GLFWwindow* window) {
  return *static_cast<Input*>(glfwGetWindowUserPointer(window));
}

// A key event, from GLFW or from DesktopOptions::script.
void handle_key(Input& in, int key, int action, int mods) {
  in.redraw = kRedrawFrames;
  if (in.session) voice_key(in.session->voice, key, action, mods);  // M, V (held)
  if (in.pointing && key == GLFW_KEY_L && action != GLFW_REPEAT)
    in.pointing->laser = action == GLFW_PRESS;
  if (action != GLFW_PRESS) return;
  if (in.pointing && key == GLFW_KEY_N) in.pointing->pin_label = true;
  if (in.pointing && key == GLFW_KEY_BACKSPACE) in.pointing->erase_pressed = true;
  if (key == GLFW_KEY_S && (mods & GLFW_MOD_CONTROL)) in.controls.save = true;
  if (mods & GLFW_MOD_CONTROL) return;
  if (key == GLFW_KEY_F12 || key == GLFW_KEY_P) in.controls.screenshot = true;
  if (key == GLFW_KEY_R) in.controls.reset_view = true;
  if (key == GLFW_KEY_H) in.controls.show_panel = !in.controls.show_panel;
  if (key == GLFW_KEY_T && in.session) in.session->teleport_mode = !in.session->teleport_mode;
}

void on_key(GLFWwindow* window, int key, int scancode, int action, int mods) {
  ImGui_ImplGlfw_KeyCallback(window, key, scancode, action, mods);
  // Typing into the panel: keys are the panel's, but a release still ends a held V.
  if (ImGui::GetIO().WantCaptureKeyboard && action != GLFW_RELEASE) {
    input_of(window).redraw = kRedrawFrames;
    return;
  }
  handle_key(input_of(window), key, action, mods);
}

// A mouse button pressed (`press`, not over the panel) or let go, with modifier bits `mods`,
// from GLFW or a test's script. With L held, or Shift or Alt, it draws instead of navigating (as
// the browser page does): left drag a stroke (Alt: an arrow), right drag an arrow.
void mouse_button(Input& in, int button, bool press, int mods) {
  in.redraw = kRedrawFrames;
  const bool shift = mods & GLFW_MOD_SHIFT, alt = mods & GLFW_MOD_ALT;
  if (in.pointing && (in.pointing->laser || shift || alt || !press)) {
    if (in.pointing->laser || shift || alt) in.pointing->dragging = press;
    if (button == GLFW_MOUSE_BUTTON_LEFT && !alt) in.pointing->drawing = press;
    if (button == GLFW_MOUSE_BUTTON_RIGHT || (button == GLFW_MOUSE_BUTTON_LEFT && alt))
      in.pointing->arrow = press;
    if (!press) in.pointing->drawing = in.pointing->arrow = in.pointing->dragging = false;
    if (press) return;
  }
  if (press && button == GLFW_MOUSE_BUTTON_LEFT && in.session && in.session->teleport_mode) {
    in.click_pending = true;  // the loop casts the ray with this frame's view
    return;
  }
  if (button == GLFW_MOUSE_BUTTON_LEFT) in.orbiting = press;
  if (button == GLFW_MOUSE_BUTTON_RIGHT) in.looking = press;
}

void on_mouse_button(GLFWwindow* window, int button, int action, int mods) {
  ImGui_ImplGlfw_MouseButtonCallback(window, button, action, mods);
  Input& in = input_of(window);
  glfwGetCursorPos(window, &in.mouse_x, &in.mouse_y);
  mouse_button(in, button, action == GLFW_PRESS && !ImGui::GetIO().WantCaptureMouse, mods);
}

void on_cursor(GLFWwindow* window, double x, double y) {
  Input& in = input_of(window);
  const auto dx = static_cast<float>(x - in.mouse_x), dy = static_cast<float>(y - in.mouse_y);
  in.mouse_x = x, in.mouse_y = y;
  in.redraw = kRedrawFrames;
  // Orbit grabs the scene (it follows the mouse); look turns the eye toward the mouse.
  if (in.orbiting) in.camera = orbit(in.camera, -dx * kDegreesPerPixel, dy * kDegreesPerPixel);
  if (in.looking) in.camera = look(in.camera, -dx * kDegreesPerPixel, -dy * kDegreesPerPixel);
}

void on_scroll(GLFWwindow* window, double x, double y) {
  ImGui_ImplGlfw_ScrollCallback(window, x, y);
  Input& in = input_of(window);
  in.redraw = kRedrawFrames;
  if (!ImGui::GetIO().WantCaptureMouse) in.camera = zoom(in.camera, static_cast<float>(y));
}

void on_char(GLFWwindow* window, unsigned int c) {
  ImGui_ImplGlfw_CharCallback(window, c);
  input_of(window).redraw = kRedrawFrames;
}

// WASD / QE held down: moves the camera for `seconds`; true if it moved.
bool fly_keys(GLFWwindow* window, ViewCamera& camera, float seconds) {
  if (ImGui::GetIO().WantCaptureKeyboard) return false;
  const auto held = [&](int key) { return glfwGetKey(window, key) == GLFW_PRESS ? 1.0f : 0.0f; };
  const Eigen::Vector3f direction(held(GLFW_KEY_D) - held(GLFW_KEY_A),
                                  held(GLFW_KEY_E) - held(GLFW_KEY_Q),
                                  held(GLFW_KEY_W) - held(GLFW_KEY_S));
  if (direction.isZero() || held(GLFW_KEY_LEFT_CONTROL) + held(GLFW_KEY_RIGHT_CONTROL) > 0)
    return false;  // Ctrl+S saves, it does not fly back
  const bool fast = held(GLFW_KEY_LEFT_SHIFT) + held(GLFW_KEY_RIGHT_SHIFT) > 0;
  // Faster far from the pivot, like the wheel; at least 0.25 m/s.
  const float speed = std::max(0.25f, (camera.target - camera.eye).norm()) * (fast ? 4.0f : 1.0f);
  camera = fly(camera, direction * speed * std::min(seconds, 0.1f));
  return true;
}

// Acts on the panel's requests other than the screenshot (taken right after drawing the scene).
void apply_requests(ViewerControls& c, CameraRenderer& renderer,
                    const std::vector<CameraCalibration>& cameras, const DesktopOptions& o,
                    ViewCamera& camera, const ViewCamera& start) {
  if (c.poses_changed) {
    for (size_t i = 0; i < cameras.size(); ++i)
      renderer.set_world_from_camera(i, apply_sliders(cameras[i].world_from_camera, c.sliders[i]));
    c.poses_changed = false;
  }
  if (c.filter_changed) {
    renderer.set_avatar_filter(avatar_filter_of(c));
    c.filter_changed = false;
  }
  if (c.reset_view) {
    camera = start;
    c.reset_view = false;
  }
  if (c.save) {
    c.save = false;
    std::vector<RigidTransform> poses;
    for (size_t i = 0; i < cameras.size(); ++i)
      poses.push_back(apply_sliders(cameras[i].world_from_camera, c.sliders[i]));
    try {
      write_site_poses(o.site_config, poses);
      c.status = fmt::format("saved {} camera pose(s) to {}", poses.size(), o.site_config.string());
      spdlog::info("{}", c.status);
    } catch (const Error& e) {
      c.status = fmt::format("Save failed: {}", e.what());
      spdlog::warn("{}", c.status);
    }
  }
}

// The eye of a participant as a ViewCamera (room frame, +y up).
ViewCamera camera_at_eye(const SessionSnapshot& s) {
  const View eye = participant_eye(s, 1);
  ViewCamera v;
  v.eye = eye.world_from_view.translation.cast<float>();
  v.target = (eye.world_from_view * Eigen::Vector3d(0, 0, -1)).cast<float>();
  v.up = {0, 1, 0};
  v.vertical_fov_deg = 70;
  return v;
}

// Publishes the window's eye as the participant's head (play area frame), and follows its
// teleports: when its spot moved, the eye moves with it.
void sync_participant(Participant& p, const SessionSnapshot& s, ViewCamera& camera,
                      session::Spot& last_spot) {
  if (s.spot.x != last_spot.x || s.spot.z != last_spot.z || s.spot.yaw != last_spot.yaw) {
    const RigidTransform moved =
        session::room_from_playarea(s.spot) * session::room_from_playarea(last_spot).inverse();
    camera.eye = (moved * camera.eye.cast<double>()).cast<float>();
    camera.target = (moved * camera.target.cast<double>()).cast<float>();
    last_spot = s.spot;
  }
  if (!s.joined) return;
  const RigidTransform room_from_view =
      look_at(camera.eye.cast<double>(), camera.target.cast<double>(), {0, 1, 0});
  const RigidTransform playarea_from_view =
      session::room_from_playarea(s.spot).inverse() * room_from_view;
  BodyPose body;
  body.head.position = playarea_from_view.translation.cast<float>();
  body.head.orientation = Eigen::Quaternionf(playarea_from_view.rotation.cast<float>());
  p.publish(body);
}

// Teleport: the floor spot under the window point (x, y) (screen coordinates), if any.
void teleport_at(Participant& p, const ViewCamera& camera, double x, double y, int width,
                 int height) {
  const View view = to_view(camera, float(width) / float(height));
  const Eigen::Matrix4f world_from_clip = view.clip_from_world().inverse();
  const float nx = float(2 * x / width - 1), ny = float(1 - 2 * y / height);
  const Eigen::Vector4f a = world_from_clip * Eigen::Vector4f(nx, ny, -1, 1);
  const Eigen::Vector4f b = world_from_clip * Eigen::Vector4f(nx, ny, 1, 1);
  const Eigen::Vector3f from = a.head<3>() / a.w(), to = b.head<3>() / b.w();
  if (!(from.y() > 0 && to.y() < from.y())) return;  // not looking down at the floor
  const Eigen::Vector3f hit = from + (to - from) * (from.y() / (from.y() - to.y()));
  const Eigen::Vector3f sight = camera.target - camera.eye;
  p.teleport({hit.x(), hit.z(), std::atan2(-sight.x(), -sight.z())});
}

void take_screenshot(ViewerControls& c, const DesktopOptions& o, const RenderTarget& target) {
  c.screenshot = false;
  const std::filesystem::path path = screenshot_path(o.screenshot);
  try {
    save_screenshot(target.width, target.height, path);
    c.status = fmt::format("screenshot {}", path.string());
    spdlog::info("wrote screenshot {} ({}x{})", path.string(), target.width, target.height);
  } catch (const Error& e) {
    c.status = fmt::format("screenshot failed: {}", e.what());
    spdlog::warn("{}", c.status);
  }
}

using Frames = std::vector<std::shared_ptr<const CameraFrame>>;

// Routes the window's input to `input` (reached through the window's user pointer) and to Dear
// ImGui.
void install_callbacks(GLFWwindow* window, Input& input) {
  glfwSetWindowUserPointer(window, &input);
  glfwSetKeyCallback(window, on_key);
  glfwSetMouseButtonCallback(window, on_mouse_button);
  glfwSetCursorPosCallback(window, on_cursor);
  glfwSetScrollCallback(window, on_scroll);
  glfwSetCharCallback(window, on_char);
  glfwSetWindowFocusCallback(window, ImGui_ImplGlfw_WindowFocusCallback);
  glfwSetCursorEnterCallback(window, ImGui_ImplGlfw_CursorEnterCallback);
}

// Where the window looks from: the camera the user moves and the view R returns to, set once the
// session starts; from then on frames are counted.
struct Viewpoint {
  ViewCamera camera, start;
  bool started = false;     // a frame of the stream arrived (or the participant joined)
  session::Spot last_spot;  // with a participant: its spot when last seen (its teleports)
};

// Starts the view once there is something to see: with a participant once it joined (at its
// eye), else at the stream's first frame (default_view()); DesktopOptions::view if given.
void start_when_ready(Viewpoint& v, const DesktopOptions& o, Participant* participant,
                      const SessionSnapshot& snapshot,
                      const std::vector<CameraCalibration>& cameras, const Frames& uploaded) {
  if (!v.started && participant && snapshot.joined) {
    v.started = true;
    v.last_spot = snapshot.spot;
    v.start = o.view ? *o.view : camera_at_eye(snapshot);
    v.camera = v.start;
  }
  if (!v.started && std::any_of(uploaded.begin(), uploaded.end(), [](auto& f) { return !!f; })) {
    v.started = true;
    v.start = o.view ? *o.view : default_view(cameras, uploaded);
    v.camera = v.start;
  }
}

// A test's scripted keys (sorted by frame, stable) and clicks, and how many were played.
struct Script {
  std::vector<ScriptedKey> keys;
  size_t next_key = 0, next_click = 0, next_mouse = 0;
};

Script script_of(const DesktopOptions& o) {
  Script script{o.script};
  std::stable_sort(script.keys.begin(), script.keys.end(),
                   [](const ScriptedKey& a, const ScriptedKey& b) { return a.frame < b.frame; });
  return script;
}

// Plays the scripted keys and clicks due by the frame about to be drawn (`drawn` + 1) as real
// ones.
void play_script(Script& script, const std::vector<ScriptedClick>& clicks,
                 const std::vector<ScriptedMouse>& mouse, Input& input, uint64_t drawn) {
  for (; script.next_key < script.keys.size() && script.keys[script.next_key].frame <= drawn + 1;
       ++script.next_key)
    handle_key(input, script.keys[script.next_key].key,
               script.keys[script.next_key].release ? GLFW_RELEASE : GLFW_PRESS,
               script.keys[script.next_key].mods);
  for (; script.next_click < clicks.size() && clicks[script.next_click].frame <= drawn + 1;
       ++script.next_click)
    if (input.session && input.session->teleport_mode) {  // as on_mouse_button does
      input.mouse_x = clicks[script.next_click].x;
      input.mouse_y = clicks[script.next_click].y;
      input.click_pending = true;
    }
  for (; script.next_mouse < mouse.size() && mouse[script.next_mouse].frame <= drawn + 1;
       ++script.next_mouse) {
    const ScriptedMouse& m = mouse[script.next_mouse];
    input.mouse_x = m.x;
    input.mouse_y = m.y;
    if (m.button >= 0) mouse_button(input, m.button, !m.release, m.mods);
  }
}

// With a participant, before its scene is drawn: acts on a teleport click, then publishes the
// window's eye as its head and follows its teleports.
void steer_participant(GLFWwindow* window, Participant& participant,
                       const SessionSnapshot& snapshot, Input& input, Viewpoint& v) {
  if (input.click_pending) {
    input.click_pending = false;
    input.session->teleport_mode = false;
    int window_w = 0, window_h = 0;
    glfwGetWindowSize(window, &window_w, &window_h);
    if (window_w > 0 && window_h > 0)
      teleport_at(participant, v.camera, input.mouse_x, input.mouse_y, window_w, window_h);
  }
  sync_participant(participant, snapshot, v.camera, v.last_spot);
}

// The panel over the scene, unless hidden (H); with a participant the session and case sections
// come first.
void draw_gui(ViewerControls& controls, const PanelInfo& info, Participant* participant,
              const voice::VoiceLink* voice, SessionPanelState& session_panel,
              CasePanelState& case_panel, PointingState& pointing, const SessionSnapshot& snapshot,
              const View& view, int width, int height) {
  ImGui_ImplOpenGL3_NewFrame();
  ImGui_ImplGlfw_NewFrame();
  ImGui::NewFrame();
  if (participant)
    draw_label_texts(snapshot, view, ImGui::GetIO().DisplaySize.x, ImGui::GetIO().DisplaySize.y);
  if (!info.live.connection.empty()) {        // a cut: over the picture, panel shown or not
    std::string text = info.live.connection;  // "reconnecting (try 2): why", in capitals first
    for (size_t i = 0; i < text.size() && text[i] != ' ' && text[i] != ':'; ++i)
      text[i] = static_cast<char>(std::toupper(static_cast<unsigned char>(text[i])));
    const ImVec2 size = ImGui::CalcTextSize(text.c_str());
    const ImVec2 at((ImGui::GetIO().DisplaySize.x - size.x) / 2, 24);
    ImDrawList* d = ImGui::GetForegroundDrawList();
    d->AddRectFilled(ImVec2(at.x - 10, at.y - 6), ImVec2(at.x + size.x + 10, at.y + size.y + 6),
                     IM_COL32(170, 110, 0, 230), 6);
    d->AddText(at, IM_COL32(255, 255, 255, 255), text.c_str());
  }
  if (participant)  // never silently: over the picture, panel shown or not
    draw_recording_badge(ImGui::GetForegroundDrawList(), snapshot.recording,
                         ImGui::GetFontSize() * 1.2f, ImGui::GetIO().DisplaySize.x);
  if (controls.show_panel) {
    if (participant) {
      draw_panel(controls, info, [&] {
        draw_session_panel(session_panel, *participant, snapshot, voice);
        draw_annotation_panel(pointing, *participant, snapshot);
        draw_case_panel(case_panel, *participant, snapshot);
      });
    } else {
      draw_panel(controls, info);
    }
  }
  ImGui::Render();
  glViewport(0, 0, width, height);
  ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
}

// The display period the frame budget holds frames to: the options', else the primary monitor's
// refresh rate, else 60 Hz (Xvfb reports none).
int64_t display_period_us(const DesktopOptions& o) {
  if (o.frame_period_us > 0) return o.frame_period_us;
  GLFWmonitor* monitor = glfwGetPrimaryMonitor();
  const GLFWvidmode* mode = monitor ? glfwGetVideoMode(monitor) : nullptr;
  return 1'000'000 / (mode && mode->refreshRate > 0 ? mode->refreshRate : 60);
}

void present(FrameFeed& feed, ViewerResult& result, const DesktopOptions& o) {
  Glfw glfw;
  Window window(o.width, o.height, o.title);
  CameraRenderer renderer;
  Participant* participant = o.participant ? o.participant() : nullptr;
  std::unique_ptr<SessionScene> scene;
  if (participant) scene = std::make_unique<SessionScene>();
  SessionPanelState session_panel;
  CasePanelState case_panel;
  PointingState pointing;
  Viewpoint viewpoint;
  result.renderer = renderer.gl_description();
  Gui gui(window.window);
  const std::vector<CameraCalibration>& cameras = feed.cameras();
  renderer.set_cameras(cameras);
  renderer.set_avatar_filter(o.avatar_filter);
  ViewerControls controls = initial_controls(o.pass, o.avatar_filter, cameras.size());
  if (o.blend == BlendPolicy::kOff) controls.pass.blend = false;
  FrameBudget budget(display_period_us(o));
  Input input{controls, viewpoint.camera};
  if (participant) input.session = &session_panel, input.pointing = &pointing;
  install_callbacks(window.window, input);
  spdlog::info("desktop window {}x{}: {}", o.width, o.height, result.renderer);

  Script script = script_of(o);
  Frames frames, uploaded(cameras.size());
  uint64_t drawn = 0;  // frames drawn since the view started
  LiveStats live = feed.live();
  auto last_live = std::chrono::steady_clock::now(), last_loop = last_live;
  while (!feed.finished()) {
    glfwPollEvents();
    if (glfwWindowShouldClose(window.window)) break;
    const bool arrived = feed.next(frames, std::chrono::milliseconds(5));
    const auto now = std::chrono::steady_clock::now();
    const bool flew = fly_keys(window.window, viewpoint.camera,
                               std::chrono::duration<float>(now - last_loop).count());
    last_loop = now;
    upload_changed(renderer, frames, uploaded);
    SessionSnapshot snapshot;
    if (participant) snapshot = participant->snapshot(wall_clock_us());
    voice::VoiceLink* voice = participant && o.voice ? o.voice() : nullptr;  // null: not (yet)
    start_when_ready(viewpoint, o, participant, snapshot, cameras, uploaded);
    if (now - last_live > std::chrono::milliseconds(250)) {
      const std::string was = live.connection;
      live = feed.live();
      last_live = now;
      if (live.connection != was) {  // a cut (no frames come to redraw for) or its end
        input.redraw = std::max(input.redraw, 1);
        glfwSetWindowTitle(
            window.window,
            (live.connection.empty() ? o.title : "RECONNECTING - " + o.title).c_str());
      }
    }
    // In a session the others move on their own: draw every frame (vsync paces it).
    if (!(arrived || flew || input.redraw > 0 || participant)) continue;  // nothing new to draw
    input.redraw = std::max(0, input.redraw - 1);
    const auto drawing = std::chrono::steady_clock::now();
    const bool blended = controls.pass.blend && viewpoint.started;
    if (viewpoint.started) play_script(script, o.clicks, o.mouse, input, drawn);
    apply_requests(controls, renderer, cameras, o, viewpoint.camera, viewpoint.start);
    if (voice) apply_voice_input(*voice, session_panel.voice);  // the keys (also minimised)
    int width = 0, height = 0;
    glfwGetFramebufferSize(window.window, &width, &height);
    if (width <= 0 || height <= 0) continue;  // minimised
    const RenderTarget target{0, 0, 0, width, height};
    const View view = to_view(viewpoint.camera, target.aspect());
    if (participant) {
      steer_participant(window.window, *participant, snapshot, input, viewpoint);
      SessionSceneOptions so = o.scene;
      so.pass = controls.pass;
      so.own_pointer = false;  // found under the mouse below, then drawn
      scene->draw(view, target, cameras, uploaded, *participant, wall_clock_us(), so);
      int window_w = 1, window_h = 1;
      glfwGetWindowSize(window.window, &window_w, &window_h);
      const double scale = double(width) / std::max(window_w, 1);
      const std::vector<Primitive> own =
          point_and_draw(pointing, *participant, snapshot, view, target, input.mouse_x * scale,
                         input.mouse_y * scale, participant_color(snapshot.id), steady_us());
      if (!own.empty()) scene->draw_primitives(view, target, own);
    } else {
      renderer.draw_cameras(to_view(viewpoint.camera, target.aspect()), target, controls.pass);
    }
    if (controls.screenshot && !o.screenshot_panel) take_screenshot(controls, o, target);
    draw_gui(controls,
             PanelInfo{live, result.renderer, viewpoint.camera.target, viewpoint.camera.eye,
                       o.site_config},
             participant, voice, session_panel, case_panel, pointing, snapshot, view, width,
             height);
    if (voice) apply_voice_input(*voice, session_panel.voice);  // the panel's
    if (controls.screenshot && o.screenshot_panel) take_screenshot(controls, o, target);
    glfwSwapBuffers(window.window);
    feed.presented();
    const auto frame_us = std::chrono::duration_cast<std::chrono::microseconds>(
        std::chrono::steady_clock::now() - drawing);
    if (o.blend == BlendPolicy::kAuto && budget.add(frame_us.count(), blended)) {
      controls.pass.blend = false;
      controls.blend_off = result.blend_off = budget.reason();
      spdlog::warn("{}", budget.reason());
    }
    if (controls.poses_changed || controls.filter_changed || controls.save || controls.screenshot ||
        controls.reset_view)
      input.redraw = std::max(input.redraw, 1);  // act on the panel's requests next loop
    if (!viewpoint.started) continue;
    ++drawn;
    ++result.frames_rendered;
    if (o.max_frames > 0 && drawn >= o.max_frames) break;
  }
  feed.close();  // the window closed (or the session ended, when this changes nothing)
}

}  // namespace

bool desktop_available(std::string* why) {
  try {
    Glfw glfw;
    return true;
  } catch (const std::exception& e) {
    if (why) *why = e.what();
  } catch (...) {
    if (why) *why = "GLFW cannot start";
  }
  return false;
}

Presenter desktop_presenter(const DesktopOptions& options) {
  return [options](FrameFeed& feed, ViewerResult& result) { present(feed, result, options); };
}

}  // namespace volcast
