// A mock OpenXR runtime for tests (loaded by the OpenXR loader through a runtime manifest named by
// XR_RUNTIME_JSON): one head-mounted display with two views (primary stereo, 256x256 per eye),
// swapchains of two real OpenGL RGBA8 textures made in the application's current context, STAGE
// and LOCAL spaces, a head 1.6 m above the stage floor with eyes 64 mm apart and a symmetric 90
// degree field of view, and frames paced at about 90 Hz. It implements exactly the calls the
// OpenXR presenter (src/viewer/xr) makes, validating handles, structure types and call order
// (XR_ERROR_VALIDATION_FAILURE etc. on misuse, each logged).
//
// The session: READY after xrCreateSession; SYNCHRONIZED, VISIBLE, FOCUSED after xrBeginSession;
// once VOLCAST_MOCK_XR_FRAMES (default 5) frames were ended with a valid projection layer whose eye
// images show something (not one flat colour), and the file VOLCAST_MOCK_XR_UNTIL names exists
// where that is set -- or 6000 frames were ended without that -- it asks
// to exit: VISIBLE, SYNCHRONIZED, STOPPING, and after xrEndSession IDLE, EXITING. Where
// VOLCAST_MOCK_XR_FROM names a file, the frames counted for that, and the xrSyncActions calls the
// scripted controllers count (below), start once it exists: a test writes it when what the script
// acts on is there (the session joined, the case arrived), so that a loaded machine only delays
// the script, never runs it before its time. On that last
// frame it reads back each eye's submitted image into eye0.ppm and eye1.ppm (binary PPM) in the
// folder VOLCAST_MOCK_XR_OUT names, and it writes log.json there (frame counts, errors) whenever a
// session or instance is destroyed. With VOLCAST_MOCK_XR_END=lost it loses the instance instead of
// asking to exit: every later call but a destroy returns XR_ERROR_INSTANCE_LOST.
//
// Controllers: the runtime is a pair of Oculus Touch controllers (or, if only those bindings are
// suggested, KHR simple controllers). Actions, action sets, suggested bindings, attaching, action
// spaces, xrSyncActions, float / boolean / pose action states and xrLocateSpace are implemented.
// The grips: left at VOLCAST_MOCK_XR_LEFT_GRIP ("x,y,z", default (-0.2, 1.1, -0.3)), right at
// VOLCAST_MOCK_XR_RIGHT_GRIP (default (0.2, 1.1, -0.3)), stage frame, metres, level.
// VOLCAST_MOCK_XR_SQUEEZE ("first,last", counted in xrSyncActions calls) squeezes the right grip
// fully for those syncs, turning the right hand about +y by 0.03 rad per sync while it squeezes (it
// stays turned after). VOLCAST_MOCK_XR_BUTTONS ("input:first,last;..." with input a left-hand
// component such as x/click, or a right-hand one prefixed right/, such as right/a/click) holds each
// of those buttons down for those syncs (a float input held reads 1). Every action space of a hand
// (grip, aim) is located at that hand's grip.
#include <openxr/openxr.h>

#include <epoxy/gl.h>
#include <epoxy/glx.h>
#define XR_USE_PLATFORM_XLIB
#define XR_USE_GRAPHICS_API_OPENGL
#include <openxr/openxr_platform.h>

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <fstream>
#include <map>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

// The loader's runtime interface (openxr/loader_interfaces.h, which Debian's libopenxr-dev does
// not ship): stable since OpenXR 1.0.
extern "C" {
enum XrLoaderInterfaceStructs {
  XR_LOADER_INTERFACE_STRUCT_UNINTIALIZED = 0,
  XR_LOADER_INTERFACE_STRUCT_LOADER_INFO,
  XR_LOADER_INTERFACE_STRUCT_API_LAYER_REQUEST,
  XR_LOADER_INTERFACE_STRUCT_RUNTIME_REQUEST,
  XR_LOADER_INTERFACE_STRUCT_API_LAYER_CREATE_INFO,
  XR_LOADER_INTERFACE_STRUCT_API_LAYER_NEXT_INFO,
};
struct XrNegotiateLoaderInfo {
  XrLoaderInterfaceStructs structType;
  uint32_t structVersion;
  size_t structSize;
  uint32_t minInterfaceVersion;
  uint32_t maxInterfaceVersion;
  XrVersion minApiVersion;
  XrVersion maxApiVersion;
};
struct XrNegotiateRuntimeRequest {
  XrLoaderInterfaceStructs structType;
  uint32_t structVersion;
  size_t structSize;
  uint32_t runtimeInterfaceVersion;
  XrVersion runtimeApiVersion;
  PFN_xrGetInstanceProcAddr getInstanceProcAddr;
};
__attribute__((visibility("default"))) XrResult XRAPI_CALL xrNegotiateLoaderRuntimeInterface(
    const XrNegotiateLoaderInfo* loaderInfo, XrNegotiateRuntimeRequest* runtimeRequest);
}

namespace {

constexpr uint32_t kEyeSize = 256, kMaxEyeSize = 1024, kImages = 2;
constexpr XrSystemId kSystem = 1;
// The display's frame period: VOLCAST_MOCK_XR_PERIOD_US, else 90 Hz.
int64_t frame_period_ns() {
  const char* v = std::getenv("VOLCAST_MOCK_XR_PERIOD_US");
  const long us = v ? std::strtol(v, nullptr, 10) : 0;
  return us > 0 ? int64_t(us) * 1000 : 11'111'111;
}
constexpr uint64_t kMaxFrames = 6000;     // exit even if no frame shows anything
constexpr float kHalfFov = 0.785398163f;  // 45 degrees
constexpr float kHeadHeight = 1.6f, kEyeDistance = 0.064f;

template <typename Handle>
Handle make_handle(uint64_t value) {
  return reinterpret_cast<Handle>(static_cast<uintptr_t>(value));
}
template <typename Handle>
uint64_t handle_value(Handle handle) {
  return static_cast<uint64_t>(reinterpret_cast<uintptr_t>(handle));
}

struct SwapchainState {
  std::array<GLuint, kImages> textures{};
  uint32_t width = 0, height = 0;
  uint32_t array_size = 1;
  std::deque<uint32_t> acquired;  // acquired, oldest first
  bool waited = false;            // the oldest acquired image was waited for
  uint32_t next = 0;              // the image the next acquire returns
  int last_released = -1;
};

enum class FramePhase { kIdle, kWaited, kBegun };

struct Runtime {
  std::mutex mutex;
  uint64_t next_handle = 0x1000;
  std::map<uint64_t, bool> instances;  // handle -> graphics requirements asked for
  uint64_t session = 0, session_instance = 0;
  XrSessionState state = XR_SESSION_STATE_UNKNOWN;
  std::map<uint64_t, XrReferenceSpaceType> spaces;
  std::map<uint64_t, SwapchainState> swapchains;
  std::deque<XrSessionState> events;
  FramePhase phase = FramePhase::kIdle;
  std::chrono::steady_clock::time_point start = std::chrono::steady_clock::now();
  int64_t last_predicted = 0;
  std::chrono::steady_clock::time_point next_frame = start;
  bool exit_requested = false, lost = false;
  // What log.json reports.
  uint64_t frames_waited = 0, frames_ended = 0, frames_with_layer = 0, frames_with_content = 0;
  uint64_t sessions = 0, sessions_ended = 0;
  bool images_written = false, destroyed_running = false;
  std::string log_dir;  // the VOLCAST_MOCK_XR_OUT these figures are for
  std::vector<std::string> errors;
  std::array<XrView, 2> located{};
  bool have_located = false;
  // Actions.
  std::map<std::string, XrPath> paths;   // interned path strings
  std::map<uint64_t, bool> action_sets;  // handle -> attached
  struct Action {
    XrActionType type;
    std::vector<XrPath> subactions;
    std::vector<std::string> inputs;  // bound input paths, for the chosen profile
  };
  std::map<uint64_t, Action> actions;
  std::string profile;  // the interaction profile whose bindings are used
  std::map<uint64_t, std::pair<uint64_t, XrPath>> action_spaces;  // space -> (action, subaction)
  uint64_t syncs = 0;           // xrSyncActions calls since VOLCAST_MOCK_XR_FROM's file came
  uint64_t frames_counted = 0;  // frames with content since then (the end's count)
  bool from_seen = false;       // that file exists (latched)

