#include "volcast/session/names.hpp"

#include <unicode/normalizer2.h>
#include <unicode/uchar.h>
#include <unicode/unistr.h>
#include <unicode/uscript.h>
#include <unicode/uspoof.h>

#include <cstdio>
#include <map>
#include <memory>

#include "volcast/core/error.hpp"
#include "volcast/session/messages.hpp"

namespace volcast::session {
namespace {

// "U+202E RIGHT-TO-LEFT OVERRIDE"
std::string describe(UChar32 c) {
  char code[16];
  std::snprintf(code, sizeof code, "U+%04X", static_cast<unsigned>(c));
  char name[128];
  UErrorCode e = U_ZERO_ERROR;
  const int32_t n = u_charName(c, U_EXTENDED_CHAR_NAME, name, sizeof name, &e);
  return U_SUCCESS(e) && n > 0 ? std::string(code) + " " + std::string(name, n) : code;
}

// Why `c` may not be in a name shown to others; empty if it may.
std::string refused_character(UChar32 c) {
  if (u_hasBinaryProperty(c, UCHAR_BIDI_CONTROL))
    return "a bidirectional control, which reorders the text around it";
  switch (u_charType(c)) {
    case U_CONTROL_CHAR:
      return "a control character";
    case U_FORMAT_CHAR:
      return "an invisible formatting character";
    case U_PRIVATE_USE_CHAR:
      return "a private-use character";
    case U_UNASSIGNED:
      return "an unassigned code point";
    case U_SURROGATE:
      return "a surrogate";
    case U_LINE_SEPARATOR:
    case U_PARAGRAPH_SEPARATOR:
      return "a line or paragraph separator";
    default:
      break;
  }
  if (u_hasBinaryProperty(c, UCHAR_DEFAULT_IGNORABLE_CODE_POINT)) return "an invisible character";
  if (u_isUWhiteSpace(c) && c != ' ') return "a space other than U+0020";
  return {};
}

struct SpoofChecker {
  USpoofChecker* checker = nullptr;
  USpoofCheckResult* result = nullptr;
  SpoofChecker() {
    UErrorCode e = U_ZERO_ERROR;
    checker = uspoof_open(&e);
    uspoof_setChecks(checker,
                     USPOOF_RESTRICTION_LEVEL | USPOOF_MIXED_SCRIPT_CONFUSABLE | USPOOF_INVISIBLE |
                         USPOOF_MIXED_NUMBERS,
                     &e);
    uspoof_setRestrictionLevel(checker, USPOOF_HIGHLY_RESTRICTIVE);
    result = uspoof_openCheckResult(&e);
    if (U_FAILURE(e)) throw Error(std::string("ICU spoof checker: ") + u_errorName(e));
  }
  ~SpoofChecker() {
    uspoof_closeCheckResult(result);
    uspoof_close(checker);
  }
};

// One per thread: a USpoofChecker is not to be shared while it checks.
SpoofChecker& spoof_checker() {
  thread_local SpoofChecker c;
  return c;
}

std::string to_utf8(const icu::UnicodeString& s) {
  std::string out;
  s.toUTF8String(out);
  return out;
}

// The letter whose script is not the word's most common one (the look-alike), for the error.
std::string odd_letter(const icu::UnicodeString& word) {
  std::map<UScriptCode, int> count;
  UErrorCode e = U_ZERO_ERROR;
  for (int32_t i = 0; i < word.length(); i = word.moveIndex32(i, 1)) {
    const UScriptCode s = uscript_getScript(word.char32At(i), &e);
    if (s != USCRIPT_COMMON && s != USCRIPT_INHERITED) ++count[s];
  }
  UScriptCode main = USCRIPT_INVALID_CODE;
  for (const auto& [s, n] : count)
    if (main == USCRIPT_INVALID_CODE || n > count[main]) main = s;
  for (int32_t i = 0; i < word.length(); i = word.moveIndex32(i, 1)) {
    const UChar32 c = word.char32At(i);
    const UScriptCode s = uscript_getScript(c, &e);
    if (s != USCRIPT_COMMON && s != USCRIPT_INHERITED && s != main)
      return describe(c) + " among " + uscript_getName(main) + " letters";
  }
  return "digits of several systems or repeated combining marks";
}

}  // namespace

std::string checked_name(std::string_view utf8, const char* what) {
  const std::string field(what);
  if (utf8.empty()) throw Error(field + " is empty");
  // Invalid UTF-8: fromUTF8 turns each bad sequence into U+FFFD; compare back.
  const icu::UnicodeString raw = icu::UnicodeString::fromUTF8(
      icu::StringPiece(utf8.data(), static_cast<int32_t>(utf8.size())));
  if (to_utf8(raw) != utf8) throw Error(field + " is not valid UTF-8");
  UErrorCode e = U_ZERO_ERROR;
  const icu::Normalizer2* nfc = icu::Normalizer2::getNFCInstance(e);
  if (U_FAILURE(e)) throw Error(std::string("ICU NFC normaliser: ") + u_errorName(e));
  const icu::UnicodeString name = nfc->normalize(raw, e);
  if (U_FAILURE(e)) throw Error(field + ": cannot be normalised (" + u_errorName(e) + ")");
  const std::string out = to_utf8(name);
  if (out.size() > kMaxNameBytes)
    throw Error(field + " must be 1 to " + std::to_string(kMaxNameBytes) + " bytes (UTF-8, NFC)");
  for (int32_t i = 0; i < name.length(); i = name.moveIndex32(i, 1)) {
    const UChar32 c = name.char32At(i);
    if (const std::string why = refused_character(c); !why.empty())
      throw Error(field + " has " + describe(c) + ", " + why);
  }
  // Each word on its own: a name may mix scripts between words ("Dr. Иванов"), a word may not.
  SpoofChecker& sc = spoof_checker();
  for (int32_t start = 0; start < name.length();) {
    int32_t end = name.indexOf(UChar(' '), start);
    if (end < 0) end = name.length();
    if (end > start) {
      const icu::UnicodeString word(name, start, end - start);
      UErrorCode ce = U_ZERO_ERROR;
      const int32_t flags = uspoof_check2UnicodeString(sc.checker, word, sc.result, &ce);
      if (U_FAILURE(ce)) throw Error(field + ": ICU spoof check failed (" + u_errorName(ce) + ")");
      if (flags != 0)
        throw Error(field + " has the word '" + to_utf8(word) + "', which mixes scripts like a " +
                    "look-alike does: " + odd_letter(word));
    }
    start = end + 1;
  }
  return out;
}

std::string name_skeleton(const std::string& name) {
  SpoofChecker& sc = spoof_checker();
  UErrorCode e = U_ZERO_ERROR;
  icu::UnicodeString skeleton;
  uspoof_getSkeletonUnicodeString(sc.checker, 0, icu::UnicodeString::fromUTF8(name), skeleton, &e);
  if (U_FAILURE(e)) throw Error(std::string("ICU skeleton: ") + u_errorName(e));
  return to_utf8(skeleton);
}

std::string cut_utf8(const std::string& text, size_t bytes) {
  if (text.size() <= bytes) return text;
  size_t n = bytes;
  while (n > 0 && (static_cast<unsigned char>(text[n]) & 0xc0) == 0x80) --n;
  return text.substr(0, n);
}

}  // namespace volcast::session
