#include "volcast/pipeline/sender.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>

#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

SitePlayer::SitePlayer(std::vector<std::unique_ptr<FrameSource>> sources, double fps,
                       const std::vector<FilterConfig>& filters)
    : sources_(std::move(sources)), fps_(fps) {
  if (sources_.empty()) throw Error("a site needs at least one --source");
  if (fps_ == 0)
    for (const auto& s : sources_) fps_ = std::max(fps_, s->fps());
  if (!(fps_ > 0 && fps_ <= 1000)) throw Error("--fps must be in (0, 1000]");
  if (!filters.empty() && filters.size() != sources_.size())
    throw Error("one filter configuration per camera is needed");
  chains_.resize(sources_.size());
  for (size_t i = 0; i < filters.size(); ++i)
    if (filters[i].any()) chains_[i].emplace(sources_[i]->calibration().depth, filters[i]);
}

SitePlayer::~SitePlayer() {
  stop();
}

std::vector<protocol::CameraInfo> SitePlayer::cameras() const {
  std::vector<protocol::CameraInfo> out;
  for (size_t i = 0; i < sources_.size(); ++i) {
    CameraCalibration cal = sources_[i]->calibration();
    if (chains_[i]) cal.depth = chains_[i]->output_intrinsics();
    out.push_back({cal, sources_[i]->description()});
  }
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

std::shared_ptr<CameraFrame> SitePlayer::spare_frame(size_t i) {
  for (auto& b : buffers_[i])
    if (b.use_count() == 1) return b;  // only this list holds it: no frame set, no encoder
  auto b = std::make_shared<CameraFrame>();
  if (buffers_[i].size() < 16) buffers_[i].push_back(b);
  return b;
}

void SitePlayer::run(Server& server) {
  using clock = std::chrono::steady_clock;
  const auto period =
      std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(1.0 / fps_));
  auto next = clock::now();
  const auto start = next;
  std::vector<clock::time_point> due(sources_.size(), start);  // when each source's next frame is
  last_frames_.assign(sources_.size(), nullptr);
  buffers_.resize(sources_.size());
  uint64_t sequence = 0;
  int failures = 0;
  while (!stop_) {
    std::this_thread::sleep_until(next);
    next += period;
    if (clock::now() > next) next = clock::now() + period;  // overran: skip ticks, never queue
    auto frames = std::make_shared<CapturedFrameSet>();
    try {
      const auto now = clock::now();
      // Read every source that is due first (capture), then filter (the stage after capture).
      std::vector<std::pair<size_t, CameraFrame>> read;
      for (size_t i = 0; i < sources_.size(); ++i) {
        if (now < due[i] && last_frames_[i]) continue;  // not its time yet: repeat its last frame
        due[i] += std::chrono::duration_cast<clock::duration>(
            std::chrono::duration<double>(1.0 / sources_[i]->fps()));
        if (due[i] < now) due[i] = now;  // fell behind: never queue source frames either
        read.emplace_back(i, sources_[i]->next());
      }
      frames->capture_time_us = wall_clock_us();
      for (auto& [i, frame] : read) {
        if (chains_[i]) {
          std::shared_ptr<CameraFrame> out = spare_frame(i);
          chains_[i]->apply(frame, *out);
          last_frames_[i] = std::move(out);
        } else {
          last_frames_[i] = std::make_shared<const CameraFrame>(std::move(frame));  // no copy
        }
      }
      frames->filter_done_us = wall_clock_us();
      frames->cameras = last_frames_;  // shares the frames, copies pointers
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
    server.publish(std::move(frames));
    ++published_;
  }
}

}  // namespace volcast
