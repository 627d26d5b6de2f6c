#include "volcast/net/protocol/join.hpp"

#include <openssl/crypto.h>
#include <openssl/rand.h>

#include <cctype>
#include <charconv>
#include <fstream>
#include <sstream>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

int hex_value(char c) {
  if (c >= '0' && c <= '9') return c - '0';
  if (c >= 'a' && c <= 'f') return c - 'a' + 10;
  if (c >= 'A' && c <= 'F') return c - 'A' + 10;
  return -1;
}

std::string_view trim(std::string_view s) {
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.front()))) s.remove_prefix(1);
  while (!s.empty() && std::isspace(static_cast<unsigned char>(s.back()))) s.remove_suffix(1);
  return s;
}

bool is_hex(std::string_view s, size_t digits) {
  if (s.size() != digits) return false;
  for (char c : s)
    if (hex_value(c) < 0) return false;
  return true;
}

std::string lower(std::string_view s) {
  std::string out(s);
  for (char& c : out) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return out;
}

}  // namespace

JoinToken random_join_token() {
  JoinToken t{};
  if (RAND_bytes(t.data(), static_cast<int>(t.size())) != 1)
    throw Error("cannot make a join token: the system's random source failed");
  return t;
}

std::string to_hex(const JoinToken& token) {
  static const char kDigits[] = "0123456789abcdef";
  std::string out;
  for (uint8_t b : token) {
    out += kDigits[b >> 4];
    out += kDigits[b & 15];
  }
  return out;
}

JoinToken parse_join_token(std::string_view text) {
  text = trim(text);
  if (!is_hex(text, 2 * protocol::kTokenBytes))
    throw Error("join token must be 32 hex digits (" + std::to_string(text.size()) +
                " characters given)");
  JoinToken t{};
  for (size_t i = 0; i < t.size(); ++i)
    t[i] = static_cast<uint8_t>(hex_value(text[2 * i]) << 4 | hex_value(text[2 * i + 1]));
  return t;
}

JoinToken read_token_file(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot read token file '" + path + "'");
  std::ostringstream s;
  s << in.rdbuf();
  try {
    return parse_join_token(s.str());
  } catch (const Error& e) {
    throw Error("token file '" + path + "': " + e.what());
  }
}

std::string parse_fingerprint(std::string_view text) {
  std::string digits;
  for (char c : trim(text))
    if (c != ':') digits += c;
  if (!is_hex(digits, 64))
    throw Error("a certificate fingerprint is the 64 hex digits of a SHA-256 hash");
  return lower(digits);
}

bool tokens_equal(std::span<const uint8_t> a, std::span<const uint8_t> b) {
  return a.size() == b.size() && CRYPTO_memcmp(a.data(), b.data(), a.size()) == 0;
}

bool is_join_link(std::string_view text) {
  return trim(text).starts_with("volcast://");
}

std::string format_join_link(const JoinLink& link) {
  const bool v6 = link.host.find(':') != std::string::npos;
  std::string out = "volcast://" + (v6 ? "[" + link.host + "]" : link.host) + ":" +
                    std::to_string(link.port) + "/?token=" + to_hex(link.token);
  if (link.insecure)
    out += "&insecure=1";
  else
    out += "&fp=" + link.fingerprint;
  return out;
}

JoinLink parse_join_link(std::string_view text) {
  text = trim(text);
  constexpr std::string_view kScheme = "volcast://";
  if (!text.starts_with(kScheme)) throw Error("join link must start with volcast://");
  text.remove_prefix(kScheme.size());
  const size_t slash = text.find('/');
  const std::string_view authority = text.substr(0, slash);
  const std::string_view rest = slash == std::string_view::npos ? "" : text.substr(slash + 1);
  JoinLink link;
  std::string_view port_text;
  if (authority.starts_with('[')) {
    const size_t close = authority.find(']');
    if (close == std::string_view::npos || authority.substr(close + 1).size() < 2 ||
        authority[close + 1] != ':')
      throw Error("join link: an IPv6 host is written [ADDRESS]:PORT");
    link.host = std::string(authority.substr(1, close - 1));
    port_text = authority.substr(close + 2);
  } else {
    const size_t colon = authority.rfind(':');
    if (colon == std::string_view::npos) throw Error("join link: HOST:PORT missing");
    link.host = std::string(authority.substr(0, colon));
    port_text = authority.substr(colon + 1);
  }
  if (link.host.empty() || link.host.size() > 253) throw Error("join link: host missing");
  for (char c : link.host)
    if (!std::isalnum(static_cast<unsigned char>(c)) && c != '.' && c != '-' && c != ':' &&
        c != '_' && c != '%')
      throw Error("join link: the host has characters a host name cannot have");
  unsigned port = 0;
  const auto [end, ec] =
      std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (ec != std::errc() || end != port_text.data() + port_text.size() || port == 0 || port > 65535)
    throw Error("join link: the port must be 1-65535");
  link.port = static_cast<uint16_t>(port);

  std::string_view query = rest;
  if (query.starts_with('?')) query.remove_prefix(1);
  bool have_token = false;
  while (!query.empty()) {
    const size_t amp = query.find('&');
    const std::string_view pair = query.substr(0, amp);
    query = amp == std::string_view::npos ? "" : query.substr(amp + 1);
    const size_t eq = pair.find('=');
    const std::string_view key = pair.substr(0, eq);
    const std::string_view value = eq == std::string_view::npos ? "" : pair.substr(eq + 1);
    if (key == "token") {
      link.token = parse_join_token(value);
      have_token = true;
    } else if (key == "fp") {
      try {
        link.fingerprint = parse_fingerprint(value);
      } catch (const Error& e) {
        throw Error(std::string("join link: fp: ") + e.what());
      }
    } else if (key == "insecure") {
      link.insecure = value == "1";
    } else if (!key.empty()) {
      throw Error("join link: unknown parameter (only token, fp and insecure)");
    }
  }
  if (!have_token) throw Error("join link: token missing");
  if (link.insecure == !link.fingerprint.empty())
    throw Error("join link: needs fp (the server's certificate) or insecure=1, not both");
  return link;
}

}  // namespace volcast
