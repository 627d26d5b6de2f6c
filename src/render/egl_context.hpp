#pragma once
// Internal: a headless EGL context with OpenGL 4.5 core made current on the calling thread.
#include <epoxy/egl.h>

#include <string>

namespace volcast::detail {

struct EglContext {
  EGLDisplay display = EGL_NO_DISPLAY;
  EGLContext context = EGL_NO_CONTEXT;
  EglContext();  // throws Error
  ~EglContext();
  EglContext(const EglContext&) = delete;
  EglContext& operator=(const EglContext&) = delete;

 private:
  void create_context();
};

}  // namespace volcast::detail
