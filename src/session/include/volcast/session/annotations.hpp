#pragma once
// Pointing and drawing on the live scene (issue 36; telementoring's pointing, drawing and looking:
// ARTEMIS, Gasques et al. 2021; Proximie's telestration): each participant's laser pointer, shown
// to everyone while it is held, and annotations -- freehand strokes, arrows and pinned labels --
// that belong to the session. Session channel messages (header as messages.hpp); little-endian,
// f32 IEEE-754, strings u16 length + UTF-8. Points are in the room frame, metres.
//
// participant -> server:
//   0x10 Pointer   sequence u32 | time i64 (server clock, µs) | on u8 (0/1: held) | origin 3 f32 |
//                  hit u8 (0/1) | hit point 3 f32 (where the ray first meets what its owner sees:
//                  the live clouds, an organ, the monitor, the room; meaningless when hit = 0, and
//                  then the ray points from origin through it). Forwarded as 0x50 to the others,
//                  the newest per participant (coalesced like poses); the last one held is sent to
//                  those who join later. Rate limited like poses.
//   0x11 Annotate  tag u32 (the author's own number for it, echoed in 0x51) | kind u8 (0 stroke,
//                  1 arrow, 2 label) | anchor u8 (0 room, 1 monitor) | generation u32 (anchor 1:
//                  the case generation, objects.hpp; else 0) | slice u16 (anchor 1: the CT slice it
//                  was drawn on, shown only while the monitor shows it; else 0) | point count u16 |
//                  points count x 3 f32 | text string. A stroke has 2..kMaxStrokePoints points and
//                  no text; an arrow 2 points (tail, head) and no text; a label 1 point (its pin)
//                  and 1..kMaxLabelBytes bytes of text. The server numbers it and sends it as 0x51
//                  to everyone (the author included) and to those who join later; it stays when
//                  its author leaves.
//   0x12 Erase     annotation id u32. Allowed to its author, or to anyone where the server says so
//                  (SessionHubConfig::anyone_erases); answered by 0x52 to everyone, or by 0x43.
// server -> participant:
//   0x50 PointerFrom   participant u32 | the 0x10 payload
//   0x51 Annotation    id u32 (> 0, the server's, never reused in a session) | author u32 | time
//                      i64 (server clock) | the 0x11 payload
//   0x52 Erased        id u32 | by u32 (participant; 0: the server, e.g. its case was swapped)
//
// A message whose fields are malformed (non-finite, a count not matching the bytes, an unknown
// kind or anchor, the wrong point count for its kind, text on a stroke) drops its sender as any
// malformed message does. An annotation that is well formed but refused -- label text that is not
// printable UTF-8 (names.hpp's checks), over the session's kMaxSessionAnnotations or
// kMaxSessionAnnotationPoints, about a monitor of another case or a slice it does not have -- is
// answered by 0x43 naming why, and nothing else happens.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include <Eigen/Core>

namespace volcast::session {

inline constexpr size_t kMaxStrokePoints = 256;
inline constexpr size_t kMaxLabelBytes = 64;
/// Per session, everything drawn and not erased: a flood is refused beyond these.
inline constexpr size_t kMaxSessionAnnotations = 256;
inline constexpr size_t kMaxSessionAnnotationPoints = 16384;

/// A laser pointer (0x10; room frame, metres).
struct PointerMessage {
  uint32_t sequence = 0;
  int64_t time_us = 0;  ///< server clock
  bool on = false;      ///< held: shown; false: put away (the last message of a gesture)
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();
  bool has_hit = false;
  Eigen::Vector3f hit = Eigen::Vector3f::Zero();  ///< where the ray meets a surface (has_hit)
};

enum class AnnotationKind : uint8_t { kStroke = 0, kArrow = 1, kLabel = 2 };
enum class AnnotationAnchor : uint8_t { kRoom = 0, kMonitor = 1 };
const char* to_string(AnnotationKind kind);

/// One annotation as drawn (0x11) and as the session keeps it (0x51).
struct Annotation {
  uint32_t id = 0;      ///< the server's (0x51); 0 before it numbered it
  uint32_t author = 0;  ///< participant id (0x51)
  int64_t time_us = 0;  ///< when the server took it, server clock (0x51)
  uint32_t tag = 0;     ///< the author's own number for it
  AnnotationKind kind = AnnotationKind::kStroke;
  AnnotationAnchor anchor = AnnotationAnchor::kRoom;
  uint32_t generation = 0;  ///< anchor kMonitor: the case's generation
  uint16_t slice = 0;       ///< anchor kMonitor: the CT slice it belongs to
  /// Room frame, metres: a stroke's path, an arrow's tail and head, a label's pin.
  std::vector<Eigen::Vector3f> points;
  std::string text;  ///< a label's; empty for the others
};

std::vector<uint8_t> serialize(const PointerMessage& m);
/// Throws Error("malformed pointer: ...") on truncation, trailing bytes or a non-finite number.
PointerMessage parse_pointer(std::span<const uint8_t> p);
/// 0x11: the fields an author sends (tag .. text).
std::vector<uint8_t> serialize_annotate(const Annotation& a);
/// Throws Error("malformed annotate: ...") as the top of this file says; does not check the
/// label's text (check_label_text does).
Annotation parse_annotate(std::span<const uint8_t> p);
/// 0x51: id | author | time | the 0x11 fields.
std::vector<uint8_t> serialize(const Annotation& a);
Annotation parse_annotation(std::span<const uint8_t> p);
/// 0x12: the annotation's id; 0x52: (id, by).
std::vector<uint8_t> serialize_erase(uint32_t id);
uint32_t parse_erase(std::span<const uint8_t> p);
std::vector<uint8_t> serialize_erased(uint32_t id, uint32_t by);
std::pair<uint32_t, uint32_t> parse_erased(std::span<const uint8_t> p);
/// A label's text, normalised to NFC, checked as names.hpp checks a display name (1..kMaxLabelBytes
/// bytes, printable, no bidi controls or invisible characters). Throws Error naming the problem.
std::string check_label_text(const std::string& text);

}  // namespace volcast::session
