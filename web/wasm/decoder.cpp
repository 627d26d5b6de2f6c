// The browser viewer's decoder: Volcast's pure depth codecs (raw, rvl, trvl, volcast and its
// variants; the same sources as the native build) and the lens model's ray table, compiled to
// WebAssembly by Debian's Emscripten (web/CMakeLists.txt). Zstd, LZ4 and the video codecs are not
// in it: a browser viewer asks for a tier with one of these depth codecs.
//
// C interface (called from web/worker.js through the Emscripten module; pointers are offsets into
// the module's memory, owned by the caller unless said otherwise):
//   vc_decode_depth(camera, data, bytes) -> pixels decoded (width * height), or -1 on an error
//     (vc_last_error() says which). Each camera 0..63 has its own decoder (temporal codecs keep
//     the last frame); the codec is picked from the frame header's codec id (byte 3).
//   vc_last_pixels(), vc_last_width(), vc_last_height(): the last frame decoded, uint16 depth in
//     mm, row-major, in the module's memory until the next vc_decode_depth.
//   vc_reset(camera): forgets that camera's decoder (after a stream change).
//   vc_ray_table(intrinsics, out) -> 0, or -1 (vc_last_error()): `intrinsics` is 17 doubles
//     (width, height, fx, fy, cx, cy, k1..k6, p1, p2, codx, cody, metric_radius, as the protocol's
//     Welcome carries them); `out` gets width * height * 2 floats (X/Z, Y/Z per pixel; NaN where
//     the lens has no ray), volcast/core/ray_table.hpp.
//   vc_balance_camera(camera, intrinsics, pose) -> 0, or -1 (vc_last_error()): camera 0..63's
//     intrinsics (17 doubles, as vc_ray_table) and world_from_camera (12 doubles: the rotation
//     row-major, then the translation in metres, as the Welcome carries them), for colour balance.
//   vc_balance_take(camera, depth, rgba) -> samples kept, or -1: that camera's colour balance
//     samples from one registered frame (depth: width * height uint16 mm; rgba: width * height
//     * 4 bytes), replacing its last (volcast/render/colour_balance.hpp, the native renderer's).
//   vc_balance_gains(count, out) -> 0, or -1: the colour gains of cameras 0..count-1 from their
//     samples (a camera without any keeps 1); `out` gets count * 3 floats, RGB.
//   vc_last_error(): a NUL-terminated message, valid until the next call.
#include <cstdint>
#include <cstring>
#include <memory>
#include <span>
#include <string>

#include "../../src/codec/builtin_codecs.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/ray_table.hpp"
#include "volcast/render/colour_balance.hpp"

namespace {

constexpr int kMaxCameras = 64;
std::unique_ptr<volcast::DepthDecoder> decoders[kMaxCameras];
uint8_t decoder_ids[kMaxCameras];
volcast::DepthImage image;
std::string last_error;
volcast::ColourSamples balance[kMaxCameras];
volcast::CameraFrame balance_frame;  // reused: the frame vc_balance_take samples

// Intrinsics from 17 doubles (width, height, fx, fy, cx, cy, k1..k6, p1, p2, codx, cody,
// metric_radius); false (last_error set) when the size is out of range.
bool parse_intrinsics(const double* k, volcast::Intrinsics& in) {
  in.width = static_cast<int>(k[0]);
  in.height = static_cast<int>(k[1]);
  double* fields[] = {&in.fx, &in.fy, &in.cx, &in.cy, &in.k1,   &in.k2,   &in.k3,           &in.k4,
                      &in.k5, &in.k6, &in.p1, &in.p2, &in.codx, &in.cody, &in.metric_radius};
  for (int i = 0; i < 15; ++i) *fields[i] = k[2 + i];
  if (in.width < 1 || in.height < 1 || in.width > 4096 || in.height > 4096) {
    last_error = "camera size out of range";
    return false;
  }
  return true;
}

std::unique_ptr<volcast::DepthDecoder> make_decoder(uint8_t id) {
  switch (id) {
    case 0:
      return volcast::detail::make_raw_depth_decoder();
    case 1:
      return volcast::detail::make_rvl_decoder();
    case 2:
      return volcast::detail::make_trvl_decoder();
    case 5:
      return volcast::detail::make_volcast_decoder();
    default:
      return nullptr;
  }
}

}  // namespace

