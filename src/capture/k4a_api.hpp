#pragma once
// Internal: the part of the Azure Kinect Sensor SDK 1.4 C API (k4a.h, k4atypes.h, as documented at
// microsoft.github.io/Azure-Kinect-Sensor-SDK) that the live source uses, declared here because
// the SDK is not a Debian package; bound at run time with dlopen/dlsym. Enum values and the
// configuration struct's layout are the SDK's.
#include <cstddef>
#include <cstdint>

namespace volcast::k4a {

using device_t = struct device_s*;
using capture_t = struct capture_s*;
using image_t = struct image_s*;

enum result_t : int { kResultSucceeded = 0, kResultFailed = 1 };
enum buffer_result_t : int { kBufferSucceeded = 0, kBufferFailed = 1, kBufferTooSmall = 2 };
enum wait_result_t : int { kWaitSucceeded = 0, kWaitFailed = 1, kWaitTimeout = 2 };
enum image_format_t : int {
  kColorMjpg = 0,
  kColorNv12 = 1,
  kColorYuy2 = 2,
  kColorBgra32 = 3,
  kDepth16 = 4,
  kIr16 = 5,
};
enum color_resolution_t : int {
  kColorOff = 0,
  kColor720p = 1,
  kColor1080p = 2,
  kColor1440p = 3,
  kColor1536p = 4,
  kColor2160p = 5,
  kColor3072p = 6,
};
enum depth_mode_t : int {
  kDepthOff = 0,
  kNfov2x2Binned = 1,
  kNfovUnbinned = 2,
  kWfov2x2Binned = 3,
  kWfovUnbinned = 4,
  kPassiveIr = 5,
};
enum fps_t : int { kFps5 = 0, kFps15 = 1, kFps30 = 2 };
enum wired_sync_mode_t : int { kStandalone = 0, kMaster = 1, kSubordinate = 2 };

/// k4a_device_configuration_t.
struct device_configuration_t {
  image_format_t color_format;
  color_resolution_t color_resolution;
  depth_mode_t depth_mode;
  fps_t camera_fps;
  bool synchronized_images_only;
  int32_t depth_delay_off_color_usec;
  wired_sync_mode_t wired_sync_mode;
  uint32_t subordinate_delay_off_master_usec;
  bool disable_streaming_indicator;
};

/// The functions, by their SDK names (k4a_<name>).
struct Api {
  uint32_t (*device_get_installed_count)();
  result_t (*device_open)(uint32_t index, device_t* device);
  void (*device_close)(device_t device);
  buffer_result_t (*device_get_serialnum)(device_t device, char* serial, size_t* size);
  buffer_result_t (*device_get_raw_calibration)(device_t device, uint8_t* data, size_t* size);
  result_t (*device_start_cameras)(device_t device, const device_configuration_t* config);
  void (*device_stop_cameras)(device_t device);
  wait_result_t (*device_get_capture)(device_t device, capture_t* capture, int32_t timeout_ms);
  image_t (*capture_get_depth_image)(capture_t capture);
  image_t (*capture_get_color_image)(capture_t capture);
  void (*capture_release)(capture_t capture);
  void (*image_release)(image_t image);
  uint8_t* (*image_get_buffer)(image_t image);
  size_t (*image_get_size)(image_t image);
  image_format_t (*image_get_format)(image_t image);
  int (*image_get_width_pixels)(image_t image);
  int (*image_get_height_pixels)(image_t image);
  int (*image_get_stride_bytes)(image_t image);
  uint64_t (*image_get_device_timestamp_usec)(image_t image);
};

}  // namespace volcast::k4a
