#include <epoxy/egl.h>

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

}  // namespace

struct EglContext::Impl {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
};

EglContext::EglContext() : impl_(std::make_unique<Impl>()) {
  impl_->display = open_display();
  try {
    impl_->context = create_context(impl_->display);
  } catch (...) {
    eglTerminate(impl_->display);
    throw;
  }
}

EglContext::~EglContext() {
  if (eglGetCurrentContext() == impl_->context)
    eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, EGL_NO_CONTEXT);
  eglDestroyContext(impl_->display, impl_->context);
  eglTerminate(impl_->display);
}

void EglContext::make_current() const {
  if (!eglMakeCurrent(impl_->display, EGL_NO_SURFACE, EGL_NO_SURFACE, impl_->context))
    throw Error("EGL: cannot make the context current on this thread (current on another one?)");
}

}  // namespace volcast