  XrResult fail(XrResult result, const std::string& what) {
    if (errors.size() < 200) errors.push_back(what);
    std::fprintf(stderr, "mock OpenXR runtime: %s\n", what.c_str());
    return result;
  }
  void write_log();
};

Runtime& rt() {
  static Runtime runtime;
  return runtime;
}

const char* out_dir() {
  const char* dir = std::getenv("VOLCAST_MOCK_XR_OUT");
  return dir && *dir ? dir : nullptr;
}

std::string json_string(const std::string& s) {
  std::string out = "\"";
  for (const char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    if (static_cast<unsigned char>(c) < 0x20) continue;
    out += c;
  }
  return out + "\"";
}

void Runtime::write_log() {
  const char* dir = out_dir();
  if (!dir) return;
  std::ofstream log(std::string(dir) + "/log.json", std::ios::trunc);
  log << "{\n  \"sessions\": " << sessions << ",\n  \"sessions_ended\": " << sessions_ended
      << ",\n  \"frames_waited\": " << frames_waited << ",\n  \"frames_ended\": " << frames_ended
      << ",\n  \"frames_with_layer\": " << frames_with_layer
      << ",\n  \"frames_with_content\": " << frames_with_content
      << ",\n  \"exit_requested\": " << (exit_requested ? "true" : "false")
      << ",\n  \"lost\": " << (lost ? "true" : "false")
      << ",\n  \"images_written\": " << (images_written ? "true" : "false")
      << ",\n  \"session_destroyed_running\": " << (destroyed_running ? "true" : "false")
      << ",\n  \"errors\": [";
  for (size_t i = 0; i < errors.size(); ++i) log << (i ? ", " : "") << json_string(errors[i]);
  log << "]\n}\n";
}

uint32_t frames_wanted() {
  const char* v = std::getenv("VOLCAST_MOCK_XR_FRAMES");
  const long n = v ? std::strtol(v, nullptr, 10) : 0;
  return n > 0 ? static_cast<uint32_t>(n) : 5;
}

// Whether the file VOLCAST_MOCK_XR_FROM names exists (true where it is not set); once true,
// always true.
bool from_met() {
  if (!rt().from_seen) {
    const char* v = std::getenv("VOLCAST_MOCK_XR_FROM");
    rt().from_seen = !v || std::ifstream(v).good();
  }
  return rt().from_seen;
}

// Whether the file VOLCAST_MOCK_XR_UNTIL names exists (true where it is not set).
bool until_met() {
  const char* v = std::getenv("VOLCAST_MOCK_XR_UNTIL");
  return !v || std::ifstream(v).good();
}

// Enumerates `values` by the two-call idiom.
template <typename T>
XrResult enumerate(const std::vector<T>& values, uint32_t capacity, uint32_t* count, T* out) {
  if (!count) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "null count output");
  *count = static_cast<uint32_t>(values.size());
  if (capacity == 0) return XR_SUCCESS;
  if (capacity < values.size()) return XR_ERROR_SIZE_INSUFFICIENT;
  if (!out) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "null array output");
  std::copy(values.begin(), values.end(), out);
  return XR_SUCCESS;
}

#define LOCK std::lock_guard<std::mutex> lock(rt().mutex)

bool valid_instance(XrInstance instance) {
  return rt().instances.count(handle_value(instance));
}
bool valid_session(XrSession session) {
  return rt().session != 0 && handle_value(session) == rt().session;
}

// After the instance was lost (VOLCAST_MOCK_XR_END=lost), every call but a destroy returns
// XR_ERROR_INSTANCE_LOST.
XrResult check_instance(XrInstance instance, const char* call, bool destroy = false) {
  if (rt().lost && !destroy) return XR_ERROR_INSTANCE_LOST;
  if (!valid_instance(instance))
    return rt().fail(XR_ERROR_HANDLE_INVALID, std::string(call) + ": invalid instance");
  return XR_SUCCESS;
}
XrResult check_session(XrSession session, const char* call, bool destroy = false) {
  if (rt().lost && !destroy) return XR_ERROR_INSTANCE_LOST;
  if (!valid_session(session))
    return rt().fail(XR_ERROR_HANDLE_INVALID, std::string(call) + ": invalid session");
  return XR_SUCCESS;
}
XrResult check_type(const void* s, XrStructureType type, const char* call, const char* what) {
  if (!s) return rt().fail(XR_ERROR_VALIDATION_FAILURE, std::string(call) + ": null " + what);
  if (*static_cast<const XrStructureType*>(s) != type)
    return rt().fail(XR_ERROR_VALIDATION_FAILURE, std::string(call) + ": wrong type of " + what);
  return XR_SUCCESS;
}
#define CHECK(expr)                              \
  do {                                           \
    const XrResult checked_ = (expr);            \
    if (checked_ != XR_SUCCESS) return checked_; \
  } while (false)

void queue_state(XrSessionState state) {
  rt().events.push_back(state);
}

// --- Instance ------------------------------------------------------------------------------------

XrResult XRAPI_CALL EnumerateApiLayerProperties(uint32_t, uint32_t* count, XrApiLayerProperties*) {
  if (count) *count = 0;
  return XR_SUCCESS;
}

XrResult XRAPI_CALL EnumerateInstanceExtensionProperties(const char* layer, uint32_t capacity,
                                                         uint32_t* count,
                                                         XrExtensionProperties* out) {
  LOCK;
  if (layer && *layer) return XR_ERROR_API_LAYER_NOT_PRESENT;
  XrExtensionProperties gl{};
  gl.type = XR_TYPE_EXTENSION_PROPERTIES;
  std::strcpy(gl.extensionName, XR_KHR_OPENGL_ENABLE_EXTENSION_NAME);
  gl.extensionVersion = XR_KHR_opengl_enable_SPEC_VERSION;
  if (!count) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "null count output");
  *count = 1;
  if (capacity == 0) return XR_SUCCESS;
  if (!out) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "null properties output");
  CHECK(check_type(&out[0], XR_TYPE_EXTENSION_PROPERTIES, "xrEnumerateInstanceExtensionProperties",
                   "properties"));
  void* next = out[0].next;
  out[0] = gl;
  out[0].next = next;
  return XR_SUCCESS;
}

XrResult XRAPI_CALL CreateInstance(const XrInstanceCreateInfo* info, XrInstance* instance) {
  LOCK;
  CHECK(check_type(info, XR_TYPE_INSTANCE_CREATE_INFO, "xrCreateInstance", "create info"));
  if (!instance) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "xrCreateInstance: null output");
  if (info->enabledApiLayerCount > 0) return XR_ERROR_API_LAYER_NOT_PRESENT;
  for (uint32_t i = 0; i < info->enabledExtensionCount; ++i)
    if (std::strcmp(info->enabledExtensionNames[i], XR_KHR_OPENGL_ENABLE_EXTENSION_NAME) != 0)
      return XR_ERROR_EXTENSION_NOT_PRESENT;
  if (XR_VERSION_MAJOR(info->applicationInfo.apiVersion) != 1)
    return rt().fail(XR_ERROR_API_VERSION_UNSUPPORTED, "xrCreateInstance: API version not 1.x");
  // A new output folder (the next test in this process): new figures.
  const char* dir = out_dir();
  if (std::string(dir ? dir : "") != rt().log_dir) {
    rt().log_dir = dir ? dir : "";
    rt().sessions = rt().sessions_ended = 0;
    rt().errors.clear();
  }
  const uint64_t handle = rt().next_handle++;
  rt().instances[handle] = false;
  *instance = make_handle<XrInstance>(handle);
  return XR_SUCCESS;
}

XrResult XRAPI_CALL DestroyInstance(XrInstance instance) {
  LOCK;
  CHECK(check_instance(instance, "xrDestroyInstance", true));
  if (rt().session != 0 && rt().session_instance == handle_value(instance))
    rt().fail(XR_SUCCESS, "xrDestroyInstance: its session was not destroyed");
  rt().instances.erase(handle_value(instance));
  rt().write_log();
  return XR_SUCCESS;
}

XrResult XRAPI_CALL GetSystem(XrInstance instance, const XrSystemGetInfo* info, XrSystemId* id) {
  LOCK;
  CHECK(check_instance(instance, "xrGetSystem"));
  CHECK(check_type(info, XR_TYPE_SYSTEM_GET_INFO, "xrGetSystem", "get info"));
  if (!id) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "xrGetSystem: null output");
  if (info->formFactor != XR_FORM_FACTOR_HEAD_MOUNTED_DISPLAY)
    return XR_ERROR_FORM_FACTOR_UNSUPPORTED;
  *id = kSystem;
  return XR_SUCCESS;
}

