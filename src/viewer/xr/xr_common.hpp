#pragma once
// OpenXR results as names, checking them, and the instance every use starts from (internal to
// volcast_viewer_xr).
#include <openxr/openxr.h>

namespace volcast {

/// "XR_ERROR_RUNTIME_UNAVAILABLE" etc.; "XrResult(unknown)" for a value this header does not know.
const char* xr_result_name(XrResult result);

/// Throws Error("OpenXR: <call> failed: <name>") unless XR_SUCCEEDED(result); returns result.
XrResult xr_check(XrResult result, const char* call);

/// A zeroed OpenXR struct of type `type` (next = null).
template <typename T>
T xr_struct(XrStructureType type) {
  T value{};
  value.type = type;
  return value;
}

/// Creates an instance named "volcast" with XR_KHR_opengl_enable into `instance`. Returns the
/// loader's or runtime's result: XR_ERROR_EXTENSION_NOT_PRESENT when the runtime lacks OpenGL.
/// Silences the loader's own stderr messages unless XR_LOADER_DEBUG is set.
XrResult create_gl_instance(XrInstance* instance);

}  // namespace volcast
