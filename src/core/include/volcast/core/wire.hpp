#pragma once
// The one wire codec: little-endian field writing and bounds-checked reading for every format
// Volcast puts on a wire or in a file (the protocol's messages, the session channel, the cluster's
// chunks and session pieces, recordings). Numbers are little-endian whatever the host (assembled
// byte by byte), f32/f64 IEEE-754; strings are u16 length + UTF-8 bytes, byte strings u32 length +
// bytes.
#include <bit>
#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <type_traits>
#include <vector>

#include "volcast/core/error.hpp"

namespace volcast::wire {

/// The unsigned integer of T's size (T: an integer, an enum or a float/double of 1, 2, 4 or 8
/// bytes).
template <typename T>
using Bits =
    std::conditional_t<sizeof(T) == 1, uint8_t,
                       std::conditional_t<sizeof(T) == 2, uint16_t,
                                          std::conditional_t<sizeof(T) == 4, uint32_t, uint64_t>>>;

/// What the codec reads and writes as a number: an integer, enum, float or double of 1, 2, 4 or
/// 8 bytes.
template <typename T>
concept Number = sizeof(T) <= 8 && std::has_single_bit(sizeof(T)) &&
                 (std::is_arithmetic_v<T> || std::is_enum_v<T>);

/// Writes `v` little-endian at `at` (sizeof(T) bytes; the caller owns the room).
template <Number T>
void store(uint8_t* at, T v) {
  const auto bits = std::bit_cast<Bits<T>>(v);
  for (size_t i = 0; i < sizeof(T); ++i) at[i] = static_cast<uint8_t>(bits >> (8 * i));
}

/// Reads a little-endian T at `at` (sizeof(T) bytes; the caller has checked they are there).
template <Number T>
T load(const uint8_t* at) {
  Bits<T> bits = 0;
  for (size_t i = 0; i < sizeof(T); ++i)
    bits = static_cast<Bits<T>>(bits | static_cast<Bits<T>>(Bits<T>{at[i]} << (8 * i)));
  return std::bit_cast<T>(bits);
}

/// Appends fields to `out`. Throws Error("protocol: string too long") for a string over 65535
/// bytes.
class Writer {
 public:
  explicit Writer(std::vector<uint8_t>& out) : out_(out) {}
  /// A number, little-endian.
  template <Number T>
  void put(T v) {
    const size_t at = out_.size();
    out_.resize(at + sizeof(T));
    store<T>(out_.data() + at, v);
  }
  /// Numbers one after another, each little-endian (no count).
  template <Number T>
  void put_array(std::span<const T> values) {
    if constexpr (std::endian::native == std::endian::little) {
      append(values.data(), values.size_bytes());
    } else {
      for (const T v : values) put<T>(v);
    }
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
  /// Raw bytes as they are (no count, no byte order: only for bytes).
  void append(const void* data, size_t n) {
    if (n == 0) return;
    const size_t at = out_.size();
    out_.resize(at + n);
    std::memcpy(out_.data() + at, data, n);
  }

 private:
  std::vector<uint8_t>& out_;
};

/// Reads fields from `in` without ever reading past it. A short payload throws
/// Error("malformed <what>: truncated"), or "malformed <what>: truncated at <field>" where the read
/// names its field; fail() throws Error("malformed <what>: <why>").
class Reader {
 public:
  Reader(std::span<const uint8_t> in, const char* what) : in_(in), what_(what) {}
  /// A little-endian number.
  template <Number T>
  T get(const char* field = nullptr) {
    need(sizeof(T), field);
    const T v = load<T>(in_.data() + pos_);
    pos_ += sizeof(T);
    return v;
  }
  std::string get_string(const char* field = nullptr) {
    const size_t n = get<uint16_t>(field);
    need(n, field);
    std::string s(reinterpret_cast<const char*>(in_.data() + pos_), n);
    pos_ += n;
    return s;
  }
  /// A byte string (u32 length + bytes), as a view into the input.
  std::span<const uint8_t> get_span(const char* field = nullptr) {
    const size_t n = get<uint32_t>(field);
    return get_raw(n, field);
  }
  /// The next `n` bytes as they are, as a view into the input.
  std::span<const uint8_t> get_raw(size_t n, const char* field = nullptr) {
    need(n, field);
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
  void need(size_t n, const char* field) const {
    if (n > in_.size() - pos_) fail(field ? std::string("truncated at ") + field : "truncated");
  }
  std::span<const uint8_t> in_;
  size_t pos_ = 0;
  const char* what_;
};

}  // namespace volcast::wire
