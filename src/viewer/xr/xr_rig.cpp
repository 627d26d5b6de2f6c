// The OpenXR presenter's objects (xr_rig.hpp): the hidden window, the instance, session, space and
// eyes. Compiled on its own, not in the library's unity batch: it needs openxr_platform.h with
// the Xlib platform, which xr_rig.hpp includes without it.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <string>

#include "volcast/core/error.hpp"
#include "volcast/viewer/xr.hpp"
#include "xr_common.hpp"

// Platform headers last: Xlib's macros (None, Success, Status, ...) would break Eigen above.
#include <X11/Xlib.h>
#include <epoxy/gl.h>
#include <epoxy/glx.h>
#define GLFW_INCLUDE_NONE
#include <GLFW/glfw3.h>
#define GLFW_EXPOSE_NATIVE_X11
#define GLFW_EXPOSE_NATIVE_GLX
#include <GLFW/glfw3native.h>  // glfwGetX11Display, glfwGetGLXContext, glfwGetGLXWindow
#define XR_USE_PLATFORM_XLIB
#define XR_USE_GRAPHICS_API_OPENGL
#include <openxr/openxr_platform.h>

#include "xr_rig.hpp"

namespace volcast::xr {
namespace {

XrGraphicsBindingOpenGLXlibKHR glx_binding(GLFWwindow* window) {
  auto binding =
      xr_struct<XrGraphicsBindingOpenGLXlibKHR>(XR_TYPE_GRAPHICS_BINDING_OPENGL_XLIB_KHR);
  binding.xDisplay = glfwGetX11Display();
  binding.glxContext = glfwGetGLXContext(window);
  binding.glxDrawable = glfwGetGLXWindow(window);
  int id = 0;
  glXQueryContext(binding.xDisplay, binding.glxContext, GLX_FBCONFIG_ID, &id);
  const int attributes[] = {GLX_FBCONFIG_ID, id, None};
  int count = 0;
  GLXFBConfig* configs =
      glXChooseFBConfig(binding.xDisplay, DefaultScreen(binding.xDisplay), attributes, &count);
  if (configs && count > 0) {
    binding.glxFBConfig = configs[0];
    if (XVisualInfo* visual = glXGetVisualFromFBConfig(binding.xDisplay, configs[0])) {
      binding.visualid = static_cast<uint32_t>(visual->visualid);
      XFree(visual);
    }
  }
  if (configs) XFree(configs);
  return binding;
}

// GL_SRGB8_ALPHA8 where offered (our colors are sRGB-encoded already and GL_FRAMEBUFFER_SRGB stays
// off, so they are stored as they are and shown right), else GL_RGBA8, else the runtime's first.
int64_t pick_format(XrSession session) {
  uint32_t count = 0;
  xr_check(xrEnumerateSwapchainFormats(session, 0, &count, nullptr), "xrEnumerateSwapchainFormats");
  std::vector<int64_t> formats(count);
  xr_check(xrEnumerateSwapchainFormats(session, count, &count, formats.data()),
           "xrEnumerateSwapchainFormats");
  for (const int64_t wanted : {int64_t{GL_SRGB8_ALPHA8}, int64_t{GL_RGBA8}})
    if (std::find(formats.begin(), formats.end(), wanted) != formats.end()) return wanted;
  if (formats.empty()) throw Error("OpenXR: the runtime offers no swapchain format");
  return formats.front();
}

XrReferenceSpaceType pick_space(XrSession session) {
  uint32_t count = 0;
  xr_check(xrEnumerateReferenceSpaces(session, 0, &count, nullptr), "xrEnumerateReferenceSpaces");
  std::vector<XrReferenceSpaceType> spaces(count);
  xr_check(xrEnumerateReferenceSpaces(session, count, &count, spaces.data()),
           "xrEnumerateReferenceSpaces");
  return std::find(spaces.begin(), spaces.end(), XR_REFERENCE_SPACE_TYPE_STAGE) != spaces.end()
             ? XR_REFERENCE_SPACE_TYPE_STAGE
             : XR_REFERENCE_SPACE_TYPE_LOCAL;
}

void make_eye(XrSession session, const XrViewConfigurationView& config, int64_t format, Eye& eye) {
  eye.width = static_cast<int>(config.recommendedImageRectWidth);
  eye.height = static_cast<int>(config.recommendedImageRectHeight);
  auto info = xr_struct<XrSwapchainCreateInfo>(XR_TYPE_SWAPCHAIN_CREATE_INFO);
  info.usageFlags = XR_SWAPCHAIN_USAGE_COLOR_ATTACHMENT_BIT | XR_SWAPCHAIN_USAGE_SAMPLED_BIT;
  info.format = format;
  info.sampleCount = 1;
  info.width = config.recommendedImageRectWidth;
  info.height = config.recommendedImageRectHeight;
  info.faceCount = info.arraySize = info.mipCount = 1;
  xr_check(xrCreateSwapchain(session, &info, &eye.swapchain.handle), "xrCreateSwapchain");
  uint32_t count = 0;
  xr_check(xrEnumerateSwapchainImages(eye.swapchain.handle, 0, &count, nullptr),
           "xrEnumerateSwapchainImages");
  eye.images.assign(count,
                    xr_struct<XrSwapchainImageOpenGLKHR>(XR_TYPE_SWAPCHAIN_IMAGE_OPENGL_KHR));
  xr_check(
      xrEnumerateSwapchainImages(eye.swapchain.handle, count, &count,
                                 reinterpret_cast<XrSwapchainImageBaseHeader*>(eye.images.data())),
      "xrEnumerateSwapchainImages");
  glCreateRenderbuffers(1, &eye.depth);
  glNamedRenderbufferStorage(eye.depth, GL_DEPTH_COMPONENT24, eye.width, eye.height);
  glCreateFramebuffers(1, &eye.framebuffer);
  glNamedFramebufferRenderbuffer(eye.framebuffer, GL_DEPTH_ATTACHMENT, GL_RENDERBUFFER, eye.depth);
}

// The instance with XR_KHR_opengl_enable and its head-mounted display; checks the runtime's
// OpenGL requirements (which OpenXR requires asking for before xrCreateSession).
void open_instance(XrRig& rig) {
  xr_check(create_gl_instance(&rig.instance.handle), "xrCreateInstance");
  auto system_info = xr_struct<XrSystemGetInfo>(XR_TYPE_SYSTEM_GET_INFO);
  system_info.formFactor = XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY;
  xr_check(xrGetSystem(rig.instance.handle, &system_info, &rig.system), "xrGetSystem");
  PFN_xrGetOpenGLGraphicsRequirementsKHR requirements_of = nullptr;
  xr_check(xrGetInstanceProcAddr(rig.instance.handle, "xrGetOpenGLGraphicsRequirementsKHR",
                                 reinterpret_cast<PFN_xrVoidFunction*>(&requirements_of)),
           "xrGetInstanceProcAddr(xrGetOpenGLGraphicsRequirementsKHR)");
  auto requirements =
      xr_struct<XrGraphicsRequirementsOpenGLKHR>(XR_TYPE_GRAPHICS_REQUIREMENTS_OPENGL_KHR);
  xr_check(requirements_of(rig.instance.handle, rig.system, &requirements),
           "xrGetOpenGLGraphicsRequirementsKHR");  // required before xrCreateSession
  if (requirements.minApiVersionSupported > XR_MAKE_VERSION(4, 5, 0))
    throw Error("OpenXR: the runtime needs a newer OpenGL than 4.5");
}

// The session on `window`'s GLX context and its reference space.
void open_session(XrRig& rig, GLFWwindow* window, const XrOptions& o) {
  const XrGraphicsBindingOpenGLXlibKHR binding = glx_binding(window);
  auto session_info = xr_struct<XrSessionCreateInfo>(XR_TYPE_SESSION_CREATE_INFO);
  session_info.next = &binding;
  session_info.systemId = rig.system;
  xr_check(xrCreateSession(rig.instance.handle, &session_info, &rig.session.handle),
           "xrCreateSession");
  auto space_info = xr_struct<XrReferenceSpaceCreateInfo>(XR_TYPE_REFERENCE_SPACE_CREATE_INFO);
  space_info.referenceSpaceType = pick_space(rig.session.handle);
  space_info.poseInReferenceSpace.orientation.w = 1;
  xr_check(xrCreateReferenceSpace(rig.session.handle, &space_info, &rig.space.handle),
           "xrCreateReferenceSpace");
  rig.eye_height =
      space_info.referenceSpaceType == XR_REFERENCE_SPACE_TYPE_STAGE ? o.eye_height_m : 0;
}

// One eye per view of the stereo configuration, at the runtime's recommended size.
void make_eyes(XrRig& rig) {
  xr_check(xrEnumerateViewConfigurationViews(rig.instance.handle, rig.system, kStereo, 0,
                                             &rig.view_count, nullptr),
           "xrEnumerateViewConfigurationViews");
  std::vector<XrViewConfigurationView> configs(
      rig.view_count, xr_struct<XrViewConfigurationView>(XR_TYPE_VIEW_CONFIGURATION_VIEW));
  xr_check(xrEnumerateViewConfigurationViews(rig.instance.handle, rig.system, kStereo,
                                             rig.view_count, &rig.view_count, configs.data()),
           "xrEnumerateViewConfigurationViews");
  const int64_t format = pick_format(rig.session.handle);
  rig.eyes = std::vector<Eye>(rig.view_count);
  for (uint32_t i = 0; i < rig.view_count; ++i)
    make_eye(rig.session.handle, configs[i], format, rig.eyes[i]);
}

}  // namespace

HiddenContext::HiddenContext() {
  if (!glfwInit()) throw Error("OpenXR needs an X display for its OpenGL context (GLX)");
  glfwWindowHint(GLFW_VISIBLE, GLFW_FALSE);
  glfwWindowHint(GLFW_CONTEXT_CREATION_API, GLFW_NATIVE_CONTEXT_API);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MAJOR, 4);
  glfwWindowHint(GLFW_CONTEXT_VERSION_MINOR, 5);
  glfwWindowHint(GLFW_OPENGL_PROFILE, GLFW_OPENGL_CORE_PROFILE);
  window = glfwCreateWindow(64, 64, "volcast (OpenXR)", nullptr, nullptr);
  if (!window) {
    glfwTerminate();
    throw Error("OpenXR: cannot make an OpenGL 4.5 core context (GLX) for the session");
  }
  glfwMakeContextCurrent(window);
  glfwSwapInterval(0);  // the runtime paces frames (xrWaitFrame)
}

