#pragma once
// Join tokens and join links: what a viewer needs to join a session, in one line a person can
// copy from the server's console into `volcast view --connect`.
//
// A join token is 128 random bits (OpenSSL's CSPRNG), written as 32 lower-case hex digits. The
// viewer sends it in its Hello (protocol.hpp); the server compares it in constant time before it
// looks at any other byte the peer sent.
//
// A join link: volcast://HOST:PORT/?token=TOKEN&fp=FINGERPRINT
//   HOST         an IPv4 address, a host name, or an IPv6 address in brackets ([::1])
//   TOKEN        the join token (32 hex digits)
//   FINGERPRINT  SHA-256 of the server's TLS certificate (DER), 64 hex digits; absent for a
//                plain-TCP server (--insecure, loopback only), which adds `&insecure=1` instead.
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <string_view>

#include "volcast/net/protocol/protocol.hpp"

namespace volcast {

using JoinToken = std::array<uint8_t, protocol::kTokenBytes>;

/// A new random token. Throws Error if the system's random source fails.
JoinToken random_join_token();
/// 32 lower-case hex digits.
std::string to_hex(const JoinToken& token);
/// Parses 32 hex digits (either case; surrounding whitespace ignored). Throws Error("join token
/// must be 32 hex digits ...") otherwise; the message never repeats the input.
JoinToken parse_join_token(std::string_view text);
/// Reads a token file (32 hex digits, e.g. written by `openssl rand -hex 16 > FILE`). Throws Error
/// naming the file if it cannot be read or does not hold a token.
JoinToken read_token_file(const std::string& path);
/// Parses a certificate fingerprint: 64 hex digits (either case; colons between bytes allowed),
/// returned lower-case without colons. Throws Error otherwise.
std::string parse_fingerprint(std::string_view text);
/// Constant-time equality (CRYPTO_memcmp): the time taken does not depend on where they differ.
bool tokens_equal(std::span<const uint8_t> a, std::span<const uint8_t> b);

struct JoinLink {
  std::string host;         ///< without brackets
  uint16_t port = 0;        ///< 1..65535
  JoinToken token{};        ///< the session's join token
  std::string fingerprint;  ///< 64 lower-case hex digits, or empty when insecure
  bool insecure = false;    ///< plain TCP (loopback only)
};

/// The link's text (see the header comment).
std::string format_join_link(const JoinLink& link);
/// Parses a join link. Throws Error naming the part that is wrong (scheme, host, port, token,
/// fingerprint, an unknown parameter); the token is never echoed back.
JoinLink parse_join_link(std::string_view text);
/// True if `text` looks like a join link (starts with "volcast://").
bool is_join_link(std::string_view text);

}  // namespace volcast
