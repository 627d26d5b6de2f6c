#include "glfw_window.hpp"

#include <epoxy/gl.h>  // before GLFW, which then includes no GL header of its own
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#include <backends/imgui_impl_glfw.h>
#include <backends/imgui_impl_opengl3.h>
#include <fmt/format.h>
#include <imgui.h>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

thread_local std::string t_glfw_error;  // the last GLFW error on this thread

void on_glfw_error(int code, const char* description) {
  t_glfw_error = description ? description : fmt::format("GLFW error 0x{:x}", code);
}

}  // namespace

Glfw::Glfw() {
  glfwSetErrorCallback(on_glfw_error);
  t_glfw_error.clear();
  if (!glfwInit()) throw Error(t_glfw_error.empty() ? "GLFW cannot start" : t_glfw_error);
}
Glfw::~Glfw() {
  glfwTerminate();
}

Window::Window(int width, int height, const std::string& title) {
  if (width < 1 || width > 8192 || height < 1 || height > 8192)
    throw Error(fmt::format("desktop window: size {}x{} is outside 1..8192", width, height));
  glfwWindowHint(GLFW_CLIENT_API, GLFW_OPENGL_API);
  glfwWindowHint(GLFW_CONTEXT_CREATION_API, GLFW_NATIVE_CONTEXT_API);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  glfwWindowHint(GLFW_DEPTH_BITS, 24);
  window = glfwCreateWindow(width, height, title.c_str(), nullptr, nullptr);
  if (!window)
    throw Error(fmt::format("cannot open a {}x{} window with an OpenGL 4.5 core context: {}", width,
                            height, t_glfw_error));
  glfwMakeContextCurrent(window);
  glfwSwapInterval(1);
}
Window::~Window() {
  glfwDestroyWindow(window);
}

Gui::Gui(GLFWwindow* window) {
  IMGUI_CHECKVERSION();
  ImGui::CreateContext();
  ImGui::GetIO().IniFilename = nullptr;  // no imgui.ini in the working directory
  ImGui::StyleColorsDark();
  if (!ImGui_ImplGlfw_InitForOpenGL(window, false) || !ImGui_ImplOpenGL3_Init("#version 450"))
    throw Error("Dear ImGui cannot start its GLFW / OpenGL 3 backend");
}
Gui::~Gui() {
  ImGui_ImplOpenGL3_Shutdown();
  ImGui_ImplGlfw_Shutdown();
  ImGui::DestroyContext();
}

}  // namespace volcast
