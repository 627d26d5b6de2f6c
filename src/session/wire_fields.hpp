#pragma once
// The session channel's field codecs (messages.cpp, objects.cpp), private to src/session. A
// message's layout is written once, as a function `layout(io, m)` that names its fields in order,
// and runs both ways: with Out it writes them (core/wire.hpp's Writer), with In it reads them and
// checks each value, failing the Reader ("malformed <message>: ...") on a bad one. encode() and
// decode() run a layout over a whole payload.
#include <cmath>
#include <concepts>
#include <span>
#include <string>
#include <vector>

#include "volcast/core/wire.hpp"
#include "volcast/session/messages.hpp"

namespace volcast::session::fields {

using wire::Reader;
using wire::Writer;

/// Writes a layout's fields.
struct Out {
  Writer& w;
  template <wire::Number T>
  void number(T v) {
    w.put<T>(v);
  }
  /// An f32 that must be finite.
  void finite(float v) { w.put<float>(v); }
  /// A string (u16 length + bytes); `field` names it where it is read.
  void string(const std::string& s) { w.put_string(s); }
  /// A name: 1..kMaxNameBytes bytes without control characters.
  void name(const std::string& s, const char*) { w.put_string(s); }
  /// A u8 of 0 or 1; `why` is the reader's complaint about another value.
  void flag(bool v, const char* = nullptr) { w.put<uint8_t>(v ? 1 : 0); }
  /// A u8 enum of values 0..max.
  template <typename E>
  void enumeration(E v, uint8_t, const char*) {
    w.put<uint8_t>(static_cast<uint8_t>(v));
  }
  /// A byte string (u32 length + bytes).
  void bytes(std::span<const uint8_t> b) { w.put_bytes(b); }
  void spot(const Spot& s) {
    finite(s.x);
    finite(s.z);
    finite(s.yaw);
  }
  void pose(const Pose& p) {
    for (int i = 0; i < 3; ++i) finite(p.position[i]);
    for (float v : {p.orientation.x(), p.orientation.y(), p.orientation.z(), p.orientation.w()})
      finite(v);
  }
  /// A condition the reader checks on what it has read so far (nothing to write).
  void check(bool, const char*) {}
  /// An optional tail: its fields follow (are written) when `present`.
  bool tail(bool present) { return present; }
};

/// Reads a layout's fields, checking each.
struct In {
  Reader& r;
  template <wire::Number T>
  void number(T& v) {
    v = r.get<T>();
  }
  void finite(float& v) {
    v = r.get<float>();
    if (!std::isfinite(v)) r.fail("a number is not finite");
  }
  void string(std::string& s) { s = r.get_string(); }
  void name(std::string& s, const char* field) {
    s = r.get_string(field);
    if (s.empty() || s.size() > kMaxNameBytes)
      r.fail(std::string(field) + " must be 1 to " + std::to_string(kMaxNameBytes) + " bytes");
    for (unsigned char c : s)
      if (c < 0x20 || c == 0x7f) r.fail(std::string(field) + " has a control character");
  }
  void flag(bool& v, const char* why = nullptr) {
    const uint8_t b = r.get<uint8_t>();
    if (b > 1) r.fail(why ? why : "a flag is neither 0 nor 1");
    v = b == 1;
  }
  template <typename E>
  void enumeration(E& v, uint8_t max, const char* what) {
    const uint8_t b = r.get<uint8_t>();
    if (b > max) r.fail(std::string("unknown ") + what + " " + std::to_string(b));
    v = static_cast<E>(b);
  }
  void bytes(std::span<const uint8_t>& b) { b = r.get_span(); }
  void spot(Spot& s) {
    finite(s.x);
    finite(s.z);
    finite(s.yaw);
  }
  void pose(Pose& p) {
    for (int i = 0; i < 3; ++i) finite(p.position[i]);
    float x, y, z, w;
    finite(x);
    finite(y);
    finite(z);
    finite(w);
    p.orientation = Eigen::Quaternionf(w, x, y, z);
    if (std::abs(p.orientation.squaredNorm() - 1.0f) > 2e-3f)
      r.fail("orientation is not a unit quaternion");
    p.orientation.normalize();
  }
  void check(bool ok, const char* why) {
    if (!ok) r.fail(why);
  }
  /// An optional tail: its fields follow when any bytes are left.
  bool tail(bool) { return r.remaining() > 0; }
};

/// M or const M: a layout's message, as it is written (const) or read.
template <typename M, typename T>
concept Of = std::same_as<std::remove_const_t<M>, T>;

/// Runs the message's own layout, `layout(io, m)` (found next to the message's type).
struct Fields {
  template <typename Io, typename M>
  void operator()(Io& io, M& m) const {
    layout(io, m);
  }
};

/// The payload `layout_of(io, m)` writes (`reserve`: bytes to make room for first).
template <typename M, typename Layout = Fields>
std::vector<uint8_t> encode(const M& m, Layout layout_of = {}, size_t reserve = 0) {
  std::vector<uint8_t> out;
  out.reserve(reserve);
  Writer w(out);
  Out io{w};
  layout_of(io, m);
  return out;
}

/// The M that `layout_of(io, m)` reads from all of `p` (throws Error("malformed <what>: ...") on
/// a bad field, a short payload or trailing bytes).
template <typename M, typename Layout = Fields>
M decode(std::span<const uint8_t> p, const char* what, Layout layout_of = {}) {
  Reader r(p, what);
  In io{r};
  M m;
  layout_of(io, m);
  r.expect_end();
  return m;
}

}  // namespace volcast::session::fields