extern "C" {

const char* vc_last_error() {
  return last_error.c_str();
}
int vc_last_width() {
  return image.width;
}
int vc_last_height() {
  return image.height;
}

void vc_reset(int camera) {
  if (camera >= 0 && camera < kMaxCameras) decoders[camera].reset();
}

const uint16_t* vc_last_pixels() {
  return image.pixels.data();
}

int vc_decode_depth(int camera, const uint8_t* data, int bytes) {
  if (camera < 0 || camera >= kMaxCameras) {
    last_error = "camera index out of range";
    return -1;
  }
  if (bytes < 12) {
    last_error = "depth stream truncated: shorter than its 12-byte header";
    return -1;
  }
  const uint8_t id = data[3];
  if (!decoders[camera] || decoder_ids[camera] != id) {
    decoders[camera] = make_decoder(id);
    decoder_ids[camera] = id;
    if (!decoders[camera]) {
      last_error = "depth codec id " + std::to_string(id) +
                   " is not in the browser's decoder (raw, rvl, trvl, volcast*)";
      return -1;
    }
  }
  try {
    decoders[camera]->decode(std::span(data, static_cast<size_t>(bytes)), image);
  } catch (const volcast::Error& e) {
    last_error = e.what();
    return -1;
  }
  return static_cast<int>(image.pixels.size());
}

int vc_ray_table(const double* k, float* out) {
  volcast::Intrinsics in;
  if (!parse_intrinsics(k, in)) {
    last_error = "ray table: " + last_error;
    return -1;
  }
  const volcast::RayTable t = volcast::make_ray_table(in);
  for (size_t i = 0; i < t.x.size(); ++i) {
    out[2 * i] = t.x[i];
    out[2 * i + 1] = t.y[i];
  }
  return 0;
}

int vc_balance_camera(int camera, const double* k, const double* pose) {
  if (camera < 0 || camera >= kMaxCameras) {
    last_error = "colour balance: camera index out of range";
    return -1;
  }
  volcast::ColourSamples s;
  if (!parse_intrinsics(k, s.intrinsics)) {
    last_error = "colour balance: " + last_error;
    return -1;
  }
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) s.world_from_camera.rotation(r, c) = pose[3 * r + c];
    s.world_from_camera.translation[r] = pose[9 + r];
  }
  s.rays = volcast::shared_ray_table(s.intrinsics);
  balance[camera] = std::move(s);
  return 0;
}

int vc_balance_take(int camera, const uint16_t* depth, const uint8_t* rgba) {
  if (camera < 0 || camera >= kMaxCameras || !balance[camera].rays) {
    last_error = "colour balance: camera " + std::to_string(camera) + " has no calibration";
    return -1;
  }
  volcast::ColourSamples& s = balance[camera];
  const int w = s.intrinsics.width, h = s.intrinsics.height;
  const size_t n = static_cast<size_t>(w) * static_cast<size_t>(h);
  if (balance_frame.depth.width != w || balance_frame.depth.height != h) {
    balance_frame.depth = volcast::DepthImage(w, h);
    balance_frame.color = volcast::ColorImage(w, h);
  }
  std::memcpy(balance_frame.depth.pixels.data(), depth, n * sizeof(uint16_t));
  uint8_t* bgra = balance_frame.color.bgra.data();
  for (size_t i = 0; i < 4 * n; i += 4) {
    bgra[i] = rgba[i + 2];
    bgra[i + 1] = rgba[i + 1];
    bgra[i + 2] = rgba[i];
    bgra[i + 3] = rgba[i + 3];
  }
  try {
    volcast::take_colour_samples(balance_frame, s);
  } catch (const volcast::Error& e) {
    last_error = e.what();
    return -1;
  }
  return static_cast<int>(s.depth_mm.size());
}

int vc_balance_gains(int count, float* out) {
  if (count < 0 || count > kMaxCameras) {
    last_error = "colour balance: camera count out of range";
    return -1;
  }
  try {
    const auto gains = volcast::colour_gains(std::span(balance, static_cast<size_t>(count)));
    for (size_t i = 0; i < gains.size(); ++i)
      for (int c = 0; c < 3; ++c) out[3 * i + static_cast<size_t>(c)] = gains[i][c];
  } catch (const volcast::Error& e) {
    last_error = e.what();
    return -1;
  }
  return 0;
}

}  // extern "C"
