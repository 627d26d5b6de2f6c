#pragma once
// Text from outside the program (a peer's strings: reject reasons, camera descriptions, codec
// names) made safe to log or print.
#include <cstddef>
#include <string>
#include <string_view>

namespace volcast {

/// `text` made safe for one log line or a terminal: every byte that is not printable is escaped
/// as \xNN (two lower-case hex digits) and a backslash as \\, so the result is unambiguous and
/// can neither forge a log line (newline, carriage return) nor drive a terminal (escape
/// sequences). Printable ASCII (0x20..0x7e) passes through, and so does well-formed UTF-8 of
/// printable characters; escaped are the C0 and C1 controls, DEL, malformed UTF-8 (each of its
/// bytes), and the characters that reorder or break lines (U+2028, U+2029, U+200E, U+200F,
/// U+202A..U+202E, U+2066..U+2069). At most `max_len` bytes of the result come from `text` (an
/// escape or a UTF-8 character is never cut); when `text` does not fit, "..." follows them.
std::string printable(std::string_view text, size_t max_len = 200);

}  // namespace volcast
