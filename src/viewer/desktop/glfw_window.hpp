#pragma once
// The desktop presenters' GLFW pieces (internal to volcast_viewer_desktop), shared by the desktop
// viewer (window.cpp) and the OR display's window (or_display_window.cpp): GLFW started, a window
// with an OpenGL 4.5 core context (GLX), and Dear ImGui over it.
#include <string>

struct GLFWwindow;

namespace volcast {

/// glfwInit() .. glfwTerminate(). Throws Error with GLFW's reason if it cannot start (no display).
struct Glfw {
  Glfw();
  ~Glfw();
  Glfw(const Glfw&) = delete;
  Glfw& operator=(const Glfw&) = delete;
};

/// A window of width x height screen coordinates (each 1..8192) titled `title`, with an OpenGL
/// 4.5 core context and a 24-bit depth buffer, current on this thread, vsync on. Throws Error
/// naming the size and GLFW's reason if it cannot be made.
struct Window {
  GLFWwindow* window = nullptr;
  Window(int width, int height, const std::string& title);
  ~Window();
  Window(const Window&) = delete;
  Window& operator=(const Window&) = delete;
};

/// Dear ImGui's context and its GLFW and OpenGL 3 backends (the window's callbacks forward to its
/// own; no imgui.ini is written). Throws Error if a backend cannot start.
struct Gui {
  explicit Gui(GLFWwindow* window);
  ~Gui();
  Gui(const Gui&) = delete;
  Gui& operator=(const Gui&) = delete;
};

}  // namespace volcast
