#include "volcast/cluster/chunks.hpp"

#include <algorithm>
#include <cstring>
#include <limits>
#include <string>

#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"

namespace volcast::cluster {
namespace {

constexpr uint8_t kMagic[4] = {'V', 'C', 'K', '1'};

}  // namespace

void chunk_frame_set(const ChunkedFrameSet& f, size_t max_message_bytes,
                     std::vector<uint8_t>& scratch,
                     const std::function<void(std::span<const uint8_t>)>& emit) {
  if (max_message_bytes <= kChunkHeaderBytes)
    throw Error("chunks: a message of " + std::to_string(max_message_bytes) +
                " bytes has no room for a chunk");
  if (f.body.empty()) throw Error("chunks: an empty frame set body");
  if (f.body.size() > std::numeric_limits<uint32_t>::max())
    throw Error("chunks: a frame set body of " + std::to_string(f.body.size()) + " bytes");
  const size_t per = max_message_bytes - kChunkHeaderBytes;
  const size_t count = (f.body.size() + per - 1) / per;
  if (count > std::numeric_limits<uint16_t>::max())
    throw Error("chunks: " + std::to_string(f.body.size()) + " bytes need " +
                std::to_string(count) + " chunks of " + std::to_string(per) + " (at most 65535)");
  for (size_t i = 0; i < count; ++i) {
    const size_t offset = i * per, n = std::min(per, f.body.size() - offset);
    scratch.resize(kChunkHeaderBytes + n);
    uint8_t* h = scratch.data();
    std::memcpy(h, kMagic, 4);
    wire::store<uint64_t>(h + 4, f.sequence);
    wire::store<int64_t>(h + 12, f.capture_us);
    wire::store<uint32_t>(h + 20, static_cast<uint32_t>(f.body.size()));
    wire::store<uint32_t>(h + 24, static_cast<uint32_t>(offset));
    wire::store<uint16_t>(h + 28, static_cast<uint16_t>(i));
    wire::store<uint16_t>(h + 30, static_cast<uint16_t>(count));
    h[32] = f.key ? 1 : 0;
    h[33] = h[34] = h[35] = 0;
    std::memcpy(h + kChunkHeaderBytes, f.body.data() + offset, n);
    emit(scratch);
  }
}

bool Reassembler::add(std::span<const uint8_t> m) {
  const auto refuse = [this] {
    ++stats_.malformed;
    return false;
  };
  if (m.size() <= kChunkHeaderBytes || std::memcmp(m.data(), kMagic, 4) != 0) return refuse();
  const uint8_t* h = m.data();
  const auto sequence = wire::load<uint64_t>(h + 4);
  const auto capture_us = wire::load<int64_t>(h + 12);
  const auto total = wire::load<uint32_t>(h + 20);
  const auto offset = wire::load<uint32_t>(h + 24);
  const auto index = wire::load<uint16_t>(h + 28);
  const auto count = wire::load<uint16_t>(h + 30);
  const uint8_t flags = h[32];
  const size_t n = m.size() - kChunkHeaderBytes;
  // Sizes first, before anything is allocated for them.
  if (total == 0 || total > max_body_bytes_ || count == 0 || index >= count ||
      static_cast<uint64_t>(offset) + n > total || (flags & ~1u) != 0 || h[33] || h[34] || h[35])
    return refuse();
  // The chunk size this chunk implies: every chunk but the last holds exactly that many bytes at
  // index * size, and the last ends the body, so a complete set covers each byte once.
  const bool last = index == count - 1;
  size_t per = n;
  if (last) {
    if (offset + n != total) return refuse();
    if (count == 1) {
      per = total;
    } else {
      if (offset % (count - 1) != 0) return refuse();
      per = offset / (count - 1);
      if (n > per) return refuse();
    }
  }
  if (per == 0 || static_cast<uint64_t>(index) * per != offset) return refuse();
  // A publisher that restarted counts from 1 again: the first chunk of a key frame set below
  // the current sequence starts over (NATS keeps one publisher's order, so nothing else is).
  const bool restart = started_ && sequence < sequence_ && (flags & 1) != 0 && index == 0;
  if (restart) {
    ++stats_.restarts;
  } else if (started_ && (sequence < sequence_ || (sequence == sequence_ && !active_))) {
    ++stats_.stale;  // older, or of the frame set already delivered
    return false;
  }
  if (restart || !active_ || sequence > sequence_) {
    if (active_) ++stats_.incomplete;
    started_ = active_ = true;
    sequence_ = sequence;
    capture_us_ = capture_us;
    key_ = (flags & 1) != 0;
    total_ = total;
    count_ = count;
    per_ = per;
    received_ = 0;
    body_.resize(total);
    have_.assign(count, false);
  } else if (total != total_ || count != count_ || per != per_ || capture_us != capture_us_ ||
             key_ != ((flags & 1) != 0)) {
    return refuse();  // disagrees with the frame set's first chunk
  }
  if (have_[index]) return false;  // a repeat
  have_[index] = true;
  std::memcpy(body_.data() + offset, h + kChunkHeaderBytes, n);
  if (++received_ < count_) return false;
  active_ = false;
  ++stats_.complete;
  return true;
}

ChunkedFrameSet Reassembler::done() const {
  return ChunkedFrameSet{sequence_, capture_us_, key_, body_};
}

}  // namespace volcast::cluster
