#include "volcast/net/protocol/frame_set.hpp"

#include <algorithm>
#include <cstring>
#include <optional>

#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/codec/registry.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/core/worker_pool.hpp"

namespace volcast::protocol {

using wire::Reader;
using wire::Writer;

namespace {

// A frame set body's fixed head (kFrameSetHeadBytes), which a SealedFrameSet copies.
void put_frame_set_head(Writer& w, uint64_t sequence, bool key, const SenderTimes& times) {
  w.put<uint64_t>(sequence);
  w.put<uint8_t>(key ? 1 : 0);
  w.put<int64_t>(times.capture_us);
  w.put<int64_t>(times.filter_done_us);
  w.put<int64_t>(times.encode_done_us);
}

// Reads that head into the given fields (times.send_us untouched); refuses unknown flags.
void get_frame_set_head(Reader& r, uint64_t& sequence, bool& key, SenderTimes& times) {
  sequence = r.get<uint64_t>();
  const uint8_t flags = r.get<uint8_t>();
  if (flags > 1) r.fail("unknown flags " + std::to_string(flags));
  key = flags & 1;
  times.capture_us = r.get<int64_t>();
  times.filter_done_us = r.get<int64_t>();
  times.encode_done_us = r.get<int64_t>();
}

}  // namespace

void rewrite_frame_set_head(std::span<uint8_t> body, uint64_t sequence, bool key,
                            const SenderTimes& times) {
  if (body.size() < kFrameSetHeadBytes)
    throw Error("protocol: a frame set body of " + std::to_string(body.size()) +
                " bytes has no head");
  std::vector<uint8_t> bytes;
  bytes.reserve(kFrameSetHeadBytes);
  Writer w(bytes);
  put_frame_set_head(w, sequence, key, times);
  std::copy(bytes.begin(), bytes.end(), body.begin());
}

void serialize_frame_set_body(uint64_t sequence, bool key, const SenderTimes& times,
                              std::span<const EncodedCamera> cameras, std::vector<uint8_t>& out) {
  out.clear();
  Writer w(out);
  put_frame_set_head(w, sequence, key, times);
  w.put<uint32_t>(static_cast<uint32_t>(cameras.size()));
  for (const EncodedCamera& c : cameras) {
    w.put<int64_t>(c.device_timestamp_us);
    w.put_bytes(c.depth);
    w.put_bytes(c.color);
  }
}

namespace {

// Header (payload = 8 + rest) and send time: how both frame set messages start for one viewer.
std::array<uint8_t, kFrameSetPrefixBytes> send_time_prefix(MessageType type, const char* what,
                                                           size_t rest_bytes, int64_t send_us,
                                                           uint32_t limit) {
  if (rest_bytes + 8 > limit) throw Error(std::string("protocol: ") + what + " too large to send");
  std::array<uint8_t, kFrameSetPrefixBytes> out;
  write_header(type, static_cast<uint32_t>(rest_bytes + 8), out.data());
  wire::store<int64_t>(out.data() + kHeaderBytes, send_us);
  return out;
}

}  // namespace

std::array<uint8_t, kFrameSetPrefixBytes> frame_set_prefix(size_t body_bytes, int64_t send_us) {
  return send_time_prefix(MessageType::kFrameSet, "frame set", body_bytes, send_us,
                          kMaxPayloadBytes);
}

void parse_frame_set(std::span<const uint8_t> payload, FrameSetView& out) {
  Reader r(payload, "frame set");
  out.times.send_us = r.get<int64_t>();
  get_frame_set_head(r, out.sequence, out.key, out.times);
  const uint32_t n = r.get<uint32_t>();
  if (n == 0 || n > kMaxCameras) r.fail("camera count " + std::to_string(n));
  out.cameras.resize(n);
  for (EncodedCameraView& c : out.cameras) {
    c.device_timestamp_us = r.get<int64_t>();
    c.depth = r.get_span();
    c.color = r.get_span();
  }
  r.expect_end();
}

namespace {

// Chunks of `body` bytes at `chunk` bytes each, or an empty optional for a chunk length out of
// range (not a power of two in [kMinSealChunkBytes, kMaxSealChunkBytes]).
std::optional<uint64_t> seal_chunk_count(uint64_t body, uint32_t chunk) {
  if (chunk < kMinSealChunkBytes || chunk > kMaxSealChunkBytes || (chunk & (chunk - 1)) != 0)
    return std::nullopt;
  return (body + chunk - 1) / chunk;
}

}  // namespace

void serialize_sealed_frame_set_rest(const SealedFrameSet& m, std::vector<uint8_t>& out) {
  const auto count = seal_chunk_count(m.body_bytes, m.chunk_bytes);
  if (!count || *count != m.chunks.size() || *count > kMaxSealChunks)
    throw Error("protocol: sealed frame set with " + std::to_string(m.chunks.size()) +
                " chunks of " + std::to_string(m.chunk_bytes) + " bytes for a body of " +
                std::to_string(m.body_bytes));
  out.clear();
  Writer w(out);
  put_frame_set_head(w, m.sequence, m.key_frame_set, m.times);
  w.put<uint32_t>(m.body_bytes);
  w.put<uint32_t>(m.chunk_bytes);
  w.append(m.key.data(), m.key.size());
  for (const SealChunk& c : m.chunks) {
    w.append(c.tag.data(), c.tag.size());
    w.append(c.digest.data(), c.digest.size());
  }
}

std::array<uint8_t, kFrameSetPrefixBytes> sealed_frame_set_prefix(size_t rest_bytes,
                                                                  int64_t send_us) {
  return send_time_prefix(MessageType::kSealedFrameSet, "sealed frame set descriptor", rest_bytes,
                          send_us, kMaxSealedFrameSetBytes);
}

void parse_sealed_frame_set(std::span<const uint8_t> payload, SealedFrameSet& out) {
  Reader r(payload, "sealed frame set");
  out.send_us = r.get<int64_t>();
  get_frame_set_head(r, out.sequence, out.key_frame_set, out.times);
  out.body_bytes = r.get<uint32_t>();
  out.chunk_bytes = r.get<uint32_t>();
  const auto count = seal_chunk_count(out.body_bytes, out.chunk_bytes);
  if (!count)
    r.fail("chunk length " + std::to_string(out.chunk_bytes) + " is not a power of two in [" +
           std::to_string(kMinSealChunkBytes) + ", " + std::to_string(kMaxSealChunkBytes) + "]");
  if (*count > kMaxSealChunks)
    r.fail(std::to_string(*count) + " chunks, more than " + std::to_string(kMaxSealChunks));
  for (uint8_t& b : out.key) b = r.get<uint8_t>();
  // The count is bounded above, and the payload must hold every chunk: check before resizing.
  if (payload.size() !=
      8 + kFrameSetHeadBytes + 4 + 4 + kSealKeyBytes + *count * (kSealTagBytes + kSealDigestBytes))
    r.fail("payload of " + std::to_string(payload.size()) + " bytes for " + std::to_string(*count) +
           " chunks");
  out.chunks.resize(static_cast<size_t>(*count));
  for (SealChunk& c : out.chunks) {
    for (uint8_t& b : c.tag) b = r.get<uint8_t>();
    for (uint8_t& b : c.digest) b = r.get<uint8_t>();
  }
  r.expect_end();
}

}  // namespace volcast::protocol