HiddenContext::~HiddenContext() {
  glfwDestroyWindow(window);
  glfwTerminate();
}

XrResult xr_check_live(XrResult result, const char* call) {
  if (result == XR_ERROR_INSTANCE_LOST || result == XR_ERROR_SESSION_LOST) throw Lost{};
  return xr_check(result, call);
}

Eye::~Eye() {
  glDeleteFramebuffers(1, &framebuffer);
  glDeleteRenderbuffers(1, &depth);
}

void open_rig(XrRig& rig, GLFWwindow* window, const XrOptions& o) {
  open_instance(rig);
  open_session(rig, window, o);
  make_eyes(rig);
}

void draw_eye(Eye& eye, const std::function<void(const RenderTarget&)>& draw) {
  uint32_t index = 0;
  xr_check_live(xrAcquireSwapchainImage(eye.swapchain.handle, nullptr, &index),
                "xrAcquireSwapchainImage");
  auto wait = xr_struct<XrSwapchainImageWaitInfo>(XR_TYPE_SWAPCHAIN_IMAGE_WAIT_INFO);
  wait.timeout = XR_INFINITE_DURATION;
  xr_check_live(xrWaitSwapchainImage(eye.swapchain.handle, &wait), "xrWaitSwapchainImage");
  glNamedFramebufferTexture(eye.framebuffer, GL_COLOR_ATTACHMENT0, eye.images[index].image, 0);
  draw(RenderTarget{eye.framebuffer, 0, 0, eye.width, eye.height});
  xr_check_live(xrReleaseSwapchainImage(eye.swapchain.handle, nullptr), "xrReleaseSwapchainImage");
}

