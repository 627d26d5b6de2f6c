#include "volcast/capture/k4a_device.hpp"

#include <dlfcn.h>
#include <spdlog/spdlog.h>

#include <climits>
#include <cstdlib>
#include <cstring>
#include <map>
#include <mutex>
#include <optional>
#include <vector>

#include "k4a_api.hpp"
#include "volcast/capture/k4a_calibration.hpp"
#include "volcast/capture/registration.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/jpeg.hpp"

namespace volcast {
namespace {

// libk4a, loaded once per process (never unloaded: devices may outlive any one source).
const k4a::Api& api() {
  static std::mutex mutex;
  static std::optional<k4a::Api> loaded;
  std::lock_guard lock(mutex);
  if (loaded) return *loaded;
  std::string failure;  // not remembered: the SDK may be installed while a server runs
  std::vector<std::string> names;
  if (const char* env = std::getenv("VOLCAST_K4A_LIBRARY"); env && *env)
    names.emplace_back(env);
  else
    names = {"libk4a.so.1.4", "libk4a.so.1", "libk4a.so"};
  void* lib = nullptr;
  std::string errors;
  for (const auto& n : names) {
    lib = dlopen(n.c_str(), RTLD_NOW | RTLD_LOCAL);
    if (lib) break;
    const char* e = dlerror();
    errors += std::string(errors.empty() ? "" : "; ") + (e ? e : n);
  }
  if (!lib) {
    throw Error(
        "live Azure Kinect cameras need the Azure Kinect Sensor SDK, which is not installed: "
        "install libk4a1.4 (packages.microsoft.com) or point VOLCAST_K4A_LIBRARY at its "
        "libk4a.so (" +
        errors + ")");
  }
  k4a::Api a{};
  const auto bind = [&](auto& fn, const char* name) {
    void* sym = dlsym(lib, name);
    if (!sym) failure = std::string("libk4a lacks ") + name + " (not SDK 1.4?)";
    fn = reinterpret_cast<std::remove_reference_t<decltype(fn)>>(sym);
  };
  bind(a.device_get_installed_count, "k4a_device_get_installed_count");
  bind(a.device_open, "k4a_device_open");
  bind(a.device_close, "k4a_device_close");
  bind(a.device_get_serialnum, "k4a_device_get_serialnum");
  bind(a.device_get_raw_calibration, "k4a_device_get_raw_calibration");
  bind(a.device_start_cameras, "k4a_device_start_cameras");
  bind(a.device_stop_cameras, "k4a_device_stop_cameras");
  bind(a.device_get_capture, "k4a_device_get_capture");
  bind(a.capture_get_depth_image, "k4a_capture_get_depth_image");
  bind(a.capture_get_color_image, "k4a_capture_get_color_image");
  bind(a.capture_release, "k4a_capture_release");
  bind(a.image_release, "k4a_image_release");
  bind(a.image_get_buffer, "k4a_image_get_buffer");
  bind(a.image_get_size, "k4a_image_get_size");
  bind(a.image_get_format, "k4a_image_get_format");
  bind(a.image_get_width_pixels, "k4a_image_get_width_pixels");
  bind(a.image_get_height_pixels, "k4a_image_get_height_pixels");
  bind(a.image_get_stride_bytes, "k4a_image_get_stride_bytes");
  bind(a.image_get_device_timestamp_usec, "k4a_image_get_device_timestamp_usec");
  if (!failure.empty()) {
    dlclose(lib);
    throw Error(failure);
  }
  loaded = a;
  return *loaded;
}

// The URL's parts (k4a_device.hpp).
struct DeviceUrl {
  std::string device;  // index or serial
  k4a::device_configuration_t config{};
  K4aDepthMode mode = K4aDepthMode::kNfovUnbinned;
  double fps = 30;
};

DeviceUrl parse_url(const std::string& url) {
  const auto bad = [&](const std::string& why) {
    return Error("camera '" + url + "': " + why +
                 " (k4a://INDEX|SERIAL?depth=NFOV_UNBINNED&color=MJPG&resolution=720P&fps=30&"
                 "sync=standalone|master|subordinate&delay_us=0)");
  };
  if (!is_k4a_device_url(url)) throw bad("not a k4a:// URL");
  const std::string rest = url.substr(6);
  const size_t q = rest.find('?');
  DeviceUrl u;
  u.device = rest.substr(0, q);
  if (u.device.empty()) throw bad("no device index or serial");
  u.config.color_format = k4a::kColorMjpg;
  u.config.color_resolution = k4a::kColor720p;
  u.config.depth_mode = k4a::kNfovUnbinned;
  u.config.camera_fps = k4a::kFps30;
  u.config.synchronized_images_only = true;
  u.config.wired_sync_mode = k4a::kStandalone;
  std::map<std::string, std::string> params;
  if (q != std::string::npos) {
    std::string query = rest.substr(q + 1);
    for (size_t at = 0; at <= query.size();) {
      const size_t amp = std::min(query.find('&', at), query.size());
      const std::string kv = query.substr(at, amp - at);
      const size_t eq = kv.find('=');
      if (eq == std::string::npos) throw bad("'" + kv + "' is not KEY=VALUE");
      params[kv.substr(0, eq)] = kv.substr(eq + 1);
      at = amp + 1;
    }
  }
  for (const auto& [key, value] : params) {
    if (key == "depth") {
      static const std::map<std::string, std::pair<k4a::depth_mode_t, K4aDepthMode>> modes = {
          {"NFOV_UNBINNED", {k4a::kNfovUnbinned, K4aDepthMode::kNfovUnbinned}},
          {"NFOV_2X2BINNED", {k4a::kNfov2x2Binned, K4aDepthMode::kNfov2x2Binned}},
          {"WFOV_2X2BINNED", {k4a::kWfov2x2Binned, K4aDepthMode::kWfov2x2Binned}},
          {"WFOV_UNBINNED", {k4a::kWfovUnbinned, K4aDepthMode::kWfovUnbinned}}};
      const auto it = modes.find(value);
      if (it == modes.end()) throw bad("unknown depth mode '" + value + "'");
      u.config.depth_mode = it->second.first;
      u.mode = it->second.second;
    } else if (key == "color") {
      if (value == "MJPG") {
        u.config.color_format = k4a::kColorMjpg;
      } else if (value == "BGRA32") {
        u.config.color_format = k4a::kColorBgra32;
      } else if (value == "OFF") {
        u.config.color_resolution = k4a::kColorOff;
        u.config.synchronized_images_only = false;
      } else {
        throw bad("unknown color format '" + value + "'");
      }
    } else if (key == "resolution") {
      static const std::map<std::string, k4a::color_resolution_t> res = {
          {"720P", k4a::kColor720p},   {"1080P", k4a::kColor1080p}, {"1440P", k4a::kColor1440p},
          {"1536P", k4a::kColor1536p}, {"2160P", k4a::kColor2160p}, {"3072P", k4a::kColor3072p}};
      const auto it = res.find(value);
      if (it == res.end()) throw bad("unknown color resolution '" + value + "'");
      if (u.config.color_resolution != k4a::kColorOff) u.config.color_resolution = it->second;
    } else if (key == "fps") {
      if (value == "5") {
        u.config.camera_fps = k4a::kFps5;
        u.fps = 5;
      } else if (value == "15") {
        u.config.camera_fps = k4a::kFps15;
        u.fps = 15;
      } else if (value == "30") {
        u.config.camera_fps = k4a::kFps30;
        u.fps = 30;
      } else {
        throw bad("fps must be 5, 15 or 30");
      }
    } else if (key == "sync") {
      if (value == "standalone")
        u.config.wired_sync_mode = k4a::kStandalone;
      else if (value == "master")
        u.config.wired_sync_mode = k4a::kMaster;
      else if (value == "subordinate")
        u.config.wired_sync_mode = k4a::kSubordinate;
      else
        throw bad("sync must be standalone, master or subordinate");
    } else if (key == "delay_us") {
      if (value.empty() || value.size() > 6 ||
          value.find_first_not_of("0123456789") != std::string::npos)
        throw bad("delay_us must be 0..999999");
      u.config.subordinate_delay_off_master_usec = static_cast<uint32_t>(std::stoul(value));
    } else {
      throw bad("unknown parameter '" + key + "'");
    }
  }
  if (u.fps > 15 &&
      (u.config.depth_mode == k4a::kWfovUnbinned || u.config.color_resolution == k4a::kColor3072p))
    throw bad("WFOV_UNBINNED depth and 3072P color run at 15 fps at most");
  return u;
}

std::pair<int, int> color_size(k4a::color_resolution_t r) {
  switch (r) {
    case k4a::kColor720p:
      return {1280, 720};
    case k4a::kColor1080p:
      return {1920, 1080};
    case k4a::kColor1440p:
      return {2560, 1440};
    case k4a::kColor1536p:
      return {2048, 1536};
    case k4a::kColor2160p:
      return {3840, 2160};
    case k4a::kColor3072p:
      return {4096, 3072};
    default:
      return {0, 0};
  }
}

std::string serial_of(const k4a::Api& a, k4a::device_t d) {
  char serial[64] = {};
  size_t size = sizeof serial;
  if (a.device_get_serialnum(d, serial, &size) != k4a::kBufferSucceeded) return "";
  return std::string(serial, strnlen(serial, sizeof serial));
}

class K4aDeviceSource final : public FrameSource {
 public:
  K4aDeviceSource(const std::string& url, const SourceOptions& options) : url_(url) {
    const DeviceUrl u = parse_url(url);
    const k4a::Api& a = api();
    const uint32_t count = a.device_get_installed_count();
    const bool by_index =
        u.device.find_first_not_of("0123456789") == std::string::npos && u.device.size() < 4;
    std::string serials;
    for (uint32_t i = 0; i < count && !device_; ++i) {
      if (by_index && i != std::stoul(u.device)) continue;
      k4a::device_t d = nullptr;
      if (a.device_open(i, &d) != k4a::kResultSucceeded) {
        serials += (serials.empty() ? "" : ", ") + std::string("#") + std::to_string(i) +
                   " (busy: open in another program?)";
        continue;
      }
      const std::string serial = serial_of(a, d);
      if (by_index || serial == u.device) {
        device_ = d;
        serial_ = serial;
      } else {
        serials += (serials.empty() ? "" : ", ") + serial;
        a.device_close(d);
      }
    }
    if (!device_)
      throw Error("camera '" + url + "': no such Azure Kinect (" + std::to_string(count) +
                  " connected" + (serials.empty() ? "" : ": " + serials) + ")");
    try {
      size_t size = 0;
      a.device_get_raw_calibration(device_, nullptr, &size);
      if (size == 0 || size > (1u << 20))
        throw Error("camera '" + url + "': the device reports no factory calibration");
      std::vector<uint8_t> raw(size);
      if (a.device_get_raw_calibration(device_, raw.data(), &size) != k4a::kBufferSucceeded)
        throw Error("camera '" + url + "': cannot read its factory calibration");
      std::string json(raw.begin(),
                       raw.begin() + static_cast<ptrdiff_t>(std::min(size, raw.size())));
      while (!json.empty() && json.back() == '\0') json.pop_back();
      const K4aCalibration cal = parse_k4a_calibration(json);
      calibration_.depth = k4a_depth_mode_intrinsics(cal.depth, u.mode);
      calibration_.world_from_camera =
          options.world_from_camera.value_or(RigidTransform::identity());
      const auto [cw, ch] = color_size(u.config.color_resolution);
      if (cw > 0) {
        color_ = k4a_color_mode_intrinsics(cal.color, cw, ch);
        registration_.emplace(calibration_.depth, color_, cal.color.camera_from_depth);
      }
      fps_ = u.fps;
      if (a.device_start_cameras(device_, &u.config) != k4a::kResultSucceeded)
        throw Error("camera '" + url + "' (serial " + serial_ +
                    "): the cameras would not start (mode not supported, USB bandwidth, or a "
                    "subordinate without a master's sync signal?)");
    } catch (...) {
      a.device_close(device_);
      throw;
    }
    spdlog::info(
        "Azure Kinect {} (serial {}): started, depth {}x{}, color {}", url, serial_,
        calibration_.depth.width, calibration_.depth.height,
        registration_ ? std::to_string(color_.width) + "x" + std::to_string(color_.height) : "off");
  }

