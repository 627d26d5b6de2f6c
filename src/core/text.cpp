#include "volcast/core/text.hpp"

#include <algorithm>
#include <cstdint>

namespace volcast {
namespace {

// The length of the well-formed UTF-8 sequence at the start of `s` (2..4) and its code point, or
// 0 if it is not one (overlong forms, surrogates and code points above U+10FFFF are not).
size_t utf8_sequence(std::string_view s, char32_t& cp) {
  const auto b = [&](size_t i) { return static_cast<uint8_t>(s[i]); };
  const uint8_t lead = b(0);
  size_t n;
  if (lead >= 0xc2 && lead <= 0xdf) {
    n = 2;
    cp = lead & 0x1f;
  } else if (lead >= 0xe0 && lead <= 0xef) {
    n = 3;
    cp = lead & 0x0f;
  } else if (lead >= 0xf0 && lead <= 0xf4) {
    n = 4;
    cp = lead & 0x07;
  } else {
    return 0;
  }
  if (s.size() < n) return 0;
  for (size_t i = 1; i < n; ++i) {
    if ((b(i) & 0xc0) != 0x80) return 0;
    cp = cp << 6 | (b(i) & 0x3f);
  }
  const char32_t min = n == 2 ? 0x80 : n == 3 ? 0x800 : 0x10000;
  if (cp < min || cp > 0x10ffff || (cp >= 0xd800 && cp <= 0xdfff)) return 0;
  return n;
}

bool printable_code_point(char32_t cp) {
  if (cp < 0xa0) return false;  // C1 controls (and anything a one-byte check should have taken)
  if (cp == 0x2028 || cp == 0x2029) return false;  // line / paragraph separator
  if (cp == 0x200e || cp == 0x200f) return false;  // left-to-right / right-to-left mark
  if (cp >= 0x202a && cp <= 0x202e) return false;  // bidirectional embeddings
  if (cp >= 0x2066 && cp <= 0x2069) return false;  // bidirectional isolates
  return true;
}

}  // namespace

std::string printable(std::string_view text, size_t max_len) {
  static constexpr char kHex[] = "0123456789abcdef";
  std::string out;
  out.reserve(std::min(text.size(), max_len) + 3);
  size_t i = 0;
  while (i < text.size()) {
    const uint8_t c = static_cast<uint8_t>(text[i]);
    std::string_view piece;
    char escaped[4];
    size_t consumed = 1;
    char32_t cp = 0;
    if (c >= 0x20 && c < 0x7f && c != '\\') {
      piece = text.substr(i, 1);
    } else if (c == '\\') {
      piece = "\\\\";
    } else if (const size_t n = c >= 0x80 ? utf8_sequence(text.substr(i), cp) : 0;
               n > 0 && printable_code_point(cp)) {
      piece = text.substr(i, n);
      consumed = n;
    } else {
      escaped[0] = '\\';
      escaped[1] = 'x';
      escaped[2] = kHex[c >> 4];
      escaped[3] = kHex[c & 15];
      piece = std::string_view(escaped, 4);
    }
    if (out.size() + piece.size() > max_len) {
      out += "...";
      return out;
    }
    out += piece;
    i += consumed;
  }
  return out;
}

}  // namespace volcast
