#pragma once
// A session message's payload as data: its fields in order, as the C++ encoder writes them and
// the decoder reads them (little endian). The same `layout(io, m)` that runs the encoder and the
// decoder (src/session/wire_fields.hpp) records it, so it cannot drift from them; the page's
// reader and writer (web/page/messages.js, written at build time by web/gen/page_messages.cpp)
// are made from it. docs/protocol.md describes the same fields for people.
#include <cstdint>
#include <string>
#include <vector>

#include "volcast/session/messages.hpp"

namespace volcast::session {

/// How a field is written. Sizes in bytes; all numbers little endian.
enum class FieldKind : uint8_t {
  kU8,
  kU16,
  kU32,
  kU64,
  kI64,
  kF32,     ///< any f32
  kFinite,  ///< an f32 that must be finite
  kString,  ///< u16 length + UTF-8 bytes; `max`: the most bytes (0: up to 65535)
  kName,    ///< a string of 1..kMaxNameBytes bytes without control characters
  kFlag,    ///< u8 0 or 1
  kEnum,    ///< u8 of 0..max
  kBytes,   ///< u32 length + bytes
  kSpot,    ///< a floor spot: x, z (metres), yaw (radians): 3 finite f32
  kPose,    ///< position x, y, z (metres) then orientation x, y, z, w (a unit quaternion): 7 finite
            ///< f32
  kVec3,    ///< x, y, z: 3 finite f32
  kList,    ///< u16 count (at most `max`), then `count` times the fields of `items`
  kTail,    ///< no bytes: the fields after it are present only when bytes are left
};
/// "u8", "u16", "u32", "u64", "i64", "f32", "finite", "string", "name", "flag", "enum", "bytes",
/// "spot", "pose", "vec3", "list", "tail".
const char* to_string(FieldKind kind);

/// One field of a payload. `name` is snake_case, the C++ member's name ("session_name");
/// decoders name it, with spaces, in their errors.
struct LayoutField {
  std::string name;
  FieldKind kind = FieldKind::kU8;
  uint32_t max = 0;                ///< kEnum: the largest value; kList: the most items; kString
  std::vector<LayoutField> items;  ///< kList: one item's fields
};

/// The payload of one session message type, field by field. A type a participant's message is
/// forwarded as (k<Name>From) starts with the sender's id, u32 "participant" (messages.hpp
/// forward). `described` is false for the types whose codec is written by hand because their
/// payload is bulk data, not fields: the avatar camera (0x07, 0x49), avatar frames (0x08, 0x4a)
/// and the case (0x4b); their `fields` are empty.
struct PayloadLayout {
  Type type{};
  bool described = false;
  std::vector<LayoutField> fields;
};

/// Every session message type's layout, in the order of message_table().
const std::vector<PayloadLayout>& payload_layouts();
/// The layout of `type`; null for a type that does not exist.
const PayloadLayout* find_layout(uint8_t type);

}  // namespace volcast::session
