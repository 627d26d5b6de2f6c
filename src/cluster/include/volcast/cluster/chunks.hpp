#pragma once
// A tier's encoded frame sets cut into messages no larger than a NATS server's max_payload, and
// put back together on the receiving side (issue 17: the stream over a NATS cluster).
//
// Wire format of one chunk (all integers little-endian), as published:
//   offset size
//        0    4  magic "VCK1"
//        4    8  sequence: the tier's frame set number (uint64; 1, 2, ... from the publisher's
//                start: a delta decodes after sequence - 1)
//       12    8  capture_us: the sender's wall clock at capture (int64, µs since the Unix epoch)
//       20    4  total: the frame set body's size in bytes (uint32, 1..max_body_bytes)
//       24    4  offset: where this chunk's bytes go in the body (uint32)
//       28    2  index: this chunk's number (uint16, 0..count-1)
//       30    2  count: chunks of this frame set (uint16, >= 1)
//       32    1  flags: bit 0 = key frame set (every camera decodes on its own); others 0
//       33    3  reserved, 0
//       36    …  the body's bytes [offset, offset + n), n = message size - 36
// A body is `total` bytes: the FrameSet body exactly as the tier sends it to viewers
// (volcast/net/protocol/protocol.hpp).
#include <cstddef>
#include <cstdint>
#include <functional>
#include <span>
#include <vector>

namespace volcast::cluster {

inline constexpr size_t kChunkHeaderBytes = 36;

/// One frame set as carried: the body and what a receiver needs besides it.
struct ChunkedFrameSet {
  uint64_t sequence = 0;
  int64_t capture_us = 0;
  bool key = false;
  std::span<const uint8_t> body;
};

/// Cuts `f.body` into chunks of at most `max_message_bytes` (header included) and calls `emit`
/// with each message, in order; `scratch` is reused between calls (no allocation once grown).
/// Throws Error if max_message_bytes <= kChunkHeaderBytes, the body is empty or larger than
/// 4 GiB - 1, or it needs more than 65535 chunks.
void chunk_frame_set(const ChunkedFrameSet& f, size_t max_message_bytes,
                     std::vector<uint8_t>& scratch,
                     const std::function<void(std::span<const uint8_t>)>& emit);

/// Counts of what a Reassembler saw.
struct ReassemblyStats {
  uint64_t complete = 0;    ///< frame sets delivered
  uint64_t incomplete = 0;  ///< frame sets abandoned for a newer one before all chunks came
  uint64_t stale = 0;       ///< chunks of a frame set older than the one being assembled
  uint64_t malformed = 0;   ///< chunks refused: bad magic, sizes or fields that disagree
  uint64_t restarts = 0;    ///< the publisher started over (a key frame set below the sequence)
};

/// Puts chunks back together, one frame set at a time (NATS delivers a publisher's messages in
/// order; a chunk of a newer frame set abandons the one in progress; chunks of older or already
/// delivered frame sets are stale, except the first chunk of a key frame set: the publisher
/// restarted and counts from 1 again). A chunk must sit where its index says (index x the chunk
/// size, every chunk but the last full), so a completed body is covered exactly once. Every
/// peer-supplied size is checked against `max_body_bytes` before anything is allocated; a malformed
/// chunk is counted and dropped, never thrown.
class Reassembler {
 public:
  explicit Reassembler(size_t max_body_bytes) : max_body_bytes_(max_body_bytes) {}

  /// Takes one message. Returns true when it completed a frame set, which is then `done()` until
  /// the next call.
  bool add(std::span<const uint8_t> message);
  /// The frame set just completed (body valid until the next add()).
  ChunkedFrameSet done() const;
  const ReassemblyStats& stats() const { return stats_; }

 private:
  size_t max_body_bytes_;
  bool started_ = false;  // a frame set has begun (sequence_ is meaningful)
  bool active_ = false;   // ... and is still missing chunks
  uint64_t sequence_ = 0;
  int64_t capture_us_ = 0;
  bool key_ = false;
  uint32_t total_ = 0;
  uint16_t count_ = 0, received_ = 0;
  size_t per_ = 0;  // bytes in every chunk but the last
  std::vector<uint8_t> body_;
  std::vector<bool> have_;
  ReassemblyStats stats_;
};

}  // namespace volcast::cluster
