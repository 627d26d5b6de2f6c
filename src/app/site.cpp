#include "site.hpp"

#include <spdlog/spdlog.h>

#include <chrono>

#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

SitePlayer::SitePlayer(std::vector<std::unique_ptr<FrameSource>> sources, double fps)
    : sources_(std::move(sources)), fps_(fps) {
  if (sources_.empty()) throw Error("a site needs at least one --source");
  if (!(fps_ > 0 && fps_ <= 1000)) throw Error("--fps must be in (0, 1000]");
}

SitePlayer::~SitePlayer() {
  stop();
}

std::vector<protocol::CameraInfo> SitePlayer::cameras() const {
  std::vector<protocol::CameraInfo> out;
  for (const auto& s : sources_) out.push_back({s->calibration(), s->description()});
  return out;
}

void SitePlayer::start(Server& server) {
  stop_ = false;
  thread_ = std::thread([this, &server] { run(server); });
}

void SitePlayer::stop() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void SitePlayer::run(Server& server) {
  using clock = std::chrono::steady_clock;
  const auto period =
      std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(1.0 / fps_));
  auto next = clock::now();
  uint64_t sequence = 0;
  int failures = 0;
  while (!stop_) {
    std::this_thread::sleep_until(next);
    next += period;
    if (clock::now() > next) next = clock::now() + period;  // overran: skip ticks, never queue
    auto frames = std::make_shared<FrameSet>();
    try {
      for (auto& s : sources_) frames->cameras.push_back(s->next());
      failures = 0;
    } catch (const std::exception& e) {
      spdlog::error("site: skipping a frame set: {}", e.what());
      if (++failures >= 30) {
        spdlog::error("site: 30 frame sets in a row failed to read; stopping playback");
        return;
      }
      continue;
    }
    frames->sequence = ++sequence;
    frames->capture_time_us = wall_clock_us();
    server.publish(std::move(frames));
    ++published_;
  }
}

}  // namespace volcast