XrResult XRAPI_CALL GetOpenGLGraphicsRequirementsKHR(XrInstance instance, XrSystemId system,
                                                     XrGraphicsRequirementsOpenGLKHR* out) {
  LOCK;
  CHECK(check_instance(instance, "xrGetOpenGLGraphicsRequirementsKHR"));
  if (system != kSystem)
    return rt().fail(XR_ERROR_SYSTEM_INVALID, "xrGetOpenGLGraphicsRequirementsKHR: bad system");
  CHECK(check_type(out, XR_TYPE_GRAPHICS_REQUIREMENTS_OPENGL_KHR,
                   "xrGetOpenGLGraphicsRequirementsKHR", "requirements"));
  out->minApiVersionSupported = XR_MAKE_VERSION(4, 3, 0);
  out->maxApiVersionSupported = XR_MAKE_VERSION(4, 6, 0);
  rt().instances[handle_value(instance)] = true;
  return XR_SUCCESS;
}

XrResult XRAPI_CALL EnumerateViewConfigurationViews(XrInstance instance, XrSystemId system,
                                                    XrViewConfigurationType type, uint32_t capacity,
                                                    uint32_t* count, XrViewConfigurationView* out) {
  LOCK;
  CHECK(check_instance(instance, "xrEnumerateViewConfigurationViews"));
  if (system != kSystem)
    return rt().fail(XR_ERROR_SYSTEM_INVALID, "xrEnumerateViewConfigurationViews: bad system");
  if (type != XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO)
    return XR_ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED;
  if (!count) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "null count output");
  *count = 2;
  if (capacity == 0) return XR_SUCCESS;
  if (capacity < 2) return XR_ERROR_SIZE_INSUFFICIENT;
  for (uint32_t i = 0; i < 2; ++i) {
    CHECK(check_type(&out[i], XR_TYPE_VIEW_CONFIGURATION_VIEW, "xrEnumerateViewConfigurationViews",
                     "view"));
    out[i].recommendedImageRectWidth = out[i].recommendedImageRectHeight = kEyeSize;
    out[i].maxImageRectWidth = out[i].maxImageRectHeight = kMaxEyeSize;
    out[i].recommendedSwapchainSampleCount = out[i].maxSwapchainSampleCount = 1;
  }
  return XR_SUCCESS;
}

XrResult XRAPI_CALL PollEvent(XrInstance instance, XrEventDataBuffer* event) {
  LOCK;
  CHECK(check_instance(instance, "xrPollEvent"));
  CHECK(check_type(event, XR_TYPE_EVENT_DATA_BUFFER, "xrPollEvent", "event buffer"));
  if (rt().events.empty() || rt().session_instance != handle_value(instance))
    return XR_EVENT_UNAVAILABLE;
  auto* changed = reinterpret_cast<XrEventDataSessionStateChanged*>(event);
  *changed = XrEventDataSessionStateChanged{};
  changed->type = XR_TYPE_EVENT_DATA_SESSION_STATE_CHANGED;
  changed->session = make_handle<XrSession>(rt().session);
  changed->state = rt().events.front();
  changed->time = std::chrono::duration_cast<std::chrono::nanoseconds>(
                      std::chrono::steady_clock::now() - rt().start)
                      .count();
  rt().state = rt().events.front();
  rt().events.pop_front();
  return XR_SUCCESS;
}

// --- Session -------------------------------------------------------------------------------------

XrResult XRAPI_CALL CreateSession(XrInstance instance, const XrSessionCreateInfo* info,
                                  XrSession* session) {
  LOCK;
  CHECK(check_instance(instance, "xrCreateSession"));
  CHECK(check_type(info, XR_TYPE_SESSION_CREATE_INFO, "xrCreateSession", "create info"));
  if (!session) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "xrCreateSession: null output");
  if (info->systemId != kSystem)
    return rt().fail(XR_ERROR_SYSTEM_INVALID, "xrCreateSession: bad system");
  if (!rt().instances[handle_value(instance)])
    return rt().fail(XR_ERROR_GRAPHICS_REQUIREMENTS_CALL_MISSING,
                     "xrCreateSession before xrGetOpenGLGraphicsRequirementsKHR");
  if (rt().session != 0) return rt().fail(XR_ERROR_LIMIT_REACHED, "xrCreateSession: a second one");
  const auto* binding = static_cast<const XrGraphicsBindingOpenGLXlibKHR*>(info->next);
  if (!binding || binding->type != XR_TYPE_GRAPHICS_BINDING_OPENGL_XLIB_KHR)
    return rt().fail(XR_ERROR_GRAPHICS_DEVICE_INVALID, "xrCreateSession: no Xlib GL binding");
  if (!binding->xDisplay || !binding->glxContext || !binding->glxDrawable ||
      !binding->glxFBConfig || binding->visualid == 0)
    return rt().fail(XR_ERROR_GRAPHICS_DEVICE_INVALID,
                     "xrCreateSession: the GL binding misses a display, context, drawable, "
                     "FBConfig or visual");
  if (glXGetCurrentContext() != binding->glxContext)
    return rt().fail(XR_ERROR_GRAPHICS_DEVICE_INVALID,
                     "xrCreateSession: the bound GLX context is not current");
  rt().session = rt().next_handle++;
  rt().session_instance = handle_value(instance);
  rt().state = XR_SESSION_STATE_UNKNOWN;
  rt().events.clear();
  rt().phase = FramePhase::kIdle;
  rt().exit_requested = rt().lost = false;
  rt().frames_waited = rt().frames_ended = rt().frames_with_layer = rt().frames_with_content = 0;
  rt().frames_counted = rt().syncs = 0;
  rt().from_seen = false;
  rt().images_written = rt().destroyed_running = false;
  ++rt().sessions;
  queue_state(XR_SESSION_STATE_IDLE);
  queue_state(XR_SESSION_STATE_READY);
  *session = make_handle<XrSession>(rt().session);
  return XR_SUCCESS;
}

bool running();

XrResult XRAPI_CALL DestroySession(XrSession session) {
  LOCK;
  CHECK(check_session(session, "xrDestroySession", true));
  if (!rt().spaces.empty() || !rt().swapchains.empty())
    rt().fail(XR_SUCCESS, "xrDestroySession: spaces or swapchains left");
  rt().destroyed_running = running();  // allowed: the runtime ends it
  rt().spaces.clear();
  rt().swapchains.clear();
  rt().session = 0;
  rt().events.clear();
  rt().write_log();
  return XR_SUCCESS;
}

XrResult XRAPI_CALL BeginSession(XrSession session, const XrSessionBeginInfo* info) {
  LOCK;
  CHECK(check_session(session, "xrBeginSession"));
  CHECK(check_type(info, XR_TYPE_SESSION_BEGIN_INFO, "xrBeginSession", "begin info"));
  if (info->primaryViewConfigurationType != XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO)
    return rt().fail(XR_ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED, "xrBeginSession: not stereo");
  if (rt().state != XR_SESSION_STATE_READY)
    return rt().fail(XR_ERROR_SESSION_NOT_READY, "xrBeginSession: the session is not READY");
  queue_state(XR_SESSION_STATE_SYNCHRONIZED);
  queue_state(XR_SESSION_STATE_VISIBLE);
  queue_state(XR_SESSION_STATE_FOCUSED);
  rt().state = XR_SESSION_STATE_SYNCHRONIZED;  // running from now on
  return XR_SUCCESS;
}

XrResult XRAPI_CALL EndSession(XrSession session) {
  LOCK;
  CHECK(check_session(session, "xrEndSession"));
  if (rt().state != XR_SESSION_STATE_STOPPING)
    return rt().fail(XR_ERROR_SESSION_NOT_STOPPING, "xrEndSession: the session is not STOPPING");
  queue_state(XR_SESSION_STATE_IDLE);
  queue_state(XR_SESSION_STATE_EXITING);
  rt().state = XR_SESSION_STATE_IDLE;
  rt().phase = FramePhase::kIdle;
  ++rt().sessions_ended;
  return XR_SUCCESS;
}

bool running() {
  const XrSessionState s = rt().state;
  return s == XR_SESSION_STATE_SYNCHRONIZED || s == XR_SESSION_STATE_VISIBLE ||
         s == XR_SESSION_STATE_FOCUSED || s == XR_SESSION_STATE_STOPPING;
}

// --- Spaces and views ----------------------------------------------------------------------------

