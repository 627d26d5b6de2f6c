#include "tier_encoder.hpp"

#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"

namespace volcast::detail {

TierEncoder::TierEncoder(TierKey key, size_t cameras) : key_(std::move(key)) {
  for (size_t i = 0; i < cameras; ++i) {
    depth_.push_back(make_depth_encoder(key_.depth_codec));
    color_.push_back(make_color_encoder(key_.color_codec));
    if (key_.color_quality > 0) color_.back()->set_quality(key_.color_quality);
  }
  encoded_.resize(cameras);
  key_flags_.resize(2 * cameras);
}

std::shared_ptr<const EncodedFrames> TierEncoder::encode(const CapturedFrameSet& frames, bool key,
                                                         WorkerPool& pool) {
  const size_t n = depth_.size();
  if (frames.cameras.size() != n) throw Error("tier: frame set has the wrong number of cameras");
  // Tasks 0..n-1 encode depth, n..2n-1 color: the slowest of the 2n sets the time.
  pool.parallel_for(2 * n, [&](size_t t) {
    const size_t i = t % n;
    const CameraFrame& f = *frames.cameras[i];
    key_flags_[t] = t < n ? depth_[i]->encode(f.depth, key, encoded_[i].depth)
                          : color_[i]->encode(f.color, key, encoded_[i].color);
  });
  bool all_key = true;
  for (size_t i = 0; i < n; ++i) {
    encoded_[i].device_timestamp_us = frames.cameras[i]->device_timestamp_us;
    all_key = all_key && key_flags_[i] && key_flags_[n + i];
  }
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
  out->sequence = frames.sequence;
  out->index = ++index_;
  out->key = all_key;
  out->capture_us = frames.capture_time_us;
  out->encode_done_us = wall_clock_us();
  protocol::SenderTimes times;
  times.capture_us = frames.capture_time_us;
  times.filter_done_us = frames.filter_done_us;
  times.encode_done_us = out->encode_done_us;
  protocol::serialize_frame_set_body(frames.sequence, all_key, times, encoded_, out->body);
  return out;
}

}  // namespace volcast::detail
