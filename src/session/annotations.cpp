#include "volcast/session/annotations.hpp"

#include "feature_layouts.hpp"
#include "volcast/core/error.hpp"
#include "volcast/session/names.hpp"
#include "wire_fields.hpp"

namespace volcast::session {

using fields::decode;
using fields::encode;
using fields::In;
using fields::Of;

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

// One point of a list: x, y, z f32, finite (room frame, metres).
const auto kPoint = [](auto& io, auto& v) { io.vec3(v, "point"); };

// 0x11's fields.
template <typename Io, typename M>
void annotate_layout(Io& io, M& a) {
  io.number(a.tag, "tag");
  io.enumeration(a.kind, 2, "kind", "annotation kind");
  io.enumeration(a.anchor, 1, "anchor", "annotation anchor");
  io.number(a.generation, "generation");
  io.number(a.slice, "slice");
  io.list(a.points, kMaxStrokePoints, 12, "points", kPoint);
  io.string(a.text, "text");
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
  io.number(a.id, "id");
  io.check(a.id != 0, "annotation id 0");
  io.number(a.author, "author");
  io.number(a.time_us, "time_us");
  annotate_layout(io, a);
};

}  // namespace

template <typename Io, Of<PointerMessage> M>
void layout(Io& io, M& m) {
  io.number(m.sequence, "sequence");
  io.number(m.time_us, "time_us");
  io.flag(m.on, "on");
  io.vec3(m.origin, "origin");
  io.flag(m.has_hit, "has_hit");
  io.vec3(m.hit, "hit");
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
const auto kErase = [](auto& io, auto& e) { io.number(e.id, "id"); };
const auto kErased = [](auto& io, auto& e) {
  io.number(e.id, "id");
  io.number(e.by, "by");
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

bool describe_drawing(Type type, std::vector<LayoutField>& out) {
  using fields::describe;
  switch (type) {
    case Type::kPointer:
      out = describe<PointerMessage>();
      return true;
    case Type::kPointerFrom:
      out = fields::forwarded(describe<PointerMessage>());
      return true;
    case Type::kAnnotate:
      out = describe<Annotation>(kAnnotate);
      return true;
    case Type::kAnnotation:
      out = describe<Annotation>(kAnnotation);
      return true;
    case Type::kErase:
      out = describe<Erased>(kErase);
      return true;
    case Type::kErased:
      out = describe<Erased>(kErased);
      return true;
    default:
      return false;
  }
}

std::string check_label_text(const std::string& text) {
  static_assert(kMaxLabelBytes == kMaxNameBytes, "labels are checked as names are");
  return checked_name(text, "label");
}

}  // namespace volcast::session