XrResult XRAPI_CALL EnumerateReferenceSpaces(XrSession session, uint32_t capacity, uint32_t* count,
                                             XrReferenceSpaceType* out) {
  LOCK;
  CHECK(check_session(session, "xrEnumerateReferenceSpaces"));
  return enumerate<XrReferenceSpaceType>(
      {XR_REFERENCE_SPACE_TYPE_VIEW, XR_REFERENCE_SPACE_TYPE_LOCAL, XR_REFERENCE_SPACE_TYPE_STAGE},
      capacity, count, out);
}

XrResult XRAPI_CALL CreateReferenceSpace(XrSession session, const XrReferenceSpaceCreateInfo* info,
                                         XrSpace* space) {
  LOCK;
  CHECK(check_session(session, "xrCreateReferenceSpace"));
  CHECK(check_type(info, XR_TYPE_REFERENCE_SPACE_CREATE_INFO, "xrCreateReferenceSpace",
                   "create info"));
  if (!space) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "xrCreateReferenceSpace: null output");
  const XrQuaternionf& q = info->poseInReferenceSpace.orientation;
  if (std::abs(q.x * q.x + q.y * q.y + q.z * q.z + q.w * q.w - 1) > 1e-3f)
    return rt().fail(XR_ERROR_POSE_INVALID, "xrCreateReferenceSpace: orientation not unit");
  if (info->referenceSpaceType != XR_REFERENCE_SPACE_TYPE_LOCAL &&
      info->referenceSpaceType != XR_REFERENCE_SPACE_TYPE_STAGE &&
      info->referenceSpaceType != XR_REFERENCE_SPACE_TYPE_VIEW)
    return rt().fail(XR_ERROR_REFERENCE_SPACE_UNSUPPORTED, "xrCreateReferenceSpace: bad type");
  const uint64_t handle = rt().next_handle++;
  rt().spaces[handle] = info->referenceSpaceType;
  *space = make_handle<XrSpace>(handle);
  return XR_SUCCESS;
}

XrResult XRAPI_CALL DestroySpace(XrSpace space) {
  LOCK;
  if (!rt().spaces.erase(handle_value(space)))
    return rt().fail(XR_ERROR_HANDLE_INVALID, "xrDestroySpace: invalid space");
  rt().action_spaces.erase(handle_value(space));
  return XR_SUCCESS;
}

XrResult XRAPI_CALL LocateViews(XrSession session, const XrViewLocateInfo* info, XrViewState* state,
                                uint32_t capacity, uint32_t* count, XrView* views) {
  LOCK;
  CHECK(check_session(session, "xrLocateViews"));
  CHECK(check_type(info, XR_TYPE_VIEW_LOCATE_INFO, "xrLocateViews", "locate info"));
  CHECK(check_type(state, XR_TYPE_VIEW_STATE, "xrLocateViews", "view state"));
  if (!count) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "xrLocateViews: null count");
  if (info->viewConfigurationType != XR_VIEW_CONFIGURATION_TYPE_PRIMARY_STEREO)
    return rt().fail(XR_ERROR_VIEW_CONFIGURATION_TYPE_UNSUPPORTED, "xrLocateViews: not stereo");
  const auto space = rt().spaces.find(handle_value(info->space));
  if (space == rt().spaces.end())
    return rt().fail(XR_ERROR_HANDLE_INVALID, "xrLocateViews: invalid space");
  if (info->displayTime <= 0) return rt().fail(XR_ERROR_TIME_INVALID, "xrLocateViews: bad time");
  *count = 2;
  if (capacity == 0) return XR_SUCCESS;
  if (capacity < 2) return XR_ERROR_SIZE_INSUFFICIENT;
  // The head: 1.6 m above a STAGE space's origin, at a LOCAL (or VIEW) space's origin.
  const float height = space->second == XR_REFERENCE_SPACE_TYPE_STAGE ? kHeadHeight : 0;
  for (uint32_t i = 0; i < 2; ++i) {
    CHECK(check_type(&views[i], XR_TYPE_VIEW, "xrLocateViews", "view"));
    views[i].pose.orientation = {0, 0, 0, 1};
    views[i].pose.position = {(i == 0 ? -0.5f : 0.5f) * kEyeDistance, height, 0};
    views[i].fov = {-kHalfFov, kHalfFov, kHalfFov, -kHalfFov};
    rt().located[i] = views[i];
  }
  rt().have_located = true;
  state->viewStateFlags = XR_VIEW_STATE_ORIENTATION_VALID_BIT | XR_VIEW_STATE_POSITION_VALID_BIT |
                          XR_VIEW_STATE_ORIENTATION_TRACKED_BIT |
                          XR_VIEW_STATE_POSITION_TRACKED_BIT;
  return XR_SUCCESS;
}

// --- Swapchains ----------------------------------------------------------------------------------

XrResult XRAPI_CALL EnumerateSwapchainFormats(XrSession session, uint32_t capacity, uint32_t* count,
                                              int64_t* out) {
  LOCK;
  CHECK(check_session(session, "xrEnumerateSwapchainFormats"));
  return enumerate<int64_t>({GL_RGBA8}, capacity, count, out);
}

XrResult XRAPI_CALL CreateSwapchain(XrSession session, const XrSwapchainCreateInfo* info,
                                    XrSwapchain* swapchain) {
  LOCK;
  CHECK(check_session(session, "xrCreateSwapchain"));
  CHECK(check_type(info, XR_TYPE_SWAPCHAIN_CREATE_INFO, "xrCreateSwapchain", "create info"));
  if (!swapchain) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "xrCreateSwapchain: null output");
  if (info->format != GL_RGBA8)
    return rt().fail(XR_ERROR_SWAPCHAIN_FORMAT_UNSUPPORTED, "xrCreateSwapchain: bad format");
  if (info->width == 0 || info->height == 0 || info->width > kMaxEyeSize ||
      info->height > kMaxEyeSize || info->sampleCount != 1 || info->faceCount != 1 ||
      info->arraySize != 1 || info->mipCount != 1)
    return rt().fail(XR_ERROR_VALIDATION_FAILURE,
                     "xrCreateSwapchain: bad size, samples, faces, array size or mip count");
  if (!glXGetCurrentContext())
    return rt().fail(XR_ERROR_GRAPHICS_DEVICE_INVALID, "xrCreateSwapchain: no current context");
  SwapchainState s;
  s.width = info->width;
  s.height = info->height;
  s.array_size = info->arraySize;
  glCreateTextures(GL_TEXTURE_2D, static_cast<GLsizei>(kImages), s.textures.data());
  for (const GLuint texture : s.textures)
    glTextureStorage2D(texture, 1, GL_RGBA8, static_cast<GLsizei>(s.width),
                       static_cast<GLsizei>(s.height));
  if (glGetError() != GL_NO_ERROR)
    return rt().fail(XR_ERROR_RUNTIME_FAILURE, "xrCreateSwapchain: OpenGL error");
  const uint64_t handle = rt().next_handle++;
  rt().swapchains[handle] = s;
  *swapchain = make_handle<XrSwapchain>(handle);
  return XR_SUCCESS;
}

XrResult XRAPI_CALL DestroySwapchain(XrSwapchain swapchain) {
  LOCK;
  const auto it = rt().swapchains.find(handle_value(swapchain));
  if (it == rt().swapchains.end())
    return rt().fail(XR_ERROR_HANDLE_INVALID, "xrDestroySwapchain: invalid swapchain");
  if (glXGetCurrentContext())
    glDeleteTextures(static_cast<GLsizei>(kImages), it->second.textures.data());
  else
    rt().fail(XR_SUCCESS, "xrDestroySwapchain: no current context to delete its textures in");
  rt().swapchains.erase(it);
  return XR_SUCCESS;
}

SwapchainState* find_swapchain(XrSwapchain swapchain) {
  const auto it = rt().swapchains.find(handle_value(swapchain));
  return it == rt().swapchains.end() ? nullptr : &it->second;
}

XrResult XRAPI_CALL EnumerateSwapchainImages(XrSwapchain swapchain, uint32_t capacity,
                                             uint32_t* count, XrSwapchainImageBaseHeader* out) {
  LOCK;
  SwapchainState* s = find_swapchain(swapchain);
  if (!s) return rt().fail(XR_ERROR_HANDLE_INVALID, "xrEnumerateSwapchainImages: invalid");
  if (!count) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "null count output");
  *count = kImages;
  if (capacity == 0) return XR_SUCCESS;
  if (capacity < kImages) return XR_ERROR_SIZE_INSUFFICIENT;
  auto* images = reinterpret_cast<XrSwapchainImageOpenGLKHR*>(out);
  for (uint32_t i = 0; i < kImages; ++i) {
    CHECK(check_type(&images[i], XR_TYPE_SWAPCHAIN_IMAGE_OPENGL_KHR, "xrEnumerateSwapchainImages",
                     "image"));
    images[i].image = s->textures[i];
  }
  return XR_SUCCESS;
}

