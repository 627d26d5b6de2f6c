#include <epoxy/egl.h>

#include <map>
#include <mutex>
#include <string>

#include "volcast/core/error.hpp"
#include "volcast/render/headless_target.hpp"

namespace volcast {
namespace {

bool has_extension(EGLDisplay dpy, const char* name) {
  const char* exts = eglQueryString(dpy, EGL_EXTENSIONS);
  return exts && std::string(exts).find(name) != std::string::npos;
}

// Tries a GPU device first (NVIDIA and Mesa export EGL devices), then Mesa's surfaceless platform,
// then the default display.
EGLDisplay open_display() {
  if (has_extension(EGL_NO_DISPLAY, "EGL_EXT_platform_device") &&
      has_extension(EGL_NO_DISPLAY, "EGL_EXT_device_enumeration")) {
    EGLDeviceEXT devices[8];
    EGLint count = 0;
    if (eglQueryDevicesEXT(8, devices, &count)) {
      for (EGLint i = 0; i < count; ++i) {
        const char* dev_exts = eglQueryDeviceStringEXT(devices[i], EGL_EXTENSIONS);
        // Skip Mesa's software device here; surfaceless below picks llvmpipe anyway.
        if (dev_exts && std::string(dev_exts).find("EGL_MESA_device_software") != std::string::npos)
          continue;
        EGLDisplay dpy = eglGetPlatformDisplayEXT(EGL_PLATFORM_DEVICE_EXT, devices[i], nullptr);
        if (dpy != EGL_NO_DISPLAY && eglInitialize(dpy, nullptr, nullptr)) return dpy;
      }
    }
  }
  if (has_extension(EGL_NO_DISPLAY, "EGL_MESA_platform_surfaceless")) {
    EGLDisplay dpy =
        eglGetPlatformDisplayEXT(EGL_PLATFORM_SURFACELESS_MESA, EGL_DEFAULT_DISPLAY, nullptr);
    if (dpy != EGL_NO_DISPLAY && eglInitialize(dpy, nullptr, nullptr)) return dpy;
  }
  EGLDisplay dpy = eglGetDisplay(EGL_DEFAULT_DISPLAY);
  if (dpy != EGL_NO_DISPLAY && eglInitialize(dpy, nullptr, nullptr)) return dpy;
  throw Error("EGL: no display could be initialised (is libegl-mesa0 / a GPU driver installed?)");
}

// Creates an OpenGL 4.5 core context without a surface and makes it current.
EGLContext create_context(EGLDisplay display) {
  if (!eglBindAPI(EGL_OPENGL_API)) throw Error("EGL: desktop OpenGL API unavailable");
  const EGLint config_attribs[] = {EGL_SURFACE_TYPE,
                                   0,
                                   EGL_RENDERABLE_TYPE,
                                   EGL_OPENGL_BIT,
                                   EGL_RED_SIZE,
                                   8,
                                   EGL_GREEN_SIZE,
                                   8,
                                   EGL_BLUE_SIZE,
                                   8,
                                   EGL_NONE};
  EGLConfig config;
  EGLint n = 0;
  if (!eglChooseConfig(display, config_attribs, &config, 1, &n) || n == 0)
    throw Error("EGL: no OpenGL-capable config");
  const EGLint context_attribs[] = {EGL_CONTEXT_MAJOR_VERSION,
                                    4,
                                    EGL_CONTEXT_MINOR_VERSION,
                                    5,
                                    EGL_CONTEXT_OPENGL_PROFILE_MASK,
                                    EGL_CONTEXT_OPENGL_CORE_PROFILE_BIT,
                                    EGL_NONE};
  EGLContext context = eglCreateContext(display, config, EGL_NO_CONTEXT, context_attribs);
  if (context == EGL_NO_CONTEXT) throw Error("EGL: cannot create an OpenGL 4.5 core context");
  if (!eglMakeCurrent(display, EGL_NO_SURFACE, EGL_NO_SURFACE, context)) {
    eglDestroyContext(display, context);
    throw Error("EGL: cannot make the context current without a surface");
  }
  return context;
}

// EGL hands every context of a platform and device the same EGLDisplay, and eglTerminate ends it
// for all of them: another thread's context can then no longer be queried (libepoxy aborts on its
// next new GL call, "Couldn't find current GLX or EGL context": the demo's participants, ending
// on a loaded machine). So each display counts the contexts made on it and is terminated with the
// last; opening and counting, and uncounting and terminating, happen under one lock.
std::mutex displays_mutex;
std::map<EGLDisplay, int> display_users;  // under displays_mutex

EGLDisplay open_counted_display() {
  std::lock_guard lock(displays_mutex);
  const EGLDisplay display = open_display();
  ++display_users[display];
  return display;
}

void release_display(EGLDisplay display) {
  std::lock_guard lock(displays_mutex);
  if (--display_users[display] > 0) return;
  display_users.erase(display);
  eglTerminate(display);
}

}  // namespace

struct EglContext::Impl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
};

EglContext::EglContext() : impl_(std::make_unique<Impl>()) {
  impl_->display = open_counted_display();
  try {
    impl_->context = create_context(impl_->display);
  } catch (...) {
    release_display(impl_->display);
    throw;
  }
}

EglContext::~EglContext() {
  if (eglGetCurrentContext() == impl_->context)
    eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  eglDestroyContext(impl_->display, impl_->context);
  release_display(impl_->display);
}

void EglContext::make_current() const {
  if (!eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, impl_->context))
    throw Error("EGL: cannot make the context current on this thread (current on another one?)");
}

}  // namespace volcast
