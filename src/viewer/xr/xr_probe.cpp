// xr_available(): can OpenXR run here?
#include <string>

#include "volcast/viewer/xr.hpp"
#include "xr_common.hpp"

namespace volcast {

bool xr_available(std::string* why) {
  const auto fail = [&](const std::string& reason) {
    if (why) *why = reason;
    return false;
  };
  try {
    XrInstance instance = XR_NULL_HANDLE;
    const XrResult created = create_gl_instance(&instance);
    if (created == XR_ERROR_EXTENSION_NOT_PRESENT)
      return fail("the runtime has no OpenGL support (XR_KHR_opengl_enable)");
    if (XR_FAILED(created))
      return fail(std::string("no runtime available (") + xr_result_name(created) + ")");
    auto system = xr_struct<XrSystemGetInfo>(XR_TYPE_SYSTEM_GET_INFO);
    system.formFactor = XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY;
    XrSystemId id = XR_NULL_SYSTEM_ID;
    const XrResult found = xrGetSystem(instance, &system, &id);
    xrDestroyInstance(instance);
    if (XR_FAILED(found)) return fail(std::string("no headset (") + xr_result_name(found) + ")");
    return true;
  } catch (const std::exception& e) {  // the loader is C++ and may throw
    return fail(std::string("the OpenXR loader failed: ") + e.what());
  } catch (...) {
    return fail("the OpenXR loader failed");
  }
}

}  // namespace volcast