XrResult XRAPI_CALL AcquireSwapchainImage(XrSwapchain swapchain,
                                          const XrSwapchainImageAcquireInfo* info,
                                          uint32_t* index) {
  LOCK;
  SwapchainState* s = find_swapchain(swapchain);
  if (!s) return rt().fail(XR_ERROR_HANDLE_INVALID, "xrAcquireSwapchainImage: invalid");
  if (info)
    CHECK(check_type(info, XR_TYPE_SWAPCHAIN_IMAGE_ACQUIRE_INFO, "xrAcquireSwapchainImage",
                     "acquire info"));
  if (!index) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "xrAcquireSwapchainImage: null");
  if (s->acquired.size() >= kImages)
    return rt().fail(XR_ERROR_CALL_ORDER_INVALID, "xrAcquireSwapchainImage: all acquired");
  *index = s->next;
  s->acquired.push_back(s->next);
  s->next = (s->next + 1) % kImages;
  return XR_SUCCESS;
}

XrResult XRAPI_CALL WaitSwapchainImage(XrSwapchain swapchain,
                                       const XrSwapchainImageWaitInfo* info) {
  LOCK;
  SwapchainState* s = find_swapchain(swapchain);
  if (!s) return rt().fail(XR_ERROR_HANDLE_INVALID, "xrWaitSwapchainImage: invalid");
  CHECK(check_type(info, XR_TYPE_SWAPCHAIN_IMAGE_WAIT_INFO, "xrWaitSwapchainImage", "wait info"));
  if (s->acquired.empty() || s->waited)
    return rt().fail(XR_ERROR_CALL_ORDER_INVALID, "xrWaitSwapchainImage: nothing to wait for");
  s->waited = true;
  return XR_SUCCESS;
}

XrResult XRAPI_CALL ReleaseSwapchainImage(XrSwapchain swapchain,
                                          const XrSwapchainImageReleaseInfo* info) {
  LOCK;
  SwapchainState* s = find_swapchain(swapchain);
  if (!s) return rt().fail(XR_ERROR_HANDLE_INVALID, "xrReleaseSwapchainImage: invalid");
  if (info)
    CHECK(check_type(info, XR_TYPE_SWAPCHAIN_IMAGE_RELEASE_INFO, "xrReleaseSwapchainImage",
                     "release info"));
  if (s->acquired.empty() || !s->waited)
    return rt().fail(XR_ERROR_CALL_ORDER_INVALID, "xrReleaseSwapchainImage: not waited for");
  s->last_released = static_cast<int>(s->acquired.front());
  s->acquired.pop_front();
  s->waited = false;
  return XR_SUCCESS;
}

// --- Frames --------------------------------------------------------------------------------------

XrResult XRAPI_CALL WaitFrame(XrSession session, const XrFrameWaitInfo* info, XrFrameState* state) {
  std::chrono::steady_clock::time_point until;
  {
    LOCK;
    CHECK(check_session(session, "xrWaitFrame"));
    if (info) CHECK(check_type(info, XR_TYPE_FRAME_WAIT_INFO, "xrWaitFrame", "wait info"));
    CHECK(check_type(state, XR_TYPE_FRAME_STATE, "xrWaitFrame", "frame state"));
    if (!running())
      return rt().fail(XR_ERROR_SESSION_NOT_RUNNING, "xrWaitFrame: the session is not running");
    if (rt().phase == FramePhase::kWaited)
      return rt().fail(XR_ERROR_CALL_ORDER_INVALID, "xrWaitFrame twice without xrBeginFrame");
    until = rt().next_frame;
  }
  std::this_thread::sleep_until(until);  // pacing, outside the lock
  LOCK;
  const auto now = std::chrono::steady_clock::now();
  rt().next_frame = std::max(now, until) + std::chrono::nanoseconds(frame_period_ns());
  int64_t predicted =
      std::chrono::duration_cast<std::chrono::nanoseconds>(now - rt().start).count() +
      2 * frame_period_ns();
  predicted = std::max(predicted, rt().last_predicted + 1);
  rt().last_predicted = predicted;
  state->predictedDisplayTime = predicted;
  state->predictedDisplayPeriod = frame_period_ns();
  state->shouldRender =
      rt().state == XR_SESSION_STATE_VISIBLE || rt().state == XR_SESSION_STATE_FOCUSED;
  rt().phase = FramePhase::kWaited;
  ++rt().frames_waited;
  return XR_SUCCESS;
}

XrResult XRAPI_CALL BeginFrame(XrSession session, const XrFrameBeginInfo* info) {
  LOCK;
  CHECK(check_session(session, "xrBeginFrame"));
  if (info) CHECK(check_type(info, XR_TYPE_FRAME_BEGIN_INFO, "xrBeginFrame", "begin info"));
  if (!running()) return rt().fail(XR_ERROR_SESSION_NOT_RUNNING, "xrBeginFrame: not running");
  if (rt().phase != FramePhase::kWaited)
    return rt().fail(XR_ERROR_CALL_ORDER_INVALID, "xrBeginFrame without xrWaitFrame");
  rt().phase = FramePhase::kBegun;
  return XR_SUCCESS;
}

// The texture's RGBA8 pixels, bottom row first.
std::vector<uint8_t> read_texture(const SwapchainState& s, GLuint texture) {
  std::vector<uint8_t> pixels(size_t{s.width} * s.height * 4);
  glPixelStorei(GL_PACK_ALIGNMENT, 1);
  glGetTextureImage(texture, 0, GL_RGBA, GL_UNSIGNED_BYTE, static_cast<GLsizei>(pixels.size()),
                    pixels.data());
  return pixels;
}

// Whether more than 1 % of the pixels differ clearly from the first one.
bool has_content(const std::vector<uint8_t>& pixels) {
  size_t differing = 0;
  for (size_t i = 0; i < pixels.size(); i += 4)
    differing += std::abs(pixels[i] - pixels[0]) + std::abs(pixels[i + 1] - pixels[1]) +
                     std::abs(pixels[i + 2] - pixels[2]) >
                 30;
  return differing * 100 > pixels.size() / 4;
}

void write_ppm(const std::string& path, const SwapchainState& s,
               const std::vector<uint8_t>& pixels) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out << "P6\n" << s.width << " " << s.height << "\n255\n";
  for (uint32_t y = s.height; y-- > 0;)  // top row first
    for (uint32_t x = 0; x < s.width; ++x)
      out.write(reinterpret_cast<const char*>(&pixels[(size_t{y} * s.width + x) * 4]), 3);
}

bool same_pose(const XrPosef& a, const XrPosef& b) {
  return std::abs(a.position.x - b.position.x) < 1e-5f &&
         std::abs(a.position.y - b.position.y) < 1e-5f &&
         std::abs(a.position.z - b.position.z) < 1e-5f &&
         std::abs(a.orientation.x - b.orientation.x) < 1e-5f &&
         std::abs(a.orientation.y - b.orientation.y) < 1e-5f &&
         std::abs(a.orientation.z - b.orientation.z) < 1e-5f &&
         std::abs(a.orientation.w - b.orientation.w) < 1e-5f;
}
bool same_fov(const XrFovf& a, const XrFovf& b) {
  return std::abs(a.angleLeft - b.angleLeft) < 1e-5f &&
         std::abs(a.angleRight - b.angleRight) < 1e-5f && std::abs(a.angleUp - b.angleUp) < 1e-5f &&
         std::abs(a.angleDown - b.angleDown) < 1e-5f;
}

