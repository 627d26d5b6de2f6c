#pragma once
// Internal: deadline-bounded reads and writes on a non-blocking asio socket, so a silent or
// stalled peer can never hold a server thread forever.
#include <poll.h>

#include <asio.hpp>
#include <atomic>
#include <chrono>
#include <string>

#include "volcast/core/error.hpp"

namespace volcast::detail {

/// Waits until the socket is readable (POLLIN) or writable (POLLOUT), at most `ms`.
inline bool wait_ready(asio::ip::tcp::socket& s, short events, int ms) {
  pollfd p{s.native_handle(), events, 0};
  return ::poll(&p, 1, ms) > 0;
}

/// Reads exactly `size` bytes. Throws Error if `timeout_ms` passes with no complete read, the peer
/// closes, or `stop` becomes true.
inline void read_exact(asio::ip::tcp::socket& s, uint8_t* data, size_t size, int timeout_ms,
                       const std::atomic<bool>& stop) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  size_t done = 0;
  while (done < size) {
    if (stop) throw Error("server stopping");
    asio::error_code ec;
    done += s.read_some(asio::buffer(data + done, size - done), ec);
    if (ec == asio::error::would_block || ec == asio::error::try_again) {
      if (std::chrono::steady_clock::now() > deadline)
        throw Error("timed out waiting for the peer");
      wait_ready(s, POLLIN, 50);
    } else if (ec == asio::error::eof) {
      throw Error("peer closed the connection");
    } else if (ec) {
      throw Error("read failed: " + ec.message());
    }
  }
}

/// Writes all bytes. Throws Error if the peer accepts nothing for `stall_ms`, the connection
/// breaks, or `stop` becomes true.
inline void write_all(asio::ip::tcp::socket& s, const uint8_t* data, size_t size, int stall_ms,
                      const std::atomic<bool>& stop) {
  auto last_progress = std::chrono::steady_clock::now();
  size_t done = 0;
  while (done < size) {
    if (stop) throw Error("server stopping");
    asio::error_code ec;
    const size_t n = s.write_some(asio::buffer(data + done, size - done), ec);
    if (n > 0) {
      done += n;
      last_progress = std::chrono::steady_clock::now();
    }
    if (ec == asio::error::would_block || ec == asio::error::try_again) {
      if (std::chrono::steady_clock::now() - last_progress > std::chrono::milliseconds(stall_ms))
        throw Error("viewer stalled: accepted no data for " + std::to_string(stall_ms) + " ms");
      wait_ready(s, POLLOUT, 50);
    } else if (ec) {
      throw Error("write failed: " + ec.message());
    }
  }
}

}  // namespace volcast::detail
