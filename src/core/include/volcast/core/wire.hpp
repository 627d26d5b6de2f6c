#pragma once
// Little-endian field writing and bounds-checked reading for the protocol's payloads
// (protocol.hpp's conventions: strings are u16 length + UTF-8 bytes, byte strings u32 length +
// bytes, numbers in the host's little-endian layout). Shared by the stream and session messages.
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/core/error.hpp"

namespace volcast::protocol {

/// Appends fields to `out`. Throws Error("protocol: string too long") for a string over 65535
/// bytes.
class Writer {
 public:
  explicit Writer(std::vector<uint8_t>& out) : out_(out) {}
  template <typename T>
  void put(T v) {
    append(&v, sizeof(T));  // host is little-endian (x86-64, ARM64 Linux)
  }
  void put_string(const std::string& s) {
    if (s.size() > 0xffff) throw Error("protocol: string too long");
    put<uint16_t>(static_cast<uint16_t>(s.size()));
    append(s.data(), s.size());
  }
  void put_bytes(std::span<const uint8_t> b) {
    put<uint32_t>(static_cast<uint32_t>(b.size()));
    append(b.data(), b.size());
  }
  void append(const void* data, size_t n) {
    if (n == 0) return;
    const size_t at = out_.size();
    out_.resize(at + n);
    std::memcpy(out_.data() + at, data, n);
  }

 private:
  std::vector<uint8_t>& out_;
};

/// Reads fields from `in` without ever reading past it: a short payload throws
/// Error("malformed <what>: truncated"), fail() throws Error("malformed <what>: <why>").
class Reader {
 public:
  Reader(std::span<const uint8_t> in, const char* what) : in_(in), what_(what) {}
  template <typename T>
  T get() {
    need(sizeof(T));
    T v;
    std::memcpy(&v, in_.data() + pos_, sizeof(T));
    pos_ += sizeof(T);
    return v;
  }
  std::string get_string() {
    const size_t n = get<uint16_t>();
    need(n);
    std::string s(reinterpret_cast<const char*>(in_.data() + pos_), n);
    pos_ += n;
    return s;
  }
  std::span<const uint8_t> get_span() {
    const size_t n = get<uint32_t>();
    need(n);
    const auto s = in_.subspan(pos_, n);
    pos_ += n;
    return s;
  }
  /// Bytes not read yet.
  size_t remaining() const { return in_.size() - pos_; }
  void expect_end() const {
    if (pos_ != in_.size()) fail("trailing bytes");
  }
  [[noreturn]] void fail(const std::string& why) const {
    throw Error(std::string("malformed ") + what_ + ": " + why);
  }

 private:
  void need(size_t n) const {
    if (n > in_.size() - pos_) fail("truncated");
  }
  std::span<const uint8_t> in_;
  size_t pos_ = 0;
  const char* what_;
};

/// A camera's calibration as the Welcome carries it (protocol.hpp 0.2): width u16, height u16, the
/// 15 intrinsics fx fy cx cy k1..k6 p1 p2 codx cody metric_radius (f64), rotation (9 f64,
/// row-major) and translation (3 f64, metres) of the pose.
void put_calibration(Writer& w, const CameraCalibration& c);
/// Reads what put_calibration wrote. Checks only what any calibration needs (a non-empty size, a
/// positive focal length, finite numbers, a rotation); the caller bounds the size.
CameraCalibration get_calibration(Reader& r);

}  // namespace volcast::protocol
