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
// MESSAGES[type]: {name, feature, up (a participant sends it), maxPayload (bytes)}.
#include <cctype>
#include <cstdio>
#include <fstream>
#include <iostream>
#include <set>
#include <string>

#include "volcast/net/protocol/protocol.hpp"
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
      "// {name, feature, up (a participant sends it), maxPayload (bytes)}. A classic script:\n"
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