// Checks a projection layer; on success fills the images it shows (swapchain, image index).
XrResult check_projection(const XrCompositionLayerProjection& layer,
                          std::vector<std::pair<SwapchainState*, int>>& shown) {
  if (rt().spaces.count(handle_value(layer.space)) == 0)
    return rt().fail(XR_ERROR_HANDLE_INVALID, "xrEndFrame: the layer's space is invalid");
  if (layer.viewCount != 2 || !layer.views)
    return rt().fail(XR_ERROR_VALIDATION_FAILURE, "xrEndFrame: the layer has not 2 views");
  for (uint32_t i = 0; i < 2; ++i) {
    const XrCompositionLayerProjectionView& v = layer.views[i];
    if (v.type != XR_TYPE_COMPOSITION_LAYER_PROJECTION_VIEW)
      return rt().fail(XR_ERROR_VALIDATION_FAILURE, "xrEndFrame: wrong type of projection view");
    SwapchainState* s = find_swapchain(v.subImage.swapchain);
    if (!s) return rt().fail(XR_ERROR_HANDLE_INVALID, "xrEndFrame: a view's swapchain is invalid");
    if (s->last_released < 0 || !s->acquired.empty())
      return rt().fail(XR_ERROR_LAYER_INVALID,
                       "xrEndFrame: a view's swapchain has no released image (or one acquired)");
    const XrRect2Di& r = v.subImage.imageRect;
    if (r.offset.x < 0 || r.offset.y < 0 || r.extent.width <= 0 || r.extent.height <= 0 ||
        static_cast<uint32_t>(r.offset.x + r.extent.width) > s->width ||
        static_cast<uint32_t>(r.offset.y + r.extent.height) > s->height ||
        v.subImage.imageArrayIndex >= s->array_size)
      return rt().fail(XR_ERROR_SWAPCHAIN_RECT_INVALID, "xrEndFrame: bad image rectangle");
    if (!rt().have_located || !same_pose(v.pose, rt().located[i].pose) ||
        !same_fov(v.fov, rt().located[i].fov))
      return rt().fail(XR_ERROR_VALIDATION_FAILURE,
                       "xrEndFrame: a view's pose or fov is not the located one");
    for (const auto& [other, index] : shown)
      if (other == s) return rt().fail(XR_ERROR_LAYER_INVALID, "xrEndFrame: one swapchain twice");
    shown.emplace_back(s, s->last_released);
  }
  return XR_SUCCESS;
}

XrResult XRAPI_CALL EndFrame(XrSession session, const XrFrameEndInfo* info) {
  LOCK;
  CHECK(check_session(session, "xrEndFrame"));
  CHECK(check_type(info, XR_TYPE_FRAME_END_INFO, "xrEndFrame", "end info"));
  if (!running()) return rt().fail(XR_ERROR_SESSION_NOT_RUNNING, "xrEndFrame: not running");
  if (rt().phase != FramePhase::kBegun)
    return rt().fail(XR_ERROR_CALL_ORDER_INVALID, "xrEndFrame without xrBeginFrame");
  if (info->displayTime != rt().last_predicted)
    return rt().fail(XR_ERROR_TIME_INVALID, "xrEndFrame: not the predicted display time");
  if (info->environmentBlendMode != XR_ENVIRONMENT_BLEND_MODE_OPAQUE)
    return rt().fail(XR_ERROR_ENVIRONMENT_BLEND_MODE_UNSUPPORTED, "xrEndFrame: not OPAQUE");
  if (info->layerCount > 0 && !info->layers)
    return rt().fail(XR_ERROR_VALIDATION_FAILURE, "xrEndFrame: null layers");
  std::vector<std::pair<SwapchainState*, int>> shown;
  for (uint32_t i = 0; i < info->layerCount; ++i) {
    const XrCompositionLayerBaseHeader* layer = info->layers[i];
    if (!layer) return rt().fail(XR_ERROR_LAYER_INVALID, "xrEndFrame: a null layer");
    if (layer->type != XR_TYPE_COMPOSITION_LAYER_PROJECTION)
      return rt().fail(XR_ERROR_LAYER_INVALID, "xrEndFrame: not a projection layer");
    shown.clear();
    CHECK(check_projection(*reinterpret_cast<const XrCompositionLayerProjection*>(layer), shown));
  }
  rt().phase = FramePhase::kIdle;
  ++rt().frames_ended;
  if (!shown.empty()) ++rt().frames_with_layer;
  std::vector<std::vector<uint8_t>> pixels;
  bool content = !shown.empty();
  for (const auto& [s, index] : shown) {
    pixels.push_back(read_texture(*s, s->textures[static_cast<size_t>(index)]));
    content = content && has_content(pixels.back());
  }
  if (glGetError() != GL_NO_ERROR) rt().fail(XR_SUCCESS, "xrEndFrame: OpenGL error reading back");
  if (content) ++rt().frames_with_content;
  if (content && from_met()) ++rt().frames_counted;
  if (!rt().exit_requested && ((rt().frames_counted >= frames_wanted() && until_met()) ||
                               rt().frames_ended >= kMaxFrames)) {
    rt().exit_requested = true;
    if (const char* dir = out_dir(); dir && !shown.empty()) {
      for (size_t i = 0; i < shown.size(); ++i)
        write_ppm(std::string(dir) + "/eye" + std::to_string(i) + ".ppm", *shown[i].first,
                  pixels[i]);
      rt().images_written = true;
    }
    const char* end = std::getenv("VOLCAST_MOCK_XR_END");
    if (end && std::string(end) == "lost") {  // the instance is lost, with no event before
      rt().lost = true;                       // every later call fails before it gets here again
      rt().exit_requested = false;
      return XR_SUCCESS;
    }
    if (rt().state == XR_SESSION_STATE_FOCUSED) queue_state(XR_SESSION_STATE_VISIBLE);
    queue_state(XR_SESSION_STATE_SYNCHRONIZED);
    queue_state(XR_SESSION_STATE_STOPPING);
  }
  return XR_SUCCESS;
}

// --- Actions (controllers) -----------------------------------------------------------------------

XrPath intern(const std::string& path) {
  auto [it, added] = rt().paths.try_emplace(path, XrPath(rt().paths.size() + 1));
  return it->second;
}

std::string path_string(XrPath path) {
  for (const auto& [s, p] : rt().paths)
    if (p == path) return s;
  return "";
}

XrResult XRAPI_CALL StringToPath(XrInstance instance, const char* path, XrPath* out) {
  LOCK;
  CHECK(check_instance(instance, "xrStringToPath"));
  if (!path || !out || path[0] != '/')
    return rt().fail(XR_ERROR_PATH_FORMAT_INVALID, "xrStringToPath: bad path");
  *out = intern(path);
  return XR_SUCCESS;
}

XrResult XRAPI_CALL CreateActionSet(XrInstance instance, const XrActionSetCreateInfo* info,
                                    XrActionSet* set) {
  LOCK;
  CHECK(check_instance(instance, "xrCreateActionSet"));
  CHECK(check_type(info, XR_TYPE_ACTION_SET_CREATE_INFO, "xrCreateActionSet", "create info"));
  if (!set) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "xrCreateActionSet: null output");
  const uint64_t handle = rt().next_handle++;
  rt().action_sets[handle] = false;
  *set = make_handle<XrActionSet>(handle);
  return XR_SUCCESS;
}

XrResult XRAPI_CALL DestroyActionSet(XrActionSet set) {
  LOCK;
  if (!rt().action_sets.erase(handle_value(set)))
    return rt().fail(XR_ERROR_HANDLE_INVALID, "xrDestroyActionSet: invalid action set");
  return XR_SUCCESS;
}

XrResult XRAPI_CALL CreateAction(XrActionSet set, const XrActionCreateInfo* info,
                                 XrAction* action) {
  LOCK;
  const auto s = rt().action_sets.find(handle_value(set));
  if (s == rt().action_sets.end())
    return rt().fail(XR_ERROR_HANDLE_INVALID, "xrCreateAction: invalid action set");
  if (s->second) return rt().fail(XR_ERROR_ACTIONSETS_ALREADY_ATTACHED, "xrCreateAction: attached");
  CHECK(check_type(info, XR_TYPE_ACTION_CREATE_INFO, "xrCreateAction", "create info"));
  if (!action) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "xrCreateAction: null output");
  Runtime::Action a;
  a.type = info->actionType;
  a.subactions.assign(info->subactionPaths, info->subactionPaths + info->countSubactionPaths);
  const uint64_t handle = rt().next_handle++;
  rt().actions[handle] = a;
  *action = make_handle<XrAction>(handle);
  return XR_SUCCESS;
}

XrResult XRAPI_CALL DestroyAction(XrAction action) {
  LOCK;
  if (!rt().actions.erase(handle_value(action)))
    return rt().fail(XR_ERROR_HANDLE_INVALID, "xrDestroyAction: invalid action");
  return XR_SUCCESS;
}

