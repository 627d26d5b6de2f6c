#include "volcast/session/message_layout.hpp"

#include <array>
#include <iterator>

#include "feature_layouts.hpp"
#include "volcast/session/message_table.hpp"

namespace volcast::session {

const char* to_string(FieldKind kind) {
  constexpr std::array kNames{"u8",     "u16",    "u32",  "u64",  "i64",  "f32",
                              "finite", "string", "name", "flag", "enum", "bytes",
                              "spot",   "pose",   "vec3", "list", "tail"};
  const auto i = static_cast<size_t>(kind);
  return i < kNames.size() ? kNames[i] : "?";
}

const std::vector<PayloadLayout>& payload_layouts() {
  static const std::vector<PayloadLayout> kLayouts = [] {
    std::vector<PayloadLayout> out;
    for (const MessageKind& m : message_table()) {
      PayloadLayout l{m.type, false, {}};
      l.described = describe_presence(m.type, l.fields) || describe_voice(m.type, l.fields) ||
                    describe_drawing(m.type, l.fields) || describe_objects(m.type, l.fields);
      out.push_back(std::move(l));
    }
    return out;
  }();
  return kLayouts;
}

const PayloadLayout* find_layout(uint8_t type) {
  for (const PayloadLayout& l : payload_layouts())
    if (static_cast<uint8_t>(l.type) == type) return &l;
  return nullptr;
}

}  // namespace volcast::session
