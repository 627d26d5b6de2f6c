#pragma once
// The OpenXR presenter's objects (internal to volcast_viewer_xr; made in xr_rig.cpp, used by the
// frame loop in xr_session.cpp): the hidden GLFW window whose GLX context the session renders
// with, OpenXR handles destroyed with their functions, one eye per view with its swapchain and
// FBO, and the rig made of them.
#include <epoxy/gl.h>
#include <functional>
#include <vector>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#ifndef XR_USE_GRAPHICS_API_OPENGL
#define XR_USE_GRAPHICS_API_OPENGL
#endif
#include <openxr/openxr.h>
#include <openxr/openxr_platform.h>

#include "volcast/render/render_target.hpp"
#include "volcast/viewer/xr.hpp"

namespace volcast::xr {

/// glfwInit() .. glfwTerminate() and a hidden window whose OpenGL 4.5 core context (GLX) is
/// current on this thread: the context the session renders with. Throws Error without an X
/// display or that context.
struct HiddenContext {
  GLFWwindow* window = nullptr;
  HiddenContext();
  ~HiddenContext();
  HiddenContext(const HiddenContext&) = delete;
  HiddenContext& operator=(const HiddenContext&) = delete;
};

// An OpenXR handle destroyed with its function.
template <typename Handle, XrResult (*destroy)(Handle)>
struct XrHandle {
  Handle handle = XR_NULL_HANDLE;
  XrHandle() = default;
  ~XrHandle() {
    if (handle != XR_NULL_HANDLE) destroy(handle);
  }
  XrHandle(const XrHandle&) = delete;
  XrHandle& operator=(const XrHandle&) = delete;
};
using Instance = XrHandle<XrInstance, xrDestroyInstance>;
using Session = XrHandle<XrSession, xrDestroySession>;
using Space = XrHandle<XrSpace, xrDestroySpace>;
using Swapchain = XrHandle<XrSwapchain, xrDestroySwapchain>;

// The runtime lost the instance or the session (XR_ERROR_INSTANCE_LOST, XR_ERROR_SESSION_LOST, with
// or without a loss pending event before): the viewer's session ends as closed, not on an error.
struct Lost {};

/// xr_check for the calls of a running session: throws Lost for a lost instance or session.
XrResult xr_check_live(XrResult result, const char* call);

// One eye: its swapchain, the swapchain's images, and an FBO with a depth renderbuffer that each
// acquired image is attached to.
struct Eye {
  Swapchain swapchain;
  std::vector<XrSwapchainImageOpenGLKHR> images;
  int width = 0, height = 0;
  GLuint framebuffer = 0, depth = 0;
  ~Eye();
};

// The OpenXR objects of the presenter, made in this order (open_instance, open_session,
// make_eyes) and destroyed in reverse: the instance and its head-mounted system, the session bound
// to the hidden window's GLX context, its reference space (STAGE where offered, else LOCAL) and
// one Eye per view of the stereo configuration.
struct XrRig {
  Instance instance;
  XrSystemId system = XR_NULL_SYSTEM_ID;
  Session session;
  Space space;
  float eye_height = 0;  // STAGE: XrOptions::eye_height_m (its floor is at 0); LOCAL: 0
  uint32_t view_count = 0;
  std::vector<Eye> eyes;
};

inline constexpr auto kStereo = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;

/// Makes `rig` in order: the instance with XR_KHR_opengl_enable and its head-mounted display (the
/// runtime's OpenGL requirements checked), the session on `window`'s GLX context and its reference
/// space, one eye per view of the stereo configuration at the runtime's recommended size. Throws
/// Error naming the OpenXR call that failed.
void open_rig(XrRig& rig, GLFWwindow* window, const XrOptions& o);

/// Draws into the eye's next swapchain image (acquire, wait, `draw` on its FBO, release).
void draw_eye(Eye& eye, const std::function<void(const RenderTarget&)>& draw);

/// Handles the pending events (begins the session when READY, ends it when STOPPING, setting
/// `running`); false once the viewer should end (exiting, loss pending). A lost instance throws
/// Lost.
bool poll_events(XrInstance instance, XrSession session, bool& running);

}  // namespace volcast::xr
