#include "volcast/record/recorder.hpp"

#include <spdlog/spdlog.h>

#include "volcast/core/error.hpp"

namespace volcast {

BackgroundRecorder::BackgroundRecorder(const std::filesystem::path& path,
                                       const RecordingStream& stream,
                                       RecordingWriterOptions options, size_t max_queued)
    : writer_(path, stream, options), max_queued_(std::max<size_t>(1, max_queued)) {
  stats_.bytes = writer_.bytes();
  thread_ = std::thread([this] { run(); });
}

BackgroundRecorder::~BackgroundRecorder() {
  stop();
}

void BackgroundRecorder::push(const TierFrameSet& f) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || !stats_.error.empty()) return;
    if (waiting_for_key_ && !f.key) {
      ++stats_.dropped;
      return;
    }
    waiting_for_key_ = false;
    if (queue_.size() >= max_queued_) {
      ++stats_.dropped;
      waiting_for_key_ = true;
      return;
    }
    queue_.push_back(f);
  }
  changed_.notify_one();
}

void BackgroundRecorder::run() {
  while (true) {
    TierFrameSet f;
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [&] { return stopping_ || !queue_.empty(); });
      if (queue_.empty()) break;  // stopping, all written
      f = std::move(queue_.front());
      queue_.pop_front();
    }
    std::string error;
    try {
      writer_.append(f.body);
    } catch (const Error& e) {
      error = e.what();
      spdlog::error("{}", error);
    }
    f = {};  // the tier may reuse the buffer
    std::lock_guard lock(mutex_);
    stats_.bytes = writer_.bytes();
    stats_.frame_sets = writer_.frame_sets();
    if (!error.empty()) {
      stats_.error = error;
      stats_.dropped += queue_.size();
      queue_.clear();
      break;
    }
  }
}

void BackgroundRecorder::stop() {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ && !thread_.joinable()) return;
    stopping_ = true;
  }
  changed_.notify_one();
  if (thread_.joinable()) thread_.join();
  try {
    writer_.close();
  } catch (const Error& e) {
    std::lock_guard lock(mutex_);
    if (stats_.error.empty()) stats_.error = e.what();
  }
  std::lock_guard lock(mutex_);
  stats_.bytes = writer_.bytes();
}

RecorderStats BackgroundRecorder::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

}  // namespace volcast
