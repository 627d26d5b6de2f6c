#include "tier_encoder.hpp"

#include <time.h>

#include <algorithm>

#include "volcast/codec/registry.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/stream/seal.hpp"

namespace volcast::detail {
namespace {

// CPU time of the calling thread, milliseconds.
double thread_cpu_ms() {
  timespec t{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) / 1e6;
}

// A codec's encode_ns_per_pixel, or the costliest of `all` where it has none.
template <typename Info>
double ns_per_pixel(const Info& info, const std::vector<Info>& all) {
  if (info.encode_ns_per_pixel >= 0) return info.encode_ns_per_pixel;
  double most = 0;
  for (const Info& i : all) most = std::max(most, i.encode_ns_per_pixel);
  return most;
}

}  // namespace

double tier_encode_ns(const Tier& key, uint64_t pixels) {
  const double depth = ns_per_pixel(depth_codec_info(key.depth_codec), all_depth_codecs());
  const double color = ns_per_pixel(color_codec_info(key.color_codec), all_color_codecs());
  return (depth + color) * static_cast<double>(pixels);
}

TierEncoder::TierEncoder(Tier key, size_t cameras) : key_(std::move(key)) {
  for (size_t i = 0; i < cameras; ++i) {
    depth_.push_back(make_depth_encoder(key_.depth_codec));
    color_.push_back(make_color_encoder(key_.color_codec));
    if (key_.color_quality > 0) color_.back()->set_quality(key_.color_quality);
  }
  encoded_.resize(cameras);
  key_flags_.resize(2 * cameras);
  color_gap_.resize(cameras);
  last_.resize(cameras);
  const DepthCodecInfo* d = find_depth_codec(key_.depth_codec);
  const ColorCodecInfo* c = find_color_codec(key_.color_codec);
  stateless_ = d && c && !d->temporal && !c->temporal;
}

std::shared_ptr<const EncodedFrames> TierEncoder::encode(const CapturedFrameSet& frames, bool key,
                                                         WorkerPool& pool, bool seal) {
  const size_t n = depth_.size();
  if (frames.cameras.size() != n) throw Error("tier: frame set has the wrong number of cameras");
  // A buffer no viewer still holds (only this list does) is reused; else a new one joins the list.
  std::shared_ptr<EncodedFrames> out;
  for (auto& b : buffers_)
    if (b.use_count() == 1) {
      out = b;
      break;
    }
  if (!out) {
    out = std::make_shared<EncodedFrames>();
    if (buffers_.size() < 64) buffers_.push_back(out);
  }
  protocol::SenderTimes times;
  times.capture_us = frames.capture_time_us;
  times.filter_done_us = frames.filter_done_us;
  const EncodedFrameSetBody* pre = frames.encoded.get();
  const bool same_tier =
      pre && pre->tier == key_ && pre->body.size() >= protocol::kFrameSetHeadBytes;
  if (same_tier && (pre->key || (!key && passing_ && pre->position == passed_position_ + 1))) {
    // The recorded bytes as they are; only the head (sequence, flags, times) is this server's.
    out->body.assign(pre->body.begin(), pre->body.end());
    out->key = pre->key;
    out->encode_done_us = wall_clock_us();
    times.encode_done_us = out->encode_done_us;
    protocol::rewrite_frame_set_head(out->body, frames.sequence, pre->key, times);
    passing_ = true;
    passed_position_ = pre->position;
    encoders_stale_ = true;
    std::fill(last_.begin(), last_.end(), nullptr);
    last_cpu_ms_ = 0;
    finish(frames.sequence, out, times, pool, seal);
    return out;
  }
  passing_ = false;
  if (encoders_stale_) key = true;  // the encoders' references are older than the viewers'
  encoders_stale_ = false;
  // Tasks 0..n-1 encode depth, n..2n-1 color: the slowest of the 2n sets the time. A repeated
  // frame of a stateless tier keeps last time's bytes (and key flags: always key).
  tasks_.clear();
  for (size_t t = 0; t < 2 * n; ++t)
    if (!(stateless_ && last_[t % n] == frames.cameras[t % n])) tasks_.push_back(t);
  task_cpu_ms_.assign(tasks_.size(), 0);
  pool.parallel_for(tasks_.size(), [&](size_t k) {
    const double cpu_start = thread_cpu_ms();
    const size_t t = tasks_[k], i = t % n;
    const CameraFrame& f = *frames.cameras[i];
    if (t < n) {
      key_flags_[t] = depth_[i]->encode(f.depth, key, encoded_[i].depth);
    } else if (f.color.empty()) {
      // No color: zero bytes (protocol.hpp), which decode on their own. The encoder is not
      // called, so a temporal one keeps its reference; its next frame is a key frame all the
      // same, for viewers that started on a frame set without this camera's color.
      encoded_[i].color.clear();
      key_flags_[t] = 1;
      color_gap_[i] = 1;
    } else {
      key_flags_[t] = color_[i]->encode(f.color, key || color_gap_[i], encoded_[i].color);
      color_gap_[i] = 0;
    }
    task_cpu_ms_[k] = thread_cpu_ms() - cpu_start;
  });
  last_cpu_ms_ = 0;
  for (const double ms : task_cpu_ms_) last_cpu_ms_ += ms;
  for (size_t i = 0; i < n; ++i) last_[i] = frames.cameras[i];
  bool all_key = true;
  for (size_t i = 0; i < n; ++i) {
    encoded_[i].device_timestamp_us = frames.cameras[i]->device_timestamp_us;
    all_key = all_key && key_flags_[i] && key_flags_[n + i];
  }
  out->key = all_key;
  out->encode_done_us = wall_clock_us();
  times.encode_done_us = out->encode_done_us;
  protocol::serialize_frame_set_body(frames.sequence, all_key, times, encoded_, out->body);
  finish(frames.sequence, out, times, pool, seal);
  return out;
}

void TierEncoder::finish(uint64_t sequence, const std::shared_ptr<EncodedFrames>& out,
                         const protocol::SenderTimes& times, WorkerPool& pool, bool seal) {
  out->sequence = sequence;
  out->index = ++index_;
  out->capture_us = times.capture_us;
  if (seal) {  // a recycled buffer of the same size is not cleared or zero-filled again
    seal_scratch_.sequence = sequence;
    seal_scratch_.key_frame_set = out->key;
    seal_scratch_.times = times;
    seal_body(out->body, kSealChunkBytes, seal_scratch_, out->sealed, &pool);
    protocol::serialize_sealed_frame_set_rest(seal_scratch_, out->seal_rest);
  } else {
    out->sealed.clear();
    out->seal_rest.clear();
  }
}

}  // namespace volcast::detail