XrResult XRAPI_CALL SuggestInteractionProfileBindings(
    XrInstance instance, const XrInteractionProfileSuggestedBinding* suggested) {
  LOCK;
  CHECK(check_instance(instance, "xrSuggestInteractionProfileBindings"));
  CHECK(check_type(suggested, XR_TYPE_INTERACTION_PROFILE_SUGGESTED_BINDING,
                   "xrSuggestInteractionProfileBindings", "suggested binding"));
  const std::string profile = path_string(suggested->interactionProfile);
  if (profile != "/interaction_profiles/oculus/touch_controller" &&
      profile != "/interaction_profiles/khr/simple_controller")
    return XR_SUCCESS;  // a profile this device is not: accepted, unused
  // Touch wins over simple: the device is a Touch.
  if (!rt().profile.empty() && profile != rt().profile &&
      rt().profile == "/interaction_profiles/oculus/touch_controller")
    return XR_SUCCESS;
  rt().profile = profile;
  for (auto& [handle, a] : rt().actions) a.inputs.clear();
  for (uint32_t i = 0; i < suggested->countSuggestedBindings; ++i) {
    const auto a = rt().actions.find(handle_value(suggested->suggestedBindings[i].action));
    if (a == rt().actions.end())
      return rt().fail(XR_ERROR_HANDLE_INVALID, "xrSuggestInteractionProfileBindings: action");
    const std::string input = path_string(suggested->suggestedBindings[i].binding);
    if (input.empty())
      return rt().fail(XR_ERROR_PATH_INVALID, "xrSuggestInteractionProfileBindings: path");
    a->second.inputs.push_back(input);
  }
  return XR_SUCCESS;
}

XrResult XRAPI_CALL AttachSessionActionSets(XrSession session,
                                            const XrSessionActionSetsAttachInfo* info) {
  LOCK;
  CHECK(check_session(session, "xrAttachSessionActionSets"));
  CHECK(check_type(info, XR_TYPE_SESSION_ACTION_SETS_ATTACH_INFO, "xrAttachSessionActionSets",
                   "attach info"));
  for (uint32_t i = 0; i < info->countActionSets; ++i) {
    const auto s = rt().action_sets.find(handle_value(info->actionSets[i]));
    if (s == rt().action_sets.end())
      return rt().fail(XR_ERROR_HANDLE_INVALID, "xrAttachSessionActionSets: action set");
    if (s->second) return XR_ERROR_ACTIONSETS_ALREADY_ATTACHED;
    s->second = true;
  }
  return XR_SUCCESS;
}

XrResult XRAPI_CALL CreateActionSpace(XrSession session, const XrActionSpaceCreateInfo* info,
                                      XrSpace* space) {
  LOCK;
  CHECK(check_session(session, "xrCreateActionSpace"));
  CHECK(check_type(info, XR_TYPE_ACTION_SPACE_CREATE_INFO, "xrCreateActionSpace", "create info"));
  const auto a = rt().actions.find(handle_value(info->action));
  if (a == rt().actions.end() || a->second.type != XR_ACTION_TYPE_POSE_INPUT)
    return rt().fail(XR_ERROR_HANDLE_INVALID, "xrCreateActionSpace: not a pose action");
  if (!space) return rt().fail(XR_ERROR_VALIDATION_FAILURE, "xrCreateActionSpace: null output");
  const uint64_t handle = rt().next_handle++;
  rt().spaces[handle] = XR_REFERENCE_SPACE_TYPE_MAX_ENUM;  // an action space
  rt().action_spaces[handle] = {handle_value(info->action), info->subactionPath};
  *space = make_handle<XrSpace>(handle);
  return XR_SUCCESS;
}

XrResult XRAPI_CALL SyncActions(XrSession session, const XrActionsSyncInfo* info) {
  LOCK;
  CHECK(check_session(session, "xrSyncActions"));
  CHECK(check_type(info, XR_TYPE_ACTIONS_SYNC_INFO, "xrSyncActions", "sync info"));
  for (uint32_t i = 0; i < info->countActiveActionSets; ++i) {
    const auto s = rt().action_sets.find(handle_value(info->activeActionSets[i].actionSet));
    if (s == rt().action_sets.end() || !s->second)
      return rt().fail(XR_ERROR_ACTIONSET_NOT_ATTACHED, "xrSyncActions: not attached");
  }
  if (from_met()) ++rt().syncs;
  return rt().state == XR_SESSION_STATE_FOCUSED ? XR_SUCCESS : XR_SESSION_NOT_FOCUSED;
}

std::pair<uint64_t, uint64_t> squeeze_syncs() {
  const char* v = std::getenv("VOLCAST_MOCK_XR_SQUEEZE");
  unsigned long long first = 0, last = 0;
  if (!v || std::sscanf(v, "%llu,%llu", &first, &last) != 2) return {0, 0};
  return {first, last};
}

// The right hand's state now: whether it squeezes, and its turn about +y (radians).
std::pair<bool, float> right_hand() {
  const auto [first, last] = squeeze_syncs();
  const uint64_t n = rt().syncs;
  const bool squeezing = first > 0 && n >= first && n <= last;
  const uint64_t turned = first == 0 || n < first ? 0 : std::min(n, last) - first;
  return {squeezing, 0.03f * static_cast<float>(turned)};
}

// The input `a` is bound to for `subaction` (0: any hand), or null.
const std::string* bound_input(const Runtime::Action& a, XrPath subaction) {
  const std::string hand = subaction ? path_string(subaction) : "";
  for (const std::string& input : a.inputs)
    if (hand.empty() || input.rfind(hand + "/", 0) == 0) return &input;
  return nullptr;
}

XrResult get_action(XrSession session, const XrActionStateGetInfo* info, const char* call,
                    XrActionType type, const Runtime::Action** out) {
  CHECK(check_session(session, call));
  CHECK(check_type(info, XR_TYPE_ACTION_STATE_GET_INFO, call, "get info"));
  const auto a = rt().actions.find(handle_value(info->action));
  if (a == rt().actions.end())
    return rt().fail(XR_ERROR_HANDLE_INVALID, std::string(call) + ": action");
  if (a->second.type != type)
    return rt().fail(XR_ERROR_ACTION_TYPE_MISMATCH, std::string(call) + ": type");
  *out = &a->second;
  return XR_SUCCESS;
}

// Whether VOLCAST_MOCK_XR_BUTTONS holds `component` now (e.g. "x/click" of the left controller,
// "right/a/click" of the right one).
bool button_held(const std::string& component) {
  const char* v = std::getenv("VOLCAST_MOCK_XR_BUTTONS");
  if (!v) return false;
  const std::string list = v;
  for (size_t at = 0; at < list.size();) {
    const size_t end = std::min(list.find(';', at), list.size());
    const std::string entry = list.substr(at, end - at);
    at = end + 1;
    const size_t colon = entry.find(':');
    unsigned long long first = 0, last = 0;
    if (colon == std::string::npos || entry.substr(0, colon) != component ||
        std::sscanf(entry.c_str() + colon + 1, "%llu,%llu", &first, &last) != 2)
      continue;
    if (rt().syncs >= first && rt().syncs <= last) return true;
  }
  return false;
}

float input_value(const std::string& input) {
  const std::string left = "/user/hand/left/input/";
  if (input.rfind(left, 0) == 0) return button_held(input.substr(left.size())) ? 1.0f : 0.0f;
  const std::string right = "/user/hand/right/input/";
  if (input.rfind(right, 0) != 0) return 0;
  if (input.find("/squeeze/") != std::string::npos || input.find("/select/") != std::string::npos)
    return right_hand().first ? 1.0f : 0.0f;
  return button_held("right/" + input.substr(right.size())) ? 1.0f : 0.0f;
}

XrResult XRAPI_CALL GetActionStateFloat(XrSession session, const XrActionStateGetInfo* info,
                                        XrActionStateFloat* state) {
  LOCK;
  const Runtime::Action* a = nullptr;
  CHECK(get_action(session, info, "xrGetActionStateFloat", XR_ACTION_TYPE_FLOAT_INPUT, &a));
  CHECK(check_type(state, XR_TYPE_ACTION_STATE_FLOAT, "xrGetActionStateFloat", "state"));
  const std::string* input = bound_input(*a, info->subactionPath);
  state->isActive = input ? XR_TRUE : XR_FALSE;
  state->currentState = input ? input_value(*input) : 0;
  state->changedSinceLastSync = XR_FALSE;
  state->lastChangeTime = 0;
  return XR_SUCCESS;
}

XrResult XRAPI_CALL GetActionStateBoolean(XrSession session, const XrActionStateGetInfo* info,
                                          XrActionStateBoolean* state) {
  LOCK;
  const Runtime::Action* a = nullptr;
  CHECK(get_action(session, info, "xrGetActionStateBoolean", XR_ACTION_TYPE_BOOLEAN_INPUT, &a));
  CHECK(check_type(state, XR_TYPE_ACTION_STATE_BOOLEAN, "xrGetActionStateBoolean", "state"));
  const std::string* input = bound_input(*a, info->subactionPath);
  state->isActive = input ? XR_TRUE : XR_FALSE;
  state->currentState = input && input_value(*input) > 0.5f ? XR_TRUE : XR_FALSE;
  state->changedSinceLastSync = XR_FALSE;
  state->lastChangeTime = 0;
  return XR_SUCCESS;
}

