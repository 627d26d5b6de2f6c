#pragma once
// A browser's side of the server's web door, spoken by hand (a test's own HTTP and RFC 6455
// framing: the server under test uses WebSocket++), over any Connection -- plain TCP or TLS.
#include <chrono>
#include <cstdint>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "volcast/core/error.hpp"
#include "volcast/net/transport/connection.hpp"

namespace volcast::test {

/// Writes `text` (an HTTP request, say) on `c`.
inline void write_text(Connection& c, const std::string& text) {
  c.write_all(std::span(reinterpret_cast<const uint8_t*>(text.data()), text.size()), 2000);
}

/// Reads everything until the server closes (at most `limit` bytes, 5 s).
inline std::string read_to_close(Connection& c, size_t limit = 1 << 22) {
  std::string out;
  uint8_t buffer[4096];
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(5);
  try {
    while (out.size() < limit && std::chrono::steady_clock::now() < deadline) {
      const size_t n = c.read_available(buffer);
      if (n == 0) {
        c.wait(-1, 100);
        continue;
      }
      out.append(reinterpret_cast<char*>(buffer), n);
    }
  } catch (const Error&) {  // closed
  }
  return out;
}

/// One masked client frame (RFC 6455 5.2): FIN, `opcode`, mask key 1 2 3 4; its length field
/// says `claimed_length` if given (a lie), else the payload's size.
inline std::vector<uint8_t> client_frame(uint8_t opcode, std::span<const uint8_t> payload,
                                         uint64_t claimed_length = UINT64_MAX) {
  const uint64_t n = claimed_length == UINT64_MAX ? payload.size() : claimed_length;
  std::vector<uint8_t> f = {static_cast<uint8_t>(0x80 | opcode)};
  if (n < 126) {
    f.push_back(static_cast<uint8_t>(0x80 | n));
  } else if (n < 65536) {
    f.insert(f.end(), {0x80 | 126, static_cast<uint8_t>(n >> 8), static_cast<uint8_t>(n)});
  } else {
    f.push_back(0x80 | 127);
    for (int i = 7; i >= 0; --i) f.push_back(static_cast<uint8_t>(n >> (8 * i)));
  }
  const uint8_t mask[4] = {1, 2, 3, 4};
  f.insert(f.end(), mask, mask + 4);
  for (size_t i = 0; i < payload.size(); ++i) f.push_back(payload[i] ^ mask[i % 4]);
  return f;
}

/// Asks for a WebSocket on /stream over `c`; returns the server's answer (its head only: the
/// bytes up to the blank line, "HTTP/1.1 101 ..." when it opened).
inline std::string upgrade_to_websocket(Connection& c) {
  write_text(c,
             "GET /stream HTTP/1.1\r\nHost: 127.0.0.1\r\nUpgrade: websocket\r\nConnection: "
             "Upgrade\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: "
             "13\r\n\r\n");
  std::string answer;
  uint8_t b;
  while (answer.find("\r\n\r\n") == std::string::npos) {
    c.read_exact(std::span(&b, 1), 5000);
    answer.push_back(static_cast<char>(b));
  }
  return answer;
}

/// Reads one unmasked server frame: its opcode and payload.
inline std::pair<uint8_t, std::vector<uint8_t>> server_frame(Connection& c) {
  uint8_t h[2];
  c.read_exact(h, 5000);
  uint64_t n = h[1] & 0x7f;
  if (n == 126 || n == 127) {
    uint8_t ext[8];
    const size_t k = n == 126 ? 2 : 8;
    c.read_exact(std::span(ext, k), 5000);
    n = 0;
    for (size_t i = 0; i < k; ++i) n = n << 8 | ext[i];
  }
  if (n > (64u << 20)) throw Error("server frame of " + std::to_string(n) + " bytes");
  std::vector<uint8_t> payload(n);
  c.read_exact(payload, 5000);
  return {static_cast<uint8_t>(h[0] & 0x0f), payload};
}

}  // namespace volcast::test
