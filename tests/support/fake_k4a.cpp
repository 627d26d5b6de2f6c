// A stand-in for the Azure Kinect Sensor SDK's libk4a (the functions volcast's live source binds,
// with the SDK 1.4 signatures): "devices" that serve the real k4arecorder recording named by
// VOLCAST_FAKE_K4A_RECORDING -- its factory calibration as the raw calibration, its DEPTH track as
// DEPTH16 images and its MJPG COLOR track as color images, looping, paced at the configured rate
// -- so that everything but the USB device is exercised. VOLCAST_FAKE_K4A_DEVICES sets how many
// devices there are (default 1; serials 000000000001, ...). VOLCAST_FAKE_K4A_LOG, if set, names a
// file each call to start_cameras appends "SERIAL depth_mode color_format color_resolution fps
// sync delay" to.
extern "C" {
#include <libavformat/avformat.h>
}

#include <chrono>
#include <cstdint>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

namespace {

struct Frame {
  std::vector<uint8_t> depth;  // little-endian DEPTH16, 640x576
  std::vector<uint8_t> color;  // one JPEG
};

struct Recording {
  std::string calibration;
  int width = 0, height = 0;
  std::vector<Frame> frames;
};

const Recording* recording() {
  static std::once_flag once;
  static Recording r;
  std::call_once(once, [] {
    const char* path = std::getenv("VOLCAST_FAKE_K4A_RECORDING");
    AVFormatContext* f = nullptr;
    if (!path || avformat_open_input(&f, path, nullptr, nullptr) < 0) return;
    avformat_find_stream_info(f, nullptr);
    int depth = -1, color = -1;
    for (unsigned i = 0; i < f->nb_streams; ++i) {
      AVStream* s = f->streams[i];
      const AVDictionaryEntry* title = av_dict_get(s->metadata, "title", nullptr, 0);
      const AVDictionaryEntry* name = av_dict_get(s->metadata, "filename", nullptr, 0);
      if (name && std::strcmp(name->value, "calibration.json") == 0 && s->codecpar->extradata)
        r.calibration.assign(reinterpret_cast<const char*>(s->codecpar->extradata),
                             static_cast<size_t>(s->codecpar->extradata_size));
      if (title && std::strcmp(title->value, "DEPTH") == 0) {
        depth = static_cast<int>(i);
        r.width = s->codecpar->width;
        r.height = s->codecpar->height;
      }
      if (title && std::strcmp(title->value, "COLOR") == 0) color = static_cast<int>(i);
    }
    AVPacket* p = av_packet_alloc();
    std::vector<uint8_t> last_color;
    while (av_read_frame(f, p) >= 0) {
      if (p->stream_index == color) last_color.assign(p->data, p->data + p->size);
      if (p->stream_index == depth) {
        Frame fr;
        fr.depth.resize(static_cast<size_t>(p->size));
        for (int i = 0; i + 1 < p->size; i += 2) {  // b16g is big-endian, DEPTH16 little-endian
          fr.depth[i] = p->data[i + 1];
          fr.depth[i + 1] = p->data[i];
        }
        r.frames.push_back(std::move(fr));
      }
      av_packet_unref(p);
    }
    // Color packets may come after their depth packet: pair the last color with every frame.
    for (auto& fr : r.frames) fr.color = last_color;
    av_packet_free(&p);
    avformat_close_input(&f);
  });
  return r.frames.empty() ? nullptr : &r;
}

struct Device {
  uint32_t index = 0;
  bool started = false;
  int fps = 30;
  bool color = true;
  uint64_t next = 0;  // frames served
  std::chrono::steady_clock::time_point start;
};

struct Image {
  std::vector<uint8_t> bytes;
  int format = 0, width = 0, height = 0, stride = 0;
  uint64_t timestamp_us = 0;
};

struct Capture {
  Image* depth = nullptr;
  Image* color = nullptr;
};

struct Config {  // k4a_device_configuration_t
  int color_format, color_resolution, depth_mode, camera_fps;
  bool synchronized_images_only;
  int32_t depth_delay_off_color_usec;
  int wired_sync_mode;
  uint32_t subordinate_delay_off_master_usec;
  bool disable_streaming_indicator;
};

uint32_t device_count() {
  const char* n = std::getenv("VOLCAST_FAKE_K4A_DEVICES");
  return n ? static_cast<uint32_t>(std::atoi(n)) : 1u;
}

std::string serial(uint32_t index) {
  char s[16];
  std::snprintf(s, sizeof s, "%012u", index + 1);
  return s;
}

}  // namespace

