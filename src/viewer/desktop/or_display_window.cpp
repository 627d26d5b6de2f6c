// The OR display's window: OrDisplay drawn into a texture of the camera's size, shown upright and
// letterboxed through Dear ImGui's background draw list, with the labels' text and a legend.
#include "volcast/viewer/or_display_window.hpp"

#include <epoxy/gl.h>  // before GLFW, which then includes no GL header of its own
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <fmt/format.h>
#include <imgui.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <array>
#include <chrono>

#include "glfw_window.hpp"
#include "screenshot.hpp"
#include "session_panel.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/pipeline/or_display.hpp"
#include "volcast/pipeline/viewer_result.hpp"
#include "volcast/render/annotation_scene.hpp"

namespace volcast {
namespace {

// A framebuffer of width x height with an RGBA8 colour texture (what the window shows) and a
// 24-bit depth renderbuffer, in the current context.
struct Picture {
  GLuint framebuffer = 0, color = 0, depth = 0;
  int width = 0, height = 0;
  Picture(int w, int h) : width(w), height(h) {
    glCreateTextures(GL_TEXTURE_2D, 1, &color);
    glTextureStorage2D(color, 1, GL_RGBA8, w, h);
    glTextureParameteri(color, GL_TEXTURE_MIN_FILTER, GL_LINEAR);
    glTextureParameteri(color, GL_TEXTURE_MAG_FILTER, GL_LINEAR);
    glTextureParameteri(color, GL_TEXTURE_WRAP_S, GL_CLAMP_TO_EDGE);
    glTextureParameteri(color, GL_TEXTURE_WRAP_T, GL_CLAMP_TO_EDGE);
    glCreateRenderbuffers(1, &depth);
    glNamedRenderbufferStorage(depth, GL_DEPTH_COMPONENT24, w, h);
    glCreateFramebuffers(1, &framebuffer);
    glNamedFramebufferTexture(framebuffer, GL_COLOR_ATTACHMENT0, color, 0);
    glNamedFramebufferRenderbuffer(framebuffer, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, depth);
    if (glCheckNamedFramebufferStatus(framebuffer, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
      throw Error(fmt::format("OR display window: its {}x{} framebuffer is incomplete", w, h));
  }
  ~Picture() {
    glDeleteFramebuffers(1, &framebuffer);
    glDeleteRenderbuffers(1, &depth);
    glDeleteTextures(1, &color);
  }
  Picture(const Picture&) = delete;
  Picture& operator=(const Picture&) = delete;
  RenderTarget target() const { return {framebuffer, 0, 0, width, height}; }
};

// What the keys change (reached through glfwGetWindowUserPointer).
struct DisplayKeys {
  bool toggle_fullscreen = false, leave_fullscreen = false, screenshot = false;
  bool legend = true;
};

void handle_display_key(DisplayKeys& k, int key, int action) {
  if (action != GLFW_PRESS) return;
  if (key == GLFW_KEY_F11 || key == GLFW_KEY_F) k.toggle_fullscreen = true;
  if (key == GLFW_KEY_ESCAPE) k.leave_fullscreen = true;
  if (key == GLFW_KEY_H) k.legend = !k.legend;
  if (key == GLFW_KEY_F12 || key == GLFW_KEY_P) k.screenshot = true;
}

void on_display_key(GLFWwindow* window, int key, int scancode, int action, int mods) {
  ImGui_ImplGlfw_KeyCallback(window, key, scancode, action, mods);
  handle_display_key(*static_cast<DisplayKeys*>(glfwGetWindowUserPointer(window)), key, action);
}

// Full screen on the monitor the window is most on (the primary one if none), or back to the
// windowed size it had (`windowed`: x, y, width, height, kept while full screen).
void set_fullscreen(GLFWwindow* window, bool on, std::array<int, 4>& windowed) {
  if (on == (glfwGetWindowMonitor(window) != nullptr)) return;
  if (!on) {
    glfwSetWindowMonitor(window, nullptr, windowed[0], windowed[1], windowed[2], windowed[3], 0);
    return;
  }
  glfwGetWindowPos(window, &windowed[0], &windowed[1]);
  glfwGetWindowSize(window, &windowed[2], &windowed[3]);
  GLFWmonitor* monitor = glfwGetPrimaryMonitor();
  int count = 0;
  GLFWmonitor** monitors = glfwGetMonitors(&count);
  const int cx = windowed[0] + windowed[2] / 2, cy = windowed[1] + windowed[3] / 2;
  for (int i = 0; i < count; ++i) {
    int x = 0, y = 0, w = 0, h = 0;
    glfwGetMonitorWorkarea(monitors[i], &x, &y, &w, &h);
    if (cx >= x && cy >= y && cx < x + w && cy < y + h) monitor = monitors[i];
  }
  const GLFWvidmode* mode = monitor ? glfwGetVideoMode(monitor) : nullptr;
  if (!mode) {
    spdlog::warn("OR display window: no monitor to go full screen on");
    return;
  }
  glfwSetWindowMonitor(window, monitor, 0, 0, mode->width, mode->height, mode->refreshRate);
}

ImU32 imgui_color(const Eigen::Vector3f& rgb, int alpha = 255) {
  const auto c = [](float v) { return static_cast<int>(std::clamp(v, 0.0f, 1.0f) * 255 + 0.5f); };
  return IM_COL32(c(rgb.x()), c(rgb.y()), c(rgb.z()), alpha);
}

// Where the picture of a `w` x `h` camera image turned `turns` quarter turns goes in a window of
// `width` x `height` pixels: as large as fits, centred.
struct Placement {
  float x = 0, y = 0, scale = 1;
  int turns = 0, w = 0, h = 0;  // the unturned picture's size
  ImVec2 at(const Eigen::Vector2f& pixel) const {
    const Eigen::Vector2f p = turned_point(pixel, w, h, turns);
    return {x + p.x() * scale, y + p.y() * scale};
  }
};

Placement place(int w, int h, int turns, int width, int height) {
  const bool sideways = turns % 2 != 0;
  const float shown_w = float(sideways ? h : w), shown_h = float(sideways ? w : h);
  Placement p;
  p.scale = std::min(float(width) / shown_w, float(height) / shown_h);
  p.x = (float(width) - shown_w * p.scale) / 2;
  p.y = (float(height) - shown_h * p.scale) / 2;
  p.turns = turns, p.w = w, p.h = h;
  return p;
}

// The picture (a GL texture: its first row is the image's bottom row) upright in the window.
void draw_picture(ImDrawList* list, const Picture& picture, const Placement& p) {
  // The image's corners, top-left, top-right, bottom-right, bottom-left, in texture coordinates
  // and in pixels; the window's corner i shows the image's corner i + turns.
  const std::array<ImVec2, 4> uv = {ImVec2(0, 1), ImVec2(1, 1), ImVec2(1, 0), ImVec2(0, 0)};
  const auto w = float(p.w), h = float(p.h);
  const std::array<Eigen::Vector2f, 4> corner = {Eigen::Vector2f(0, 0), Eigen::Vector2f(w, 0),
                                                 Eigen::Vector2f(w, h), Eigen::Vector2f(0, h)};
  std::array<ImVec2, 4> at{}, from{};
  for (int i = 0; i < 4; ++i) {
    const int j = (i + p.turns) % 4;
    at[i] = p.at(corner[j]);
    from[i] = uv[j];
  }
  // Shown as it is, not blended by its alpha (the passes leave alpha as they like).
  list->AddCallback([](const ImDrawList*, const ImDrawCmd*) { glDisable(GL_BLEND); }, nullptr);
  const auto texture = reinterpret_cast<ImTextureID>(static_cast<intptr_t>(picture.color));
  list->AddImageQuad(texture, at[0], at[1], at[2], at[3], from[0], from[1], from[2], from[3]);
  list->AddCallback(ImDrawCallback_ResetRenderState, nullptr);
}

// Text with a dark outline, readable on any part of the picture.
void outlined_text(ImDrawList* list, float size, ImVec2 at, ImU32 color, const std::string& text) {
  ImFont* font = ImGui::GetFont();
  for (const ImVec2 d : {ImVec2(-1, -1), ImVec2(1, -1), ImVec2(-1, 1), ImVec2(1, 1), ImVec2(2, 2)})
    list->AddText(font, size, ImVec2(at.x + d.x, at.y + d.y), IM_COL32(0, 0, 0, 220), text.c_str());
  list->AddText(font, size, at, color, text.c_str());
}

// The labels' text, each over its pin's top in its author's colour, large enough for the room.
void draw_labels(ImDrawList* list, const std::vector<OrDisplayLabel>& labels, const Placement& p,
                 float size) {
  for (const OrDisplayLabel& l : labels) {
    const ImVec2 at = p.at(l.pixel);
    const ImVec2 extent = ImGui::GetFont()->CalcTextSizeA(size, 1e9f, 0, l.text.c_str());
    outlined_text(list, size, ImVec2(at.x - extent.x / 2, at.y - extent.y - size * 0.3f),
                  imgui_color(l.rgb), l.text);
  }
}

// Who is there: each remote participant in its colour, "speaking" or "pointing" as it does.
void draw_legend(ImDrawList* list, const SessionSnapshot& s, size_t camera, float size,
                 int64_t now_us) {
  const float line = size * 1.25f;
  std::vector<std::pair<std::string, ImU32>> rows;
  rows.emplace_back(fmt::format("{} - OR camera {}", s.session_name, camera),
                    IM_COL32(230, 230, 230, 255));
  for (const RemoteParticipant& o : s.others) {
    if (o.role != session::Role::kRemote) continue;
    std::string row = o.name;
    if (o.last_voice_us != 0 && now_us - o.last_voice_us < 300'000) row += "  (speaking)";
    for (const PointerView& ptr : s.pointers)
      if (ptr.participant == o.id) row += "  (pointing)";
    rows.emplace_back(row, imgui_color(participant_color(o.id)));
  }
  if (rows.size() == 1) rows.emplace_back("no remote expert yet", IM_COL32(180, 180, 180, 255));
  float width = 0;
  for (const auto& r : rows)
    width = std::max(width, ImGui::GetFont()->CalcTextSizeA(size, 1e9f, 0, r.first.c_str()).x);
  const ImVec2 origin(size * 0.6f, size * 0.6f);
  list->AddRectFilled(
      origin,
      ImVec2(origin.x + width + size * 1.6f, origin.y + line * float(rows.size()) + size * 0.4f),
      IM_COL32(0, 0, 0, 150), size * 0.3f);
  for (size_t i = 0; i < rows.size(); ++i) {
    const ImVec2 at(origin.x + size * 0.3f, origin.y + size * 0.2f + line * float(i));
    if (i > 0)
      list->AddCircleFilled(ImVec2(at.x + size * 0.35f, at.y + size * 0.55f), size * 0.3f,
                            rows[i].second);
    list->AddText(ImGui::GetFont(), size, ImVec2(at.x + (i > 0 ? size : 0), at.y), rows[i].second,
                  rows[i].first.c_str());
  }
}

// A bigger font than Dear ImGui's 13 px bitmap one, for a wall across the room: DejaVu Sans Bold
// where Debian's fonts-dejavu-core has it, else the default.
void load_font() {
  const char* path = "/usr/share/fonts/truetype/dejavu/DejaVuSans-Bold.ttf";
  ImGuiIO& io = ImGui::GetIO();
  if (std::filesystem::exists(path) && io.Fonts->AddFontFromFileTTF(path, 48.0f)) return;
  io.Fonts->AddFontDefault();
}

void present_or_display(FrameFeed& feed, ViewerResult& result, const OrDisplayWindowOptions& o) {
  const std::vector<CameraCalibration>& site = feed.cameras();
  if (o.camera >= site.size())
    throw Error(
        fmt::format("OR display: the site has {} cameras, no camera {}", site.size(), o.camera));
  if (!o.participant) throw Error("OR display window: no participant to see the session through");
  Glfw glfw;
  Window window(o.width, o.height, o.title);
  std::array<int, 4> windowed{0, 0, o.width, o.height};
  if (o.fullscreen) set_fullscreen(window.window, true, windowed);
  Gui gui(window.window);
  load_font();
  DisplayKeys keys;
  glfwSetWindowUserPointer(window.window, &keys);
  glfwSetKeyCallback(window.window, on_display_key);
  const OrDisplaySize size = or_display_size(site[o.camera]);
  Picture picture(size.width, size.height);
  OrDisplay display;
  result.renderer = reinterpret_cast<const char*>(glGetString(GL_RENDERER));
  spdlog::info("OR display window of camera {} ({}x{} picture): {}", o.camera, size.width,
               size.height, result.renderer);
  std::vector<ScriptedKey> script = o.script;
  std::stable_sort(script.begin(), script.end(),
                   [](const ScriptedKey& a, const ScriptedKey& b) { return a.frame < b.frame; });
  size_t next_key = 0;
  std::vector<std::shared_ptr<const CameraFrame>> frames;
  uint64_t drawn = 0;
  bool shown = false;  // the picture holds the camera's image
  auto last_draw = std::chrono::steady_clock::now() - std::chrono::seconds(1);
  while (!feed.finished()) {
    glfwPollEvents();
    if (glfwWindowShouldClose(window.window)) break;
    const bool arrived = feed.next(frames, std::chrono::milliseconds(5));
    const auto now = std::chrono::steady_clock::now();
    if (!arrived && now - last_draw < std::chrono::milliseconds(33)) continue;
    last_draw = now;
    for (; next_key < script.size() && script[next_key].frame <= drawn + 1; ++next_key)
      handle_display_key(keys, script[next_key].key,
                         script[next_key].release ? GLFW_RELEASE : GLFW_PRESS);
    if (keys.toggle_fullscreen || keys.leave_fullscreen) {
      set_fullscreen(window.window,
                     keys.toggle_fullscreen && glfwGetWindowMonitor(window.window) == nullptr,
                     windowed);
      keys.toggle_fullscreen = keys.leave_fullscreen = false;
      glfwPollEvents();  // the new size
    }
    int width = 0, height = 0;
    glfwGetFramebufferSize(window.window, &width, &height);
    if (width <= 0 || height <= 0) continue;  // minimised
    Participant* participant = o.participant();
    const int64_t t = wall_clock_us();
    SessionSnapshot snapshot;
    if (participant) snapshot = participant->snapshot(t);
    if (participant && frames.size() > o.camera && frames[o.camera]) {
      display.draw(picture.target(), site[o.camera], *frames[o.camera], snapshot, t);
      shown = true;
    }
    glBindFramebuffer(GL_FRAMEBUFFER, 0);
    glViewport(0, 0, width, height);
    glDisable(GL_SCISSOR_TEST);
    glClearColor(0, 0, 0, 1);
    glClear(GL_COLOR_BUFFER_BIT | GL_DEPTH_BUFFER_BIT);
    ImGui_ImplOpenGL3_NewFrame();
    ImGui_ImplGlfw_NewFrame();
    ImGui::NewFrame();
    ImDrawList* list = ImGui::GetBackgroundDrawList();
    const float text = std::clamp(float(height) / 24, 16.0f, 64.0f);
    if (shown) {
      const int turns = upright_quarter_turns(display.room_camera().world_from_camera);
      const Placement p = place(size.width, size.height, turns, width, height);
      draw_picture(list, picture, p);
      draw_labels(list, display.labels(snapshot), p, text);
      if (keys.legend) draw_legend(list, snapshot, o.camera, text * 0.6f, t);
      draw_recording_badge(list, snapshot.recording, text * 0.6f, float(width));
    } else {
      outlined_text(
          list, text, ImVec2(text, text), IM_COL32(220, 220, 220, 255),
          participant ? fmt::format("waiting for OR camera {}", o.camera) : "joining the session");
    }
    ImGui::Render();
    ImGui_ImplOpenGL3_RenderDrawData(ImGui::GetDrawData());
    if (keys.screenshot) {
      keys.screenshot = false;
      const std::filesystem::path path = screenshot_path(o.screenshot);
      try {
        save_screenshot(width, height, path);
        spdlog::info("wrote screenshot {} ({}x{}, the OR display)", path.string(), width, height);
      } catch (const Error& e) {
        spdlog::warn("screenshot failed: {}", e.what());
      }
    }
    glfwSwapBuffers(window.window);
    if (shown) feed.presented();
    if (!shown) continue;
    ++drawn;
    ++result.frames_rendered;
    if (o.max_frames > 0 && drawn >= o.max_frames) break;
  }
  feed.close();  // the window closed (or the session ended, when this changes nothing)
}

}  // namespace

Presenter or_display_window_presenter(const OrDisplayWindowOptions& options) {
  return [options](FrameFeed& feed, ViewerResult& result) {
    present_or_display(feed, result, options);
  };
}

}  // namespace volcast
