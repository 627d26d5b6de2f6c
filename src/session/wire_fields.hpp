#pragma once
// The session channel's field codecs (messages.cpp, objects.cpp), private to src/session. A
// message's layout is written once, as a function `layout(io, m)` that names its fields in order,
// and runs both ways: with Out it writes them (core/wire.hpp's Writer), with In it reads them and
// checks each value, failing the Reader ("malformed <message>: ...") on a bad one, and with
// Describe it records them (message_layout.hpp: what the page's codec is made from). Every field
// is named as its member is (snake_case; errors say it with spaces). encode(), decode() and
// describe() run a layout over a whole payload.
#include <algorithm>
#include <cmath>
#include <concepts>
#include <limits>
#include <span>
#include <string>
#include <vector>

#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/session/message_layout.hpp"
#include "volcast/session/messages.hpp"

namespace volcast::session::fields {

using wire::Reader;
using wire::Writer;

/// "session_name" -> "session name": a field's name as errors say it.
inline std::string spoken(const char* field) {
  std::string s(field);
  for (char& c : s)
    if (c == '_') c = ' ';
  return s;
}

/// Writes a layout's fields. Every call names its field (snake_case, the member's name), which
/// Describe records and In says in its errors.
struct Out {
  Writer& w;
  template <wire::Number T>
  void number(T v, const char*) {
    w.put<T>(v);
  }
  /// A number of a wider member written as W (clamped to W's range).
  template <wire::Number W, wire::Number T>
  void number_as(const T& v, const char*) {
    w.put<W>(static_cast<W>(std::min<T>(v, T(std::numeric_limits<W>::max()))));
  }
  /// An f32 that must be finite.
  void finite(float v, const char*) { w.put<float>(v); }
  /// A string (u16 length + bytes).
  void string(const std::string& s, const char*) { w.put_string(s); }
  /// A name: 1..kMaxNameBytes bytes without control characters.
  void name(const std::string& s, const char*) { w.put_string(s); }
  /// A u8 of 0 or 1; `why` is the reader's complaint about another value.
  void flag(bool v, const char*, const char* = nullptr) { w.put<uint8_t>(v ? 1 : 0); }
  /// A u8 enum of values 0..max; `what` names it in the reader's complaint ("unknown <what> 7").
  template <typename E>
  void enumeration(E v, uint8_t, const char*, const char* = nullptr) {
    w.put<uint8_t>(static_cast<uint8_t>(v));
  }
  /// A byte string (u32 length + bytes).
  void bytes(std::span<const uint8_t> b, const char*) { w.put_bytes(b); }
  void spot(const Spot& s, const char*) {
    for (float v : {s.x, s.z, s.yaw}) w.put<float>(v);
  }
  void pose(const Pose& p, const char*) {
    for (int i = 0; i < 3; ++i) w.put<float>(p.position[i]);
    for (float v : {p.orientation.x(), p.orientation.y(), p.orientation.z(), p.orientation.w()})
      w.put<float>(v);
  }
  /// Three finite f32 (x, y, z) of anything indexed 0..2.
  template <typename V>
  void vec3(const V& v, const char*) {
    for (int i = 0; i < 3; ++i) w.put<float>(v[i]);
  }
  /// A list: u16 count, then each item's fields (`item(io, element)`); more than `max` items is
  /// the writer's error (Error "<field>: more than <max>").
  template <typename C, typename F>
  void list(const C& c, size_t max, size_t, const char* field, F item) {
    if (c.size() > max) throw Error(spoken(field) + ": more than " + std::to_string(max));
    w.put<uint16_t>(static_cast<uint16_t>(c.size()));
    for (const auto& e : c) item(*this, e);
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
  void number(T& v, const char*) {
    v = r.get<T>();
  }
  template <wire::Number W, wire::Number T>
  void number_as(T& v, const char*) {
    v = static_cast<T>(r.get<W>());
  }
  void finite(float& v, const char* field) {
    v = r.get<float>();
    if (!std::isfinite(v)) r.fail(spoken(field) + " is not finite");
  }
  void string(std::string& s, const char* field) { s = r.get_string(field); }
  void name(std::string& s, const char* field) {
    s = r.get_string(field);
    if (s.empty() || s.size() > kMaxNameBytes)
      r.fail(spoken(field) + " must be 1 to " + std::to_string(kMaxNameBytes) + " bytes");
    for (unsigned char c : s)
      if (c < 0x20 || c == 0x7f) r.fail(spoken(field) + " has a control character");
  }
  void flag(bool& v, const char* field, const char* why = nullptr) {
    const uint8_t b = r.get<uint8_t>();
    if (b > 1) r.fail(why ? std::string(why) : spoken(field) + " is neither 0 nor 1");
    v = b == 1;
  }
  template <typename E>
  void enumeration(E& v, uint8_t max, const char* field, const char* what = nullptr) {
    const uint8_t b = r.get<uint8_t>();
    if (b > max)
      r.fail("unknown " + (what ? std::string(what) : spoken(field)) + " " + std::to_string(b));
    v = static_cast<E>(b);
  }
  void bytes(std::span<const uint8_t>& b, const char*) { b = r.get_span(); }
  void spot(Spot& s, const char* field) {
    for (float* v : {&s.x, &s.z, &s.yaw}) finite(*v, field);
  }
  void pose(Pose& p, const char* field) {
    for (int i = 0; i < 3; ++i) finite(p.position[i], field);
    float q[4];
    for (float& v : q) finite(v, field);
    p.orientation = Eigen::Quaternionf(q[3], q[0], q[1], q[2]);
    if (std::abs(p.orientation.squaredNorm() - 1.0f) > 2e-3f)
      r.fail(spoken(field) + ": orientation is not a unit quaternion");
    p.orientation.normalize();
  }
  template <typename V>
  void vec3(V& v, const char* field) {
    for (int i = 0; i < 3; ++i) finite(v[i], field);
  }
  /// The count is checked against `max` and against the bytes left (each item at least
  /// `item_bytes`) before anything is allocated.
  template <typename C, typename F>
  void list(C& c, size_t max, size_t item_bytes, const char* field, F item) {
    const uint16_t n = r.get<uint16_t>();
    if (n > max)
      r.fail(std::to_string(n) + " " + spoken(field) + ", more than " + std::to_string(max));
    if (size_t{n} * item_bytes > r.remaining())
      r.fail("more " + spoken(field) + " declared than the message holds");
    c.resize(n);
    for (auto& e : c) item(*this, e);
  }
  void check(bool ok, const char* why) {
    if (!ok) r.fail(why);
  }
  /// An optional tail: its fields follow when any bytes are left.
  bool tail(bool) { return r.remaining() > 0; }
};

/// Records a layout's fields (message_layout.hpp) from the same `layout(io, m)`, run on a
/// default message: every field and every optional tail, checks aside.
struct Describe {
  std::vector<LayoutField>& out;
  void add(const char* field, FieldKind kind, uint32_t max = 0) {
    out.push_back({field, kind, max, {}});
  }
  template <wire::Number T>
  static constexpr FieldKind kind_of() {
    if constexpr (std::is_same_v<T, uint8_t>) return FieldKind::kU8;
    if constexpr (std::is_same_v<T, uint16_t>) return FieldKind::kU16;
    if constexpr (std::is_same_v<T, uint32_t>) return FieldKind::kU32;
    if constexpr (std::is_same_v<T, uint64_t>) return FieldKind::kU64;
    if constexpr (std::is_same_v<T, int64_t>) return FieldKind::kI64;
    if constexpr (std::is_same_v<T, float>) return FieldKind::kF32;
    static_assert(std::is_same_v<T, uint8_t> || std::is_same_v<T, uint16_t> ||
                      std::is_same_v<T, uint32_t> || std::is_same_v<T, uint64_t> ||
                      std::is_same_v<T, int64_t> || std::is_same_v<T, float>,
                  "a session field of a number type message_layout.hpp does not name");
    return FieldKind::kU8;
  }
  template <wire::Number T>
  void number(const T&, const char* field) {
    add(field, kind_of<T>());
  }
  template <wire::Number W, wire::Number T>
  void number_as(const T&, const char* field) {
    add(field, kind_of<W>());
  }
  void finite(float, const char* field) { add(field, FieldKind::kFinite); }
  void string(const std::string&, const char* field) { add(field, FieldKind::kString); }
  void name(const std::string&, const char* field) {
    add(field, FieldKind::kName, static_cast<uint32_t>(kMaxNameBytes));
  }
  void flag(bool, const char* field, const char* = nullptr) { add(field, FieldKind::kFlag); }
  template <typename E>
  void enumeration(E, uint8_t max, const char* field, const char* = nullptr) {
    add(field, FieldKind::kEnum, max);
  }
  void bytes(std::span<const uint8_t>, const char* field) { add(field, FieldKind::kBytes); }
  void spot(const Spot&, const char* field) { add(field, FieldKind::kSpot); }
  void pose(const Pose&, const char* field) { add(field, FieldKind::kPose); }
  template <typename V>
  void vec3(const V&, const char* field) {
    add(field, FieldKind::kVec3);
  }
  template <typename C, typename F>
  void list(const C&, size_t max, size_t, const char* field, F item) {
    LayoutField f{field, FieldKind::kList, static_cast<uint32_t>(max), {}};
    Describe inner{f.items};
    typename C::value_type e{};
    item(inner, e);
    out.push_back(std::move(f));
  }
  void check(bool, const char*) {}
  bool tail(bool) {
    add("", FieldKind::kTail);
    return true;
  }
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

/// The fields `layout_of(io, m)` names, run on a default M.
template <typename M, typename Layout = Fields>
std::vector<LayoutField> describe(Layout layout_of = {}) {
  std::vector<LayoutField> out;
  Describe io{out};
  M m{};
  layout_of(io, m);
  return out;
}

/// `fields` as a server forwards them (messages.hpp forward): after the sender's id.
inline std::vector<LayoutField> forwarded(std::vector<LayoutField> fields) {
  fields.insert(fields.begin(), LayoutField{"participant", FieldKind::kU32, 0, {}});
  return fields;
}

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