  ~K4aDeviceSource() override {
    const k4a::Api& a = api();
    a.device_stop_cameras(device_);
    a.device_close(device_);
  }

  const CameraCalibration& calibration() const override { return calibration_; }
  double fps() const override { return fps_; }
  int frame_count() const override { return INT_MAX; }
  int color_frame_count() const override { return registration_ ? INT_MAX : 0; }
  std::string description() const override {
    return "Azure Kinect " + serial_ + " (live, " + url_ + ")";
  }

  void next(CameraFrame& out) override {
    const k4a::Api& a = api();
    k4a::capture_t cap = nullptr;
    const k4a::wait_result_t w = a.device_get_capture(device_, &cap, 2000);
    if (w == k4a::kWaitTimeout)
      throw Error("camera " + serial_ + ": no capture within 2 s (a subordinate without sync?)");
    if (w != k4a::kWaitSucceeded) throw Error("camera " + serial_ + ": capture failed");
    struct Releaser {
      const k4a::Api& a;
      k4a::capture_t c;
      k4a::image_t depth = nullptr, color = nullptr;
      ~Releaser() {
        if (depth) a.image_release(depth);
        if (color) a.image_release(color);
        a.capture_release(c);
      }
    } hold{a, cap};
    hold.depth = a.capture_get_depth_image(cap);
    if (!hold.depth) throw Error("camera " + serial_ + ": a capture without depth");
    const Intrinsics& k = calibration_.depth;
    if (a.image_get_format(hold.depth) != k4a::kDepth16 ||
        a.image_get_width_pixels(hold.depth) != k.width ||
        a.image_get_height_pixels(hold.depth) != k.height ||
        a.image_get_stride_bytes(hold.depth) < k.width * 2 ||
        a.image_get_size(hold.depth) <
            static_cast<size_t>(a.image_get_stride_bytes(hold.depth)) * k.height)
      throw Error("camera " + serial_ + ": depth image is not DEPTH16 of the mode's size");
    const uint8_t* d = a.image_get_buffer(hold.depth);
    const size_t stride = static_cast<size_t>(a.image_get_stride_bytes(hold.depth));
    out.depth.width = k.width;
    out.depth.height = k.height;
    out.depth.pixels.resize(static_cast<size_t>(k.width) * k.height);
    for (int y = 0; y < k.height; ++y)  // DEPTH16: little-endian mm, as ours
      std::memcpy(out.depth.pixels.data() + static_cast<size_t>(y) * k.width, d + y * stride,
                  static_cast<size_t>(k.width) * 2);
    out.device_timestamp_us = static_cast<int64_t>(a.image_get_device_timestamp_usec(hold.depth));
    out.color = ColorImage();
    if (!registration_) return;
    hold.color = a.capture_get_color_image(cap);
    if (!hold.color) return;  // this capture has none
    const uint8_t* c = a.image_get_buffer(hold.color);
    const size_t size = a.image_get_size(hold.color);
    const k4a::image_format_t format = a.image_get_format(hold.color);
    if (format == k4a::kColorMjpg) {
      decode_jpeg(std::span(c, size), scratch_);
    } else if (format == k4a::kColorBgra32 &&
               a.image_get_width_pixels(hold.color) == color_.width &&
               a.image_get_height_pixels(hold.color) == color_.height &&
               a.image_get_stride_bytes(hold.color) == color_.width * 4 &&
               size >= static_cast<size_t>(color_.width) * color_.height * 4) {
      scratch_ = ColorImage(color_.width, color_.height);
      std::memcpy(scratch_.bgra.data(), c, scratch_.bgra.size());
    } else {
      throw Error("camera " + serial_ + ": color image is neither MJPG nor BGRA32 of its size");
    }
    if (scratch_.width != color_.width || scratch_.height != color_.height)
      throw Error("camera " + serial_ + ": color image is not of the configured resolution");
    registration_->apply(out.depth, scratch_, out.color);
  }

 private:
  std::string url_, serial_;
  k4a::device_t device_ = nullptr;
  CameraCalibration calibration_;
  Intrinsics color_;
  std::optional<ColorToDepthRegistration> registration_;
  double fps_ = 30;
  ColorImage scratch_;
};

}  // namespace

bool is_k4a_device_url(const std::string& name) {
  return name.rfind("k4a://", 0) == 0;
}

std::unique_ptr<FrameSource> open_k4a_device(const std::string& url, const SourceOptions& options) {
  return std::make_unique<K4aDeviceSource>(url, options);
}

}  // namespace volcast