XrResult XRAPI_CALL GetActionStatePose(XrSession session, const XrActionStateGetInfo* info,
                                       XrActionStatePose* state) {
  LOCK;
  const Runtime::Action* a = nullptr;
  CHECK(get_action(session, info, "xrGetActionStatePose", XR_ACTION_TYPE_POSE_INPUT, &a));
  CHECK(check_type(state, XR_TYPE_ACTION_STATE_POSE, "xrGetActionStatePose", "state"));
  state->isActive = bound_input(*a, info->subactionPath) ? XR_TRUE : XR_FALSE;
  return XR_SUCCESS;
}

XrResult XRAPI_CALL LocateSpace(XrSpace space, XrSpace base, XrTime time,
                                XrSpaceLocation* location) {
  LOCK;
  CHECK(check_type(location, XR_TYPE_SPACE_LOCATION, "xrLocateSpace", "location"));
  const auto hand = rt().action_spaces.find(handle_value(space));
  const auto base_space = rt().spaces.find(handle_value(base));
  if (hand == rt().action_spaces.end() || base_space == rt().spaces.end() ||
      base_space->second == XR_REFERENCE_SPACE_TYPE_MAX_ENUM)
    return rt().fail(XR_ERROR_HANDLE_INVALID,
                     "xrLocateSpace: only an action space in a reference space");
  if (time <= 0) return rt().fail(XR_ERROR_TIME_INVALID, "xrLocateSpace: bad time");
  location->locationFlags = 0;
  const auto a = rt().actions.find(hand->second.first);
  if (a == rt().actions.end() || !bound_input(a->second, hand->second.second)) return XR_SUCCESS;
  const bool right = path_string(hand->second.second) == "/user/hand/right";
  float x = right ? 0.2f : -0.2f, y = 1.1f, z = -0.3f, turn = 0;
  if (!right)
    if (const char* v = std::getenv("VOLCAST_MOCK_XR_LEFT_GRIP"))
      std::sscanf(v, "%f,%f,%f", &x, &y, &z);
  if (right) {
    if (const char* v = std::getenv("VOLCAST_MOCK_XR_RIGHT_GRIP"))
      std::sscanf(v, "%f,%f,%f", &x, &y, &z);
    turn = right_hand().second;
  }
  if (base_space->second != XR_REFERENCE_SPACE_TYPE_STAGE) y -= kHeadHeight;
  location->pose.position = {x, y, z};
  location->pose.orientation = {0, std::sin(turn / 2), 0, std::cos(turn / 2)};
  location->locationFlags =
      XR_SPACE_LOCATION_POSITION_VALID_BIT | XR_SPACE_LOCATION_ORIENTATION_VALID_BIT |
      XR_SPACE_LOCATION_POSITION_TRACKED_BIT | XR_SPACE_LOCATION_ORIENTATION_TRACKED_BIT;
  return XR_SUCCESS;
}

// --- Dispatch ------------------------------------------------------------------------------------

XrResult XRAPI_CALL GetInstanceProcAddr(XrInstance instance, const char* name,
                                        PFN_xrVoidFunction* function) {
  if (!name || !function) return XR_ERROR_VALIDATION_FAILURE;
  *function = nullptr;
  const auto fn = [&](auto f) {
    *function = reinterpret_cast<PFN_xrVoidFunction>(f);
    return XR_SUCCESS;
  };
  const std::string n = name;
  // Without an instance only these three.
  if (n == "xrEnumerateInstanceExtensionProperties")
    return fn(&EnumerateInstanceExtensionProperties);
  if (n == "xrEnumerateApiLayerProperties") return fn(&EnumerateApiLayerProperties);
  if (n == "xrCreateInstance") return fn(&CreateInstance);
  {
    LOCK;
    if (!valid_instance(instance)) return XR_ERROR_HANDLE_INVALID;
  }
  if (n == "xrGetInstanceProcAddr") return fn(&GetInstanceProcAddr);
  if (n == "xrDestroyInstance") return fn(&DestroyInstance);
  if (n == "xrGetSystem") return fn(&GetSystem);
  if (n == "xrGetOpenGLGraphicsRequirementsKHR") return fn(&GetOpenGLGraphicsRequirementsKHR);
  if (n == "xrEnumerateViewConfigurationViews") return fn(&EnumerateViewConfigurationViews);
  if (n == "xrPollEvent") return fn(&PollEvent);
  if (n == "xrCreateSession") return fn(&CreateSession);
  if (n == "xrDestroySession") return fn(&DestroySession);
  if (n == "xrBeginSession") return fn(&BeginSession);
  if (n == "xrEndSession") return fn(&EndSession);
  if (n == "xrEnumerateReferenceSpaces") return fn(&EnumerateReferenceSpaces);
  if (n == "xrCreateReferenceSpace") return fn(&CreateReferenceSpace);
  if (n == "xrDestroySpace") return fn(&DestroySpace);
  if (n == "xrLocateViews") return fn(&LocateViews);
  if (n == "xrEnumerateSwapchainFormats") return fn(&EnumerateSwapchainFormats);
  if (n == "xrCreateSwapchain") return fn(&CreateSwapchain);
  if (n == "xrDestroySwapchain") return fn(&DestroySwapchain);
  if (n == "xrEnumerateSwapchainImages") return fn(&EnumerateSwapchainImages);
  if (n == "xrAcquireSwapchainImage") return fn(&AcquireSwapchainImage);
  if (n == "xrWaitSwapchainImage") return fn(&WaitSwapchainImage);
  if (n == "xrReleaseSwapchainImage") return fn(&ReleaseSwapchainImage);
  if (n == "xrWaitFrame") return fn(&WaitFrame);
  if (n == "xrBeginFrame") return fn(&BeginFrame);
  if (n == "xrEndFrame") return fn(&EndFrame);
  if (n == "xrStringToPath") return fn(&StringToPath);
  if (n == "xrCreateActionSet") return fn(&CreateActionSet);
  if (n == "xrDestroyActionSet") return fn(&DestroyActionSet);
  if (n == "xrCreateAction") return fn(&CreateAction);
  if (n == "xrDestroyAction") return fn(&DestroyAction);
  if (n == "xrSuggestInteractionProfileBindings") return fn(&SuggestInteractionProfileBindings);
  if (n == "xrAttachSessionActionSets") return fn(&AttachSessionActionSets);
  if (n == "xrCreateActionSpace") return fn(&CreateActionSpace);
  if (n == "xrSyncActions") return fn(&SyncActions);
  if (n == "xrGetActionStateFloat") return fn(&GetActionStateFloat);
  if (n == "xrGetActionStateBoolean") return fn(&GetActionStateBoolean);
  if (n == "xrGetActionStatePose") return fn(&GetActionStatePose);
  if (n == "xrLocateSpace") return fn(&LocateSpace);
  return XR_ERROR_FUNCTION_UNSUPPORTED;
}

}  // namespace

extern "C" __attribute__((visibility("default"))) XrResult XRAPI_CALL
xrNegotiateLoaderRuntimeInterface(const XrNegotiateLoaderInfo* loaderInfo,
                                  XrNegotiateRuntimeRequest* runtimeRequest) {
  if (!loaderInfo || !runtimeRequest ||
      loaderInfo->structType != XR_LOADER_INTERFACE_STRUCT_LOADER_INFO ||
      loaderInfo->structSize != sizeof(XrNegotiateLoaderInfo) ||
      runtimeRequest->structType != XR_LOADER_INTERFACE_STRUCT_RUNTIME_REQUEST ||
      runtimeRequest->structSize != sizeof(XrNegotiateRuntimeRequest) ||
      loaderInfo->minInterfaceVersion > 1 || loaderInfo->maxInterfaceVersion < 1 ||
      loaderInfo->minApiVersion > XR_CURRENT_API_VERSION ||
      loaderInfo->maxApiVersion < XR_MAKE_VERSION(1, 0, 0))
    return XR_ERROR_INITIALIZATION_FAILED;
  runtimeRequest->runtimeInterfaceVersion = 1;
  runtimeRequest->runtimeApiVersion = XR_CURRENT_API_VERSION;
  runtimeRequest->getInstanceProcAddr = &GetInstanceProcAddr;
  return XR_SUCCESS;
}
