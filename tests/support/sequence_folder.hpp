#pragma once
// Test image-sequence folders built from the real hands sequence: symlinks to its first frames in
// a temporary folder (the data is never copied), with chosen files left out or replaced by bad
// ones, and a capture of what is logged.
#include <fmt/format.h>
#include <spdlog/sinks/ostream_sink.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <memory>
#include <set>
#include <sstream>
#include <string>

#include "support/test_data.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/image_io.hpp"

namespace volcast::test {

/// A hands depth or color file by frame index (the set's names are 00000.png / 00000.jpg ...).
inline std::filesystem::path hands_depth(int index) {
  return hands_dir() / "depth" / fmt::format("{:05d}.png", index);
}
inline std::filesystem::path hands_color(int index) {
  return hands_dir() / "color" / fmt::format("{:05d}.jpg", index);
}

/// A folder `dir` (made fresh) of symlinks to hands frames 0..frames-1: depth/ always, color/
/// if `color`, leaving out the color files of `no_color`. Returns `dir`.
inline std::filesystem::path hands_sequence(const std::filesystem::path& dir, int frames,
                                            bool color, const std::set<int>& no_color = {}) {
  namespace fs = std::filesystem;
  fs::remove_all(dir);
  fs::create_directories(dir / "depth");
  if (color) fs::create_directories(dir / "color");
  for (int i = 0; i < frames; ++i) {
    fs::create_symlink(hands_depth(i), dir / "depth" / hands_depth(i).filename());
    if (color && !no_color.count(i))
      fs::create_symlink(hands_color(i), dir / "color" / hands_color(i).filename());
  }
  return dir;
}

/// Ways a depth frame can be unreadable.
enum class BadDepth { kTruncated, kEightBit, kOtherSize };

inline const char* name_of(BadDepth b) {
  return b == BadDepth::kTruncated ? "truncated" : b == BadDepth::kEightBit ? "eight_bit" : "size";
}

/// Replaces depth frame `index` of a hands_sequence folder by a bad file (a regular file where the
/// symlink was): the real PNG cut in half, an 8-bit RGBA PNG of the right size, or a valid 16-bit
/// PNG of another size. Returns its path.
inline std::filesystem::path break_depth(const std::filesystem::path& dir, int index,
                                         BadDepth how) {
  const std::filesystem::path file = dir / "depth" / hands_depth(index).filename();
  std::filesystem::remove(file);
  if (how == BadDepth::kTruncated) {
    std::ifstream in(hands_depth(index), std::ios::binary);
    const std::string bytes((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    std::ofstream(file, std::ios::binary)
        .write(bytes.data(), static_cast<std::streamsize>(bytes.size() / 2));
  } else if (how == BadDepth::kEightBit) {
    write_color_png(file, ColorImage(640, 360));
  } else {
    write_depth_png(file, DepthImage(320, 180));
  }
  return file;
}

/// Writes a synthetic (labelled) 16-bit grayscale PNG of 57 bytes whose header claims
/// `width` x `height` pixels: signature, a valid IHDR (with its CRC), an empty IDAT, IEND.
inline void write_png_header_claiming(const std::filesystem::path& file, uint32_t width,
                                      uint32_t height) {
  auto crc32 = [](const std::string& bytes) {
    uint32_t c = 0xffffffffu;
    for (const char ch : bytes) {
      c ^= static_cast<uint8_t>(ch);
      for (int k = 0; k < 8; ++k) c = (c >> 1) ^ (0xedb88320u & (0u - (c & 1u)));
    }
    return ~c;
  };
  auto be32 = [](uint32_t v) {
    return std::string{static_cast<char>(v >> 24), static_cast<char>(v >> 16),
                       static_cast<char>(v >> 8), static_cast<char>(v)};
  };
  auto chunk = [&](const std::string& type, const std::string& data) {
    return be32(static_cast<uint32_t>(data.size())) + type + data + be32(crc32(type + data));
  };
  const std::string ihdr = be32(width) + be32(height) + std::string{16, 0, 0, 0, 0};
  const std::string png = std::string("\x89PNG\r\n\x1a\n", 8) + chunk("IHDR", ihdr) +
                          chunk("IDAT", "") + chunk("IEND", "");
  std::ofstream(file, std::ios::binary).write(png.data(), static_cast<std::streamsize>(png.size()));
}

/// Copies of everything the default logger writes while it lives.
class LogCapture {
 public:
  LogCapture() : sink_(std::make_shared<spdlog::sinks::ostream_sink_mt>(text_)) {
    spdlog::default_logger()->sinks().push_back(sink_);
  }
  ~LogCapture() {
    auto& sinks = spdlog::default_logger()->sinks();
    sinks.erase(std::remove(sinks.begin(), sinks.end(), sink_), sinks.end());
  }
  LogCapture(const LogCapture&) = delete;
  LogCapture& operator=(const LogCapture&) = delete;
  /// How often `what` was logged (occurrences in the text), once the writers have stopped.
  int count(const std::string& what) const {
    const std::string s = text_.str();
    int n = 0;
    for (size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + what.size()))
      ++n;
    return n;
  }
  std::string text() const { return text_.str(); }

 private:
  std::ostringstream text_;
  std::shared_ptr<spdlog::sinks::ostream_sink_mt> sink_;
};

/// Options for a hands-derived folder: the nominal intrinsics (the set has none) at `fps`.
inline SourceOptions hands_options(double fps) {
  SourceOptions opt;
  opt.intrinsics = Intrinsics{0, 0, 460, 460, 320, 180};
  opt.fps = fps;
  return opt;
}

}  // namespace volcast::test