namespace volcast {

FrameSetDecoder::FrameSetDecoder(const std::string& depth_codec, const std::string& color_codec,
                                 std::vector<protocol::CameraInfo> cameras)
    : cameras_(std::move(cameras)) {
  for (size_t i = 0; i < cameras_.size(); ++i) {
    depth_.push_back(make_depth_decoder(depth_codec));
    color_.push_back(make_color_decoder(color_codec));
  }
  const DepthCodecInfo* d = find_depth_codec(depth_codec);
  const ColorCodecInfo* c = find_color_codec(color_codec);
  stateless_ = d && c && !d->temporal && !c->temporal;
}

FrameSetDecoder::~FrameSetDecoder() = default;
FrameSetDecoder::FrameSetDecoder(FrameSetDecoder&&) noexcept = default;
FrameSetDecoder& FrameSetDecoder::operator=(FrameSetDecoder&&) noexcept = default;

const protocol::FrameSetView& FrameSetDecoder::read(std::span<const uint8_t> message) {
  protocol::parse_frame_set(message, view_);
  if (view_.cameras.size() != cameras_.size())
    throw Error("frame set has " + std::to_string(view_.cameras.size()) +
                " cameras, the site has " + std::to_string(cameras_.size()));
  return view_;
}

void FrameSetDecoder::check_declared_sizes() const {
  for (size_t i = 0; i < view_.cameras.size() && i < cameras_.size(); ++i) {
    const Intrinsics& k = cameras_[i].calibration.depth;
    const auto check = [&](const char* stream, const std::optional<DeclaredSize>& size) {
      if (size && (size->width != k.width || size->height != k.height))
        throw Error("camera " + std::to_string(i) + " (" + printable(cameras_[i].description, 80) +
                    "): its " + stream + " stream declares " + std::to_string(size->width) + "x" +
                    std::to_string(size->height) + ", its calibration is " +
                    std::to_string(k.width) + "x" + std::to_string(k.height));
    };
    check("depth", declared_depth_size(view_.cameras[i].depth));
    check("color", declared_color_size(view_.cameras[i].color));
  }
}

void FrameSetDecoder::decode_cameras(FrameSet& out, WorkerPool* pool, std::span<const char> skip) {
  const size_t n = cameras_.size();
  out.cameras.resize(n);
  tasks_.clear();
  for (size_t i = 0; i < n; ++i) {
    out.cameras[i].device_timestamp_us = view_.cameras[i].device_timestamp_us;
    if (i < skip.size() && skip[i]) continue;
    tasks_.push_back(i);
    tasks_.push_back(n + i);
  }
  // Task t decodes depth (t < n) or color (t >= n) of camera t % n.
  const auto task = [&](size_t k) {
    const size_t t = tasks_[k], i = t % n;
    const protocol::EncodedCameraView& e = view_.cameras[i];
    CameraFrame& f = out.cameras[i];
    try {
      if (t < n)
        depth_[i]->decode(e.depth, f.depth);
      else if (e.color.empty())
        f.color = ColorImage{};  // zero-length color: none for this frame (protocol.hpp)
      else
        color_[i]->decode(e.color, f.color);
    } catch (const Error& err) {
      throw Error("camera " + std::to_string(i) + ": " + err.what());
    }
  };
  if (pool)
    pool->parallel_for(tasks_.size(), task);
  else
    for (size_t k = 0; k < tasks_.size(); ++k) task(k);
}

void FrameSetDecoder::decode(std::span<const uint8_t> message, FrameSet& out) {
  read(message);
  check_declared_sizes();
  out.sequence = view_.sequence;
  out.capture_time_us = view_.times.capture_us;
  decode_cameras(out);
}

}  // namespace volcast
