#include "volcast/pipeline/sender.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <thread>

#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

namespace {

// Distinct read errors remembered per camera (so that each is logged once); past this many, new
// ones are no longer logged one by one.
constexpr size_t kMaxRememberedErrors = 1024;

}  // namespace

SitePlayer::SitePlayer(std::vector<std::unique_ptr<FrameSource>> sources, double fps,
                       const std::vector<FilterConfig>& filters, SiteOptions options)
    : sources_(std::move(sources)), options_(std::move(options)), fps_(fps) {
  if (sources_.empty()) throw Error("a site needs at least one --source");
  if (fps_ == 0)
    for (const auto& s : sources_) fps_ = std::max(fps_, s->fps());
  if (!(fps_ > 0 && fps_ <= 1000)) throw Error("--fps must be in (0, 1000]");
  if (options_.max_read_failures < 1) throw Error("--max-read-failures must be at least 1");
  if (bool(options_.now_us) != bool(options_.sleep_until_us))
    throw Error("a site's clock needs both now_us and sleep_until_us");
  if (!options_.now_us) {
    options_.now_us = [] {
      return std::chrono::duration_cast<std::chrono::microseconds>(
                 std::chrono::steady_clock::now().time_since_epoch())
          .count();
    };
    options_.sleep_until_us = [](int64_t t) {
      std::this_thread::sleep_until(
          std::chrono::steady_clock::time_point(std::chrono::microseconds(t)));
    };
  }
  if (!filters.empty() && filters.size() != sources_.size())
    throw Error("one filter configuration per camera is needed");
  chains_.resize(sources_.size());
  for (size_t i = 0; i < filters.size(); ++i)
    if (filters[i].any()) chains_[i].emplace(sources_[i]->calibration().depth, filters[i]);
  status_.resize(sources_.size());
  warned_.resize(sources_.size());
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
  start([&server](std::shared_ptr<const CapturedFrameSet> frames) {
    server.publish(std::move(frames));
  });
}

void SitePlayer::start(Publish publish) {
  stop_ = false;
  thread_ = std::thread([this, publish = std::move(publish)] { run(publish); });
}

std::vector<CameraStatus> SitePlayer::camera_status() const {
  std::lock_guard lock(status_mutex_);
  return status_;
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

void SitePlayer::read_succeeded(size_t i) {
  std::lock_guard lock(status_mutex_);
  CameraStatus& st = status_[i];
  ++st.frames_read;
  st.consecutive_failures = 0;
  if (st.failed) {
    st.failed = false;
    spdlog::info("camera {} ({}): recovered, frames read again", i, sources_[i]->description());
  }
}

void SitePlayer::read_failed(size_t i, const std::string& error) {
  auto& warned = warned_[i];
  if (warned.size() < kMaxRememberedErrors) {
    if (warned.insert(error).second) {
      spdlog::warn("camera {}: skipping a frame that cannot be read: {}", i, error);
      if (warned.size() == kMaxRememberedErrors)
        spdlog::warn("camera {}: {} distinct read errors; further ones are not logged", i,
                     kMaxRememberedErrors);
    }
  }
  std::lock_guard lock(status_mutex_);
  CameraStatus& st = status_[i];
  ++st.read_failures;
  st.last_error = error;
  if (++st.consecutive_failures >= options_.max_read_failures && !st.failed) {
    st.failed = true;
    spdlog::error(
        "camera {} ({}): FAILED: {} frames in a row could not be read; it keeps sending its last "
        "good frame and recovers when a frame reads again",
        i, sources_[i]->description(), st.consecutive_failures);
  }
}

void SitePlayer::run(const Publish& publish) {
  const auto& now_us = options_.now_us;
  const int64_t period = std::max<int64_t>(1, std::llround(1e6 / fps_));  // µs per tick
  int64_t next = now_us();
  std::vector<int64_t> due(sources_.size(), next);  // when each source's next frame is, µs
  last_frames_.assign(sources_.size(), nullptr);
  buffers_.resize(sources_.size());
  std::vector<CameraFrame> raw(sources_.size());  // a filtered camera's frame before its chain
  const std::vector<protocol::CameraInfo> infos = cameras();
  // Cameras read this tick: a recycled frame, or (with a filter chain) null: the frame is in raw.
  std::vector<std::pair<size_t, std::shared_ptr<CameraFrame>>> read;
  uint64_t sequence = 0;
  while (!stop_) {
    options_.sleep_until_us(next);
    next += period;
    const int64_t now = now_us();
    if (now > next) next = now + period;  // overran: skip ticks, never queue
    auto frames = std::make_shared<CapturedFrameSet>();
    // Read every source that is due first (capture), then filter (the stage after capture). A
    // camera whose frame fails keeps its last frame; the others go on.
    read.clear();
    for (size_t i = 0; i < sources_.size(); ++i) {
      // Not its time yet (its frame is due nearer a later tick): repeat its last frame.
      if (now + period / 2 < due[i] && last_frames_[i]) continue;
      const int64_t interval = std::max<int64_t>(1, std::llround(1e6 / sources_[i]->fps()));
      due[i] += interval;
      // Fell behind (a stall, or a source faster than the site): its next frame is one interval
      // after this read. Source frames are never queued either.
      if (due[i] <= now) due[i] = now + interval;
      try {
        if (chains_[i]) {
          sources_[i]->next(raw[i]);
          read.emplace_back(i, nullptr);
        } else {
          std::shared_ptr<CameraFrame> out = spare_frame(i);  // no allocation once warm
          sources_[i]->next(*out);
          read.emplace_back(i, std::move(out));
        }
      } catch (const std::exception& e) {
        read_failed(i, e.what());
      }
    }
    frames->capture_time_us = wall_clock_us();
    for (auto& [i, frame] : read) {
      try {
        if (chains_[i]) {
          std::shared_ptr<CameraFrame> out = spare_frame(i);
          chains_[i]->apply(raw[i], *out);
          last_frames_[i] = std::move(out);
        } else {
          last_frames_[i] = std::move(frame);
        }
        read_succeeded(i);
      } catch (const std::exception& e) {
        read_failed(i, e.what());
      }
    }
    for (size_t i = 0; i < sources_.size(); ++i)
      if (!last_frames_[i]) {  // nothing read yet: an empty frame of the camera's size
        const Intrinsics& k = infos[i].calibration.depth;
        auto empty = std::make_shared<CameraFrame>();
        empty->depth = DepthImage(k.width, k.height);
        last_frames_[i] = std::move(empty);
      }
    frames->filter_done_us = wall_clock_us();
    frames->cameras = last_frames_;  // shares the frames, copies pointers
    frames->sequence = ++sequence;
    try {
      publish(std::move(frames));
    } catch (const std::exception& e) {
      spdlog::error("site: frame set {} not published: {}", sequence, e.what());
    }
    ++published_;
  }
}

}  // namespace volcast
