#include "volcast/session/annotations.hpp"

#include "volcast/core/error.hpp"
#include "volcast/session/names.hpp"
#include "wire_fields.hpp"

namespace volcast::session {

using fields::decode;
using fields::encode;
using fields::In;
using fields::Of;
using fields::Out;

const char* to_string(AnnotationKind kind) {
  switch (kind) {
    case AnnotationKind::kStroke:
      return "stroke";
    case AnnotationKind::kArrow:
      return "arrow";
    case AnnotationKind::kLabel:
      return "label";
  }
  return "?";
}

namespace {

void vec3(Out& io, const Eigen::Vector3f& v) {
  for (int i = 0; i < 3; ++i) io.finite(v[i]);
}
void vec3(In& io, Eigen::Vector3f& v) {
  for (int i = 0; i < 3; ++i) io.finite(v[i]);
}

// The point list: count u16 | count x 3 f32; the count checked against the bytes left before
// anything is allocated.
void points(Out& io, const std::vector<Eigen::Vector3f>& p) {
  if (p.size() > kMaxStrokePoints) throw Error("annotation: more than 256 points");
  io.number(static_cast<uint16_t>(p.size()));
  for (const Eigen::Vector3f& v : p) vec3(io, v);
}
void points(In& io, std::vector<Eigen::Vector3f>& p) {
  uint16_t n = 0;
  io.number(n);
  if (n > kMaxStrokePoints)
    io.r.fail(std::to_string(n) + " points, more than " + std::to_string(kMaxStrokePoints));
  if (size_t{n} * 12 > io.r.remaining()) io.r.fail("more points declared than the message holds");
  p.resize(n);
  for (Eigen::Vector3f& v : p) vec3(io, v);
}

// 0x11's fields.
template <typename Io, typename M>
void annotate_layout(Io& io, M& a) {
  io.number(a.tag);
  io.enumeration(a.kind, 2, "annotation kind");
  io.enumeration(a.anchor, 1, "annotation anchor");
  io.number(a.generation);
  io.number(a.slice);
  points(io, a.points);
  io.string(a.text);
  const size_t n = a.points.size();
  switch (a.kind) {
    case AnnotationKind::kStroke:
      io.check(n >= 2, "a stroke needs at least 2 points");
      io.check(a.text.empty(), "a stroke has no text");
      break;
    case AnnotationKind::kArrow:
      io.check(n == 2, "an arrow has 2 points (tail, head)");
      io.check(a.text.empty(), "an arrow has no text");
      break;
    case AnnotationKind::kLabel:
      io.check(n == 1, "a label has 1 point (its pin)");
      io.check(!a.text.empty(), "a label has text");
      break;
  }
}

const auto kAnnotate = [](auto& io, auto& a) { annotate_layout(io, a); };
const auto kAnnotation = [](auto& io, auto& a) {
  io.number(a.id);
  io.check(a.id != 0, "annotation id 0");
  io.number(a.author);
  io.number(a.time_us);
  annotate_layout(io, a);
};

}  // namespace

template <typename Io, Of<PointerMessage> M>
void layout(Io& io, M& m) {
  io.number(m.sequence);
  io.number(m.time_us);
  io.flag(m.on);
  vec3(io, m.origin);
  io.flag(m.has_hit);
  vec3(io, m.hit);
}

std::vector<uint8_t> serialize(const PointerMessage& m) {
  return encode(m);
}

PointerMessage parse_pointer(std::span<const uint8_t> p) {
  return decode<PointerMessage>(p, "pointer");
}

std::vector<uint8_t> serialize_annotate(const Annotation& a) {
  return encode(a, kAnnotate, 32 + a.points.size() * 12 + a.text.size());
}

Annotation parse_annotate(std::span<const uint8_t> p) {
  return decode<Annotation>(p, "annotate", kAnnotate);
}

std::vector<uint8_t> serialize(const Annotation& a) {
  return encode(a, kAnnotation, 48 + a.points.size() * 12 + a.text.size());
}

Annotation parse_annotation(std::span<const uint8_t> p) {
  return decode<Annotation>(p, "annotation", kAnnotation);
}

namespace {
struct Erased {
  uint32_t id = 0, by = 0;
};
const auto kErase = [](auto& io, auto& e) { io.number(e.id); };
const auto kErased = [](auto& io, auto& e) {
  io.number(e.id);
  io.number(e.by);
};
}  // namespace

std::vector<uint8_t> serialize_erase(uint32_t id) {
  return encode(Erased{id, 0}, kErase);
}

uint32_t parse_erase(std::span<const uint8_t> p) {
  return decode<Erased>(p, "erase", kErase).id;
}

std::vector<uint8_t> serialize_erased(uint32_t id, uint32_t by) {
  return encode(Erased{id, by}, kErased);
}

std::pair<uint32_t, uint32_t> parse_erased(std::span<const uint8_t> p) {
  const Erased e = decode<Erased>(p, "erased", kErased);
  return {e.id, e.by};
}

std::string check_label_text(const std::string& text) {
  static_assert(kMaxLabelBytes == kMaxNameBytes, "labels are checked as names are");
  return checked_name(text, "label");
}

}  // namespace volcast::session