bool poll_events(XrInstance instance, XrSession session, bool& running) {
  for (;;) {
    auto event = xr_struct<XrEventDataBuffer>(XR_TYPE_EVENT_DATA_BUFFER);
    if (xr_check_live(xrPollEvent(instance, &event), "xrPollEvent") == XR_EVENT_UNAVAILABLE)
      return true;
    if (event.type == XR_TYPE_EVENT_DATA_INSTANCE_LOSS_PENDING) return false;
    if (event.type == XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED) {
      const auto& changed = reinterpret_cast<const XrEventDataSessionStateChanged&>(event);
      switch (changed.state) {
        case XR_SESSION_STATE_READY: {
          auto begin = xr_struct<XrSessionBeginInfo>(XR_TYPE_SESSION_BEGIN_INFO);
          begin.primaryViewConfigurationType = XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO;
          xr_check_live(xrBeginSession(session, &begin), "xrBeginSession");
          running = true;
          spdlog::info("OpenXR: session running");
          break;
        }
        case XR_SESSION_STATE_STOPPING:
          xr_check_live(xrEndSession(session), "xrEndSession");
          running = false;
          break;
        case XR_SESSION_STATE_EXITING:
        case XR_SESSION_STATE_LOSS_PENDING:
          return false;
        default:
          break;
      }
    }
  }
}

}  // namespace volcast::xr
