// Writes the page's copy of the session channel's message table, messages.js, from the C++ table
// (volcast/session/message_table.hpp) at build time (web/CMakeLists.txt), so that the page names
// every session message type by the same number, name, feature and payload limit as the server
// and the native participant. Usage: page_messages OUTPUT.js; exits 1 (naming why) when it cannot
// write OUTPUT.
//
// The file is a classic script, so that the page's modules (session.js imports it for its effect)
// and its workers (importScripts) read the same: it sets
//   globalThis.VolcastMessages = {VERSION, T, MESSAGES}
// VERSION: the stream protocol's version (protocol.hpp kVersion), which every header carries;
// T.<NAME>: the type byte, NAME the row's name in capitals with '_' for ' ', and '_FROM' for a
// server type that forwards a participant's type of the same name (messages.hpp's k<Name>From);
// MESSAGES[type]: {name, feature, up (a participant sends it), maxPayload (bytes)};
// LAYOUTS[type]: the payload's fields in order (volcast/session/message_layout.hpp), each
// {name, kind, max, items}: name in camelCase (the C++ member's, snake_case there), kind as
// to_string(FieldKind) writes it, max and items where the kind has them; only for the types whose
// payload is described (not the avatar camera and frames, not the case).
#include <cctype>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <set>
#include <string>

#include "volcast/net/protocol/protocol.hpp"
#include "volcast/session/message_layout.hpp"
#include "volcast/session/message_table.hpp"

namespace {

using volcast::session::MessageKind;
using volcast::session::Sender;

std::string symbol(const MessageKind& m, const std::set<std::string>& up_names) {
  std::string s;
  for (const char c : std::string(m.name))
    s += c == ' ' ? '_' : static_cast<char>(std::toupper(static_cast<unsigned char>(c)));
  if (m.sender == Sender::kServer && up_names.count(m.name)) s += "_FROM";
  return s;
}

using volcast::session::FieldKind;
using volcast::session::LayoutField;

std::string camel(const std::string& snake) {
  std::string s;
  bool up = false;
  for (const char c : snake) {
    if (c == '_') {
      up = true;
      continue;
    }
    s += up ? static_cast<char>(std::toupper(static_cast<unsigned char>(c))) : c;
    up = false;
  }
  return s;
}

std::string fields_js(const std::vector<LayoutField>& fields) {
  std::string js = "[";
  for (const LayoutField& f : fields) {
    js += "{name: '" + camel(f.name) + "', kind: '" + volcast::session::to_string(f.kind) + "'";
    if (f.kind == FieldKind::kEnum || f.kind == FieldKind::kList || f.kind == FieldKind::kName)
      js += ", max: " + std::to_string(f.max);
    if (f.kind == FieldKind::kList) js += ", items: " + fields_js(f.items);
    js += "}, ";
  }
  if (!fields.empty()) js.resize(js.size() - 2);
  return js + "]";
}

std::string hex(uint8_t type) {
  char b[8];
  std::snprintf(b, sizeof b, "0x%02x", type);
  return b;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc != 2) {
    std::cerr << "usage: page_messages OUTPUT.js\n";
    return 1;
  }
  const auto table = volcast::session::message_table();
  std::set<std::string> up_names;
  for (const MessageKind& m : table)
    if (m.sender == Sender::kParticipant) up_names.insert(m.name);
  std::string js =
      "// The session channel's message types (src/session/include/volcast/session/"
      "message_table.hpp),\n// written from the C++ table at build time by "
      "web/gen/page_messages.cpp: do not edit.\n"
      "// VERSION: the stream protocol's (protocol.hpp); T.<NAME>: the type byte; MESSAGES[type]:\n"
      "// {name, feature, up (a participant sends it), maxPayload (bytes)}; LAYOUTS[type]: the\n"
      "// payload's fields in order (message_layout.hpp), {name, kind, max, items}. A classic "
      "script:\n"
      "// modules import it, workers importScripts it.\n"
      "globalThis.VolcastMessages = Object.freeze({\n  VERSION: " +
      std::to_string(volcast::protocol::kVersion) + ",\n  T: Object.freeze({\n";
  for (const MessageKind& m : table)
    js += "    " + symbol(m, up_names) + ": " + hex(static_cast<uint8_t>(m.type)) + ",\n";
  js += "  }),\n  MESSAGES: Object.freeze({\n";
  for (const MessageKind& m : table)
    js += "    " + hex(static_cast<uint8_t>(m.type)) + ": Object.freeze({name: '" + m.name +
          "', feature: '" + volcast::session::to_string(m.feature) +
          "', up: " + (m.sender == Sender::kParticipant ? "true" : "false") +
          ", maxPayload: " + std::to_string(m.max_payload) + "}),\n";
  js += "  }),\n  LAYOUTS: Object.freeze({\n";
  for (const volcast::session::PayloadLayout& l : volcast::session::payload_layouts())
    if (l.described)
      js += "    " + hex(static_cast<uint8_t>(l.type)) + ": " + fields_js(l.fields) + ",\n";
  js += "  }),\n});\n";
  std::ofstream out(argv[1], std::ios::binary);
  out << js;
  out.close();
  if (!out) {
    std::cerr << "page_messages: cannot write " << argv[1] << "\n";
    return 1;
  }
  return 0;
}
