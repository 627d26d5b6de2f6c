#include "xr_common.hpp"

#include <openxr/openxr_reflection.h>

#include <algorithm>
#include <cstdlib>
#include <cstring>
#include <string>
#include <vector>

#include "volcast/core/error.hpp"

namespace volcast {

const char* xr_result_name(XrResult result) {
  switch (result) {
#define VOLCAST_XR_RESULT_CASE(name, value) \
  case name:                                \
    return #name;
    XR_LIST_ENUM_XrResult(VOLCAST_XR_RESULT_CASE)
#undef VOLCAST_XR_RESULT_CASE
        default : return "XrResult(unknown)";
  }
}

XrResult xr_check(XrResult result, const char* call) {
  if (XR_FAILED(result))
    throw Error(std::string("OpenXR: ") + call + " failed: " + xr_result_name(result));
  return result;
}

// The loader logs its failures to stderr (several lines for a missing runtime); we report the
// result in one line instead. It reads XR_LOADER_DEBUG at its first call. Set here, while the
// program's static objects are made and before main() starts a thread: setenv may move the
// environment while another thread's getenv reads it (libturbojpeg calls getenv on every encode
// and decode; a headset's first frame crashed a server's encoder thread that way).
[[maybe_unused]] const bool kQuietLoader = [] {
  return setenv("XR_LOADER_DEBUG", "none", 0) == 0;
}();

XrResult create_gl_instance(XrInstance* instance) {
  uint32_t count = 0;
  XrResult r = xrEnumerateInstanceExtensionProperties(nullptr, 0, &count, nullptr);
  if (XR_FAILED(r)) return r;
  std::vector<XrExtensionProperties> extensions(
      count, xr_struct<XrExtensionProperties>(XR_TYPE_EXTENSION_PROPERTIES));
  r = xrEnumerateInstanceExtensionProperties(nullptr, count, &count, extensions.data());
  if (XR_FAILED(r)) return r;
  const char* gl = "XR_KHR_opengl_enable";
  if (std::none_of(
          extensions.begin(), extensions.begin() + count,
          [&](const XrExtensionProperties& e) { return std::strcmp(e.extensionName, gl) == 0; }))
    return XR_ERROR_EXTENSION_NOT_PRESENT;
  auto info = xr_struct<XrInstanceCreateInfo>(XR_TYPE_INSTANCE_CREATE_INFO);
  std::strncpy(info.applicationInfo.applicationName, "volcast", XR_MAX_APPLICATION_NAME_SIZE - 1);
  std::strncpy(info.applicationInfo.engineName, "volcast", XR_MAX_ENGINE_NAME_SIZE - 1);
  info.applicationInfo.apiVersion = XR_CURRENT_API_VERSION;
  info.enabledExtensionCount = 1;
  info.enabledExtensionNames = &gl;
  return xrCreateInstance(&info, instance);
}

}  // namespace volcast
