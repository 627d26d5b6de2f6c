#pragma once
// Display and session names as others see them (issue 33, item 9): a name shown in the panels and
// on the page must look like what it is. Checked with ICU (Unicode's UAX #15 normalisation and
// UTS #39 security mechanisms, Debian's libicu), not with tables of our own.
#include <cstddef>
#include <string>
#include <string_view>

namespace volcast::session {

/// `utf8` in Unicode normalisation form C, checked for being shown to others; `what` names the
/// field in errors ("display name"). Throws Error naming the problem and the character (as
/// U+XXXX and its Unicode name) for: invalid UTF-8; empty or, once normalised, over kMaxNameBytes
/// bytes; a bidirectional control (U+202E RIGHT-TO-LEFT OVERRIDE, U+2066 ...); an invisible,
/// control, format, private-use, unassigned or line/paragraph separator character; a word (split
/// at spaces) mixing scripts the way look-alikes do (ICU's highly restrictive level per word:
/// "Dr. Аdmin" with a Cyrillic А is refused, "Dr. Иванов" is not); digits of several systems.
std::string checked_name(std::string_view utf8, const char* what);

/// The UTS #39 confusable skeleton of `name` (checked_name's output): two names with the same
/// skeleton look alike ("Dr. Admin", "Dr. Adrnin" and an all-Cyrillic look-alike share one).
std::string name_skeleton(const std::string& name);

/// `text` cut to at most `bytes` bytes at a UTF-8 character boundary (the whole of it if it fits).
std::string cut_utf8(const std::string& text, size_t bytes);

}  // namespace volcast::session
