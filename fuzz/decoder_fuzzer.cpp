// libFuzzer target for one decoder, chosen at build time (decoder_target.hpp: fuzz::kKind, depth,
// color or protocol; fuzz::kCodec, the codec name). Two inputs per run:
//  1. the fuzz bytes as a stream, decoded as they are;
//  2. a small image made from the fuzz bytes, encoded by the matching encoder, then corrupted at
//     positions and with masks taken from the bytes, and decoded - so mutations reach deep into a
//     well-formed stream without a seed corpus.
// A decoder may throw volcast::Error; anything else (a crash, a sanitizer report, another
// exception) is a finding. Run by scripts/fuzz.sh.
#include <algorithm>
#include <cstddef>
#include <cstdint>
#include <span>
#include <vector>

#include "decoder_target.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/codec_video/video_codecs.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/protocol/frame_set.hpp"
#include "volcast/net/protocol/join.hpp"
#include "volcast/net/stream/seal.hpp"

namespace {

using namespace volcast;

void corrupt(std::vector<uint8_t>& bytes, const uint8_t* data, size_t size) {
  if (bytes.empty()) return;
  for (size_t k = 2; k + 2 < size && k < 2 + 3 * 8; k += 3) {
    const size_t at = (size_t{data[k]} << 8 | data[k + 1]) % bytes.size();
    bytes[at] ^= data[k + 2];
  }
  if (size > 1 && data[1] % 7 == 0) bytes.resize(bytes.size() - data[1] % bytes.size());
}

void fuzz_depth(const uint8_t* data, size_t size) {
  DepthImage out;
  try {
    make_depth_decoder(fuzz::kCodec)->decode({data, size}, out);
  } catch (const Error&) {
  }
  if (size < 4) return;
  const int w = 1 + data[0] % 40, h = 1 + data[1] % 30;
  DepthImage image(w, h);
  for (size_t i = 0; i < image.size(); ++i) {
    const uint8_t b = data[(i + 2) % size];
    image.pixels[i] = b % 5 == 0 ? 0 : static_cast<uint16_t>(500 + b * (1 + data[3] % 64));
  }
  auto enc = make_depth_encoder(fuzz::kCodec);
  auto dec = make_depth_decoder(fuzz::kCodec);
  std::vector<uint8_t> key, delta;
  enc->encode(image, true, key);
  image.pixels[data[2] % image.size()] ^= 0x55;
  enc->encode(image, false, delta);
  corrupt(size % 2 ? key : delta, data, size);
  try {
    dec->decode(key, out);
    dec->decode(delta, out);
  } catch (const Error&) {
  }
}

void fuzz_color(const uint8_t* data, size_t size) {
  ColorImage out;
  try {
    make_color_decoder(fuzz::kCodec)->decode({data, size}, out);
  } catch (const Error&) {
  }
  if (size < 4) return;
  const int w = 2 * (1 + data[0] % 20), h = 2 * (1 + data[1] % 16);
  ColorImage image(w, h);
  for (size_t i = 0; i < image.bgra.size(); ++i) image.bgra[i] = data[(i + 2) % size];
  auto enc = make_color_encoder(fuzz::kCodec);
  auto dec = make_color_decoder(fuzz::kCodec);
  std::vector<uint8_t> bytes;
  enc->encode(image, true, bytes);
  corrupt(bytes, data, size);
  try {
    dec->decode(bytes, out);
  } catch (const Error&) {
  }
}

void fuzz_protocol(const uint8_t* data, size_t size) {
  const std::span<const uint8_t> bytes(data, size);
  auto attempt = [](auto&& parse) {
    try {
      parse();
    } catch (const Error&) {
    }
  };
  attempt([&] { protocol::parse_header(bytes); });
  attempt([&] { protocol::hello_token(bytes); });
  attempt([&] { protocol::parse_hello(bytes); });
  const std::string_view text(reinterpret_cast<const char*>(data), size);
  attempt([&] { parse_join_link(text); });
  attempt([&] { parse_join_token(text); });
  attempt([&] { parse_fingerprint(text); });
  attempt([&] { protocol::parse_welcome(bytes); });
  attempt([&] { protocol::parse_reject(bytes); });
  attempt([&] { protocol::parse_ack(bytes); });
  attempt([&] {
    protocol::FrameSetView set;
    protocol::parse_frame_set(bytes, set);
  });
  // The same bytes through every receiver's path (frame_set.hpp): read, sizes, decode.
  attempt([&] {
    static FrameSetDecoder decoder = [] {
      protocol::CameraInfo camera;
      camera.calibration.depth.width = 64;
      camera.calibration.depth.height = 48;
      camera.calibration.depth.fx = camera.calibration.depth.fy = 50;
      return FrameSetDecoder("raw", "raw", {camera});
    }();
    FrameSet frames;
    decoder.decode(bytes, frames);
  });
  attempt([&] {
    protocol::SealedFrameSet seal;
    protocol::parse_sealed_frame_set(bytes, seal);
  });
  // A sealed frame set: the first byte's length of descriptor, then what follows it outside TLS
  // (padded or cut to the body length it declares, up to 1 MiB), opened as a viewer does.
  attempt([&] {
    if (size < 1) return;
    const size_t n = std::min<size_t>(size - 1, size_t{data[0]} * 48 + 32);
    protocol::SealedFrameSet seal;
    protocol::parse_sealed_frame_set(bytes.subspan(1, n), seal);
    if (seal.body_bytes > (1u << 20)) return;
    std::vector<uint8_t> body(bytes.begin() + 1 + static_cast<std::ptrdiff_t>(n), bytes.end());
    body.resize(seal.body_bytes);
    open_sealed(seal, body, nullptr);
  });
}

}  // namespace

// The video codecs join the codec table once, before the first input.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  volcast::register_video_codecs();
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string_view kind = volcast::fuzz::kKind;
  if (kind == "depth") fuzz_depth(data, size);
  if (kind == "color") fuzz_color(data, size);
  if (kind == "protocol") fuzz_protocol(data, size);
  return 0;
}
