#include "volcast/core/jpeg.hpp"

#include <turbojpeg.h>

#include <memory>
#include <string>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

struct TjDeleter {
  void operator()(void* h) const { tjDestroy(h); }
};
using TjHandle = std::unique_ptr<void, TjDeleter>;

// TurboJPEG handles are not thread-safe but cheap to keep per thread.
tjhandle decompressor() {
  thread_local TjHandle handle(tjInitDecompress());
  if (!handle) throw Error("cannot initialise the JPEG decoder");
  return handle.get();
}
tjhandle compressor() {
  thread_local TjHandle handle(tjInitCompress());
  if (!handle) throw Error("cannot initialise the JPEG encoder");
  return handle.get();
}

}  // namespace

void decode_jpeg(std::span<const uint8_t> jpeg, ColorImage& out) {
  tjhandle tj = decompressor();
  int w = 0, h = 0, subsamp = 0, colorspace = 0;
  if (jpeg.empty() || tjDecompressHeader3(tj, jpeg.data(), static_cast<unsigned long>(jpeg.size()),
                                          &w, &h, &subsamp, &colorspace) != 0)
    throw Error(std::string("corrupt JPEG: ") + (jpeg.empty() ? "no data" : tjGetErrorStr2(tj)));
  if (w <= 0 || h <= 0 || w > kMaxImageSide || h > kMaxImageSide)
    throw Error("JPEG claims " + std::to_string(w) + "x" + std::to_string(h) +
                " pixels, more than the " + std::to_string(kMaxImageSide) + " per side accepted");
  if (out.width != w || out.height != h) out = ColorImage(w, h);
  // Warnings too ("Premature end of JPEG file": truncated data decodes as a grey tail otherwise).
  if (tjDecompress2(tj, jpeg.data(), static_cast<unsigned long>(jpeg.size()), out.bgra.data(), w, 0,
                    h, TJPF_BGRA, TJFLAG_FASTDCT | TJFLAG_STOPONWARNING) != 0)
    throw Error(std::string("corrupt JPEG: ") + tjGetErrorStr2(tj));
}

void jpeg_size(std::span<const uint8_t> jpeg, int& width, int& height) {
  tjhandle tj = decompressor();
  int subsamp = 0, colorspace = 0;
  if (jpeg.empty() || tjDecompressHeader3(tj, jpeg.data(), static_cast<unsigned long>(jpeg.size()),
                                          &width, &height, &subsamp, &colorspace) != 0)
    throw Error(std::string("corrupt JPEG: ") + tjGetErrorStr2(tj));
  if (width <= 0 || height <= 0) throw Error("corrupt JPEG: no frame header");
}

void encode_jpeg(const ColorImage& image, int quality, std::vector<uint8_t>& out) {
  tjhandle tj = compressor();
  const unsigned long bound = tjBufSize(image.width, image.height, TJSAMP_420);
  out.resize(bound);
  unsigned char* dst = out.data();
  unsigned long size = bound;
  if (tjCompress2(tj, image.bgra.data(), image.width, 0, image.height, TJPF_BGRA, &dst, &size,
                  TJSAMP_420, quality, TJFLAG_NOREALLOC | TJFLAG_FASTDCT) != 0)
    throw Error(std::string("JPEG encoding failed: ") + tjGetErrorStr2(tj));
  out.resize(size);
}

}  // namespace volcast
