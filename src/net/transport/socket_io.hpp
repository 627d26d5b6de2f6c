#pragma once
// Internal: blocking-with-deadline reads and gather writes on a non-blocking stream socket, shared
// by the plain TCP connection and the raw (sealed) bytes of a TLS connection.
#include <sys/uio.h>

#include <atomic>
#include <cstdint>
#include <span>

namespace volcast::detail {

/// Reads exactly `data.size()` bytes from `fd`. `timeout_ms` < 0 waits without limit. Throws
/// Error("timed out waiting for the peer" | "peer closed the connection" | "connection shut down"
/// | "read failed: reason"); polls at least every 100 ms to notice `shut`.
void recv_exact(int fd, std::span<uint8_t> data, int timeout_ms, const std::atomic<bool>& shut);

/// Writes every byte of `iov[0, count)` in order with sendmsg (MSG_NOSIGNAL), advancing `iov` as
/// it goes (the array is modified). Throws Error if the peer accepts nothing for `stall_ms`
/// ("peer stalled: ..."), the socket fails, or `shut` is set.
void send_all(int fd, iovec* iov, size_t count, int stall_ms, const std::atomic<bool>& shut);

}  // namespace volcast::detail