extern "C" {

uint32_t k4a_device_get_installed_count() {
  return recording() ? device_count() : 0;
}

int k4a_device_open(uint32_t index, void** device) {
  if (!recording() || index >= device_count() || !device) return 1;
  *device = new Device{index};
  return 0;
}

void k4a_device_close(void* device) {
  delete static_cast<Device*>(device);
}

int k4a_device_get_serialnum(void* device, char* out, size_t* size) {
  const std::string s = serial(static_cast<Device*>(device)->index);
  if (!out || *size < s.size() + 1) {
    *size = s.size() + 1;
    return 2;
  }
  std::memcpy(out, s.c_str(), s.size() + 1);
  *size = s.size() + 1;
  return 0;
}

int k4a_device_get_raw_calibration(void*, uint8_t* out, size_t* size) {
  const std::string& c = recording()->calibration;
  if (!out || *size < c.size() + 1) {
    *size = c.size() + 1;
    return 2;
  }
  std::memcpy(out, c.c_str(), c.size() + 1);
  *size = c.size() + 1;
  return 0;
}

int k4a_device_start_cameras(void* device, const Config* config) {
  Device* d = static_cast<Device*>(device);
  if (config->depth_mode != 2) return 1;  // the recording is NFOV unbinned
  if (config->color_resolution != 0 && (config->color_format != 0 || config->color_resolution != 1))
    return 1;  // and MJPG 720p
  d->fps = config->camera_fps == 0 ? 5 : config->camera_fps == 1 ? 15 : 30;
  d->color = config->color_resolution != 0;
  d->started = true;
  d->start = std::chrono::steady_clock::now();
  if (const char* log = std::getenv("VOLCAST_FAKE_K4A_LOG")) {
    if (FILE* f = std::fopen(log, "a")) {
      std::fprintf(f, "%s %d %d %d %d %d %u\n", serial(d->index).c_str(), config->depth_mode,
                   config->color_format, config->color_resolution, config->camera_fps,
                   config->wired_sync_mode, config->subordinate_delay_off_master_usec);
      std::fclose(f);
    }
  }
  return 0;
}

void k4a_device_stop_cameras(void* device) {
  static_cast<Device*>(device)->started = false;
}

int k4a_device_get_capture(void* device, void** capture, int32_t timeout_ms) {
  Device* d = static_cast<Device*>(device);
  if (!d->started) return 1;
  const auto due =
      d->start + std::chrono::microseconds(static_cast<int64_t>(d->next) * 1000000 / d->fps);
  if (due - std::chrono::steady_clock::now() > std::chrono::milliseconds(timeout_ms)) return 2;
  std::this_thread::sleep_until(due);
  const Recording* r = recording();
  const Frame& f = r->frames[d->next % r->frames.size()];
  const uint64_t t = d->next * 1000000 / static_cast<uint64_t>(d->fps) + 200000;
  auto* c = new Capture;
  c->depth = new Image{f.depth, 4, r->width, r->height, r->width * 2, t};
  if (d->color && !f.color.empty()) c->color = new Image{f.color, 0, 1280, 720, 0, t};
  ++d->next;
  *capture = c;
  return 0;
}

void* k4a_capture_get_depth_image(void* capture) {
  Capture* c = static_cast<Capture*>(capture);
  Image* i = c->depth;
  c->depth = nullptr;  // the caller releases what it gets
  return i;
}

void* k4a_capture_get_color_image(void* capture) {
  Capture* c = static_cast<Capture*>(capture);
  Image* i = c->color;
  c->color = nullptr;
  return i;
}

void k4a_capture_release(void* capture) {
  Capture* c = static_cast<Capture*>(capture);
  delete c->depth;
  delete c->color;
  delete c;
}

void k4a_image_release(void* image) {
  delete static_cast<Image*>(image);
}
uint8_t* k4a_image_get_buffer(void* image) {
  return static_cast<Image*>(image)->bytes.data();
}
size_t k4a_image_get_size(void* image) {
  return static_cast<Image*>(image)->bytes.size();
}
int k4a_image_get_format(void* image) {
  return static_cast<Image*>(image)->format;
}
int k4a_image_get_width_pixels(void* image) {
  return static_cast<Image*>(image)->width;
}
int k4a_image_get_height_pixels(void* image) {
  return static_cast<Image*>(image)->height;
}
int k4a_image_get_stride_bytes(void* image) {
  return static_cast<Image*>(image)->stride;
}
uint64_t k4a_image_get_device_timestamp_usec(void* image) {
  return static_cast<Image*>(image)->timestamp_us;
}

}  // extern "C"
