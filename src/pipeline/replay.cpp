#include "volcast/pipeline/replay.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <cstdlib>

#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

ReplayPlayer::ReplayPlayer(const std::filesystem::path& path, ReplayOptions options)
    : reader_(path),
      decoder_(reader_),
      options_(options),
      buffers_(reader_.info().stream.welcome.cameras.size()) {
  const auto& sets = reader_.info().frame_sets;
  if (sets.empty()) throw Error("replay " + path.string() + ": the recording holds no frame sets");
  timeline_ = playback_timeline(sets);
  if (timeline_.clamped_gaps)
    spdlog::warn(
        "replay {}: the capture time {} by {} between frame sets {} and {}; replaying them one "
        "frame interval ({}) apart{}",
        path.string(), timeline_.first_clamped_gap_us < 0 ? "goes back" : "jumps",
        describe_span_us(std::abs(timeline_.first_clamped_gap_us)), timeline_.first_clamped - 1,
        timeline_.first_clamped, describe_span_us(timeline_.frame_interval_us),
        timeline_.clamped_gaps > 1
            ? fmt::format(" ({} such gaps, each replayed so)", timeline_.clamped_gaps)
            : std::string());
  const auto at = [&](size_t k) { return static_cast<double>(timeline_.offset_us[k]) / 1e6; };
  first_ = sets.size();
  for (size_t k = 0; k < sets.size(); ++k)
    if (at(k) >= options.from_s - 1e-6) {
      first_ = k;
      break;
    }
  last_ = first_;
  for (size_t k = first_; k < sets.size() && (options.to_s < 0 || at(k) <= options.to_s + 1e-6);
       ++k)
    last_ = k;
  if (first_ >= sets.size() || (options.to_s >= 0 && options.to_s < options.from_s))
    throw Error("replay " + path.string() + ": no frame sets between " +
                std::to_string(options.from_s) + " s and " +
                (options.to_s < 0 ? std::string("the end") : std::to_string(options.to_s) + " s") +
                " (the recording lasts " + std::to_string(at(sets.size() - 1)) + " s)");
}

ReplayPlayer::~ReplayPlayer() {
  stop();
}

std::vector<protocol::CameraInfo> ReplayPlayer::cameras() const {
  return reader_.info().stream.welcome.cameras;
}

double ReplayPlayer::fps() const {
  const int64_t span = timeline_.offset_us[last_] - timeline_.offset_us[first_];
  return last_ > first_ && span > 0
             ? static_cast<double>(last_ - first_) * 1e6 / static_cast<double>(span)
             : 30.0;
}

void ReplayPlayer::start(Server& server) {
  start([&server](std::shared_ptr<const CapturedFrameSet> f) { server.publish(std::move(f)); });
}

void ReplayPlayer::start(Publish publish) {
  stop();
  stop_ = false;
  finished_ = false;
  thread_ = std::thread([this, publish = std::move(publish)] { run(publish); });
}

void ReplayPlayer::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void ReplayPlayer::run(const Publish& publish) {
  using Clock = std::chrono::steady_clock;
  const auto& sets = reader_.info().frame_sets;
  const RecordingStream& s = reader_.info().stream;
  const size_t n = s.welcome.cameras.size();
  FrameSet decoded;
  decoded.cameras.resize(n);
  uint64_t sequence = 0, position = 0;
  std::string last_warning;
  while (!stop_) {
    const auto start = Clock::now();
    position += 2;  // a new pass: its first delta does not follow the last pass's end
    for (size_t k = first_; k <= last_ && !stop_; ++k, ++position) {
      const auto due =
          start + std::chrono::microseconds(timeline_.offset_us[k] - timeline_.offset_us[first_]);
      while (!stop_ && Clock::now() < due)
        std::this_thread::sleep_for(
            std::min<Clock::duration>(due - Clock::now(), std::chrono::milliseconds(20)));
      if (stop_) break;
      auto frames = std::make_shared<CapturedFrameSet>();
      frames->capture_time_us = wall_clock_us();
      try {
        decoder_.decode(k, decoded);
      } catch (const Error& e) {
        ++skipped_;
        if (e.what() != last_warning) spdlog::warn("replay: frame set {} skipped: {}", k, e.what());
        last_warning = e.what();
        continue;
      }
      // Each camera's images go to a recycled frame no published frame set holds any more, whose
      // old buffers the next decode reuses (decoders keep their own references).
      for (size_t i = 0; i < n; ++i) {
        std::shared_ptr<CameraFrame> f = buffers_.take(i);
        std::swap(decoded.cameras[i], *f);
        frames->cameras.push_back(std::move(f));
      }
      auto body = std::make_shared<EncodedFrameSetBody>();
      body->depth_codec = s.depth_codec;
      body->color_codec = s.color_codec;
      body->color_quality = s.color_quality;
      body->position = position;
      body->key = sets[k].key;
      const auto b = decoder_.body();
      body->body.assign(b.begin(), b.end());
      frames->encoded = std::move(body);
      frames->sequence = ++sequence;
      frames->filter_done_us = wall_clock_us();
      publish(std::move(frames));
      ++published_;
    }
    if (!options_.loop) break;
  }
  finished_ = true;
}

}  // namespace volcast
