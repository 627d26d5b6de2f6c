#include "volcast/record/recorder.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "record_format.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

BackgroundRecorder::BackgroundRecorder(const std::filesystem::path& path,
                                       const RecordingStream& stream,
                                       RecordingWriterOptions options, size_t max_queued,
                                       size_t max_queued_voices, size_t max_queued_drawings)
    : writer_(path, stream, options),
      max_queued_(std::max<size_t>(1, max_queued)),
      voices_(std::max<size_t>(1, max_queued_voices)),
      writing_(voices_.size()),
      max_queued_drawings_(std::max<size_t>(1, max_queued_drawings)) {
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

void BackgroundRecorder::push_speaker(uint32_t participant, const std::string& name, uint8_t role) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || !stats_.error.empty()) return;
    speakers_.push_back({participant, name, role});
  }
  changed_.notify_one();
}

void BackgroundRecorder::push_voice(uint32_t participant, uint32_t sequence, uint32_t frame,
                                    int64_t capture_us, std::span<const uint8_t> opus) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || !stats_.error.empty()) return;
    if (opus.empty() || opus.size() > kMaxRecordedVoiceBytes || voice_count_ == voices_.size()) {
      ++stats_.voice_dropped;
      return;
    }
    QueuedVoice& q = voices_[(voice_head_ + voice_count_++) % voices_.size()];
    q.participant = participant;
    q.sequence = sequence;
    q.frame = frame;
    q.capture_us = capture_us;
    q.bytes = opus.size();
    std::copy(opus.begin(), opus.end(), q.opus.begin());
  }
  changed_.notify_one();
}

void BackgroundRecorder::push_drawing(uint8_t type, int64_t received_us,
                                      std::span<const uint8_t> payload) {
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || !stats_.error.empty()) return;
    bool valid = drawings_.size() < max_queued_drawings_;
    if (valid) try {
        detail::check_drawing(type, payload);  // small: a stroke parses in microseconds
      } catch (const Error& e) {
        if (stats_.drawing_dropped == 0) spdlog::warn("record: {}: not recorded", e.what());
        valid = false;
      }
    if (!valid) {
      ++stats_.drawing_dropped;
      return;
    }
    drawings_.push_back({type, received_us, {payload.begin(), payload.end()}});
  }
  changed_.notify_one();
}

void BackgroundRecorder::run() {
  while (true) {
    TierFrameSet f;
    std::vector<RecordedSpeaker> speakers;
    std::deque<QueuedDrawing> drawings;
    size_t voices = 0, voices_written = 0;
    {
      std::unique_lock lock(mutex_);
      changed_.wait(lock, [&] { return stopping_ || !idle(); });
      if (idle()) break;  // stopping, all written
      // Speakers first: one pushed before its voice is written before it.
      speakers.assign(speakers_.begin(), speakers_.end());
      speakers_.clear();
      drawings.swap(drawings_);
      // Every queued voice (small) at once, so that voices keep up whatever the frame sets do.
      for (; voice_count_ > 0; --voice_count_, ++voices) {
        const QueuedVoice& q = voices_[voice_head_];
        QueuedVoice& w = writing_[voices];
        w.participant = q.participant;
        w.sequence = q.sequence;
        w.frame = q.frame;
        w.capture_us = q.capture_us;
        w.bytes = q.bytes;
        std::copy_n(q.opus.begin(), q.bytes, w.opus.begin());
        voice_head_ = (voice_head_ + 1) % voices_.size();
      }
      if (!queue_.empty()) {
        f = std::move(queue_.front());
        queue_.pop_front();
      }
    }
    std::string error;
    try {
      for (const RecordedSpeaker& s : speakers)
        writer_.append_speaker(s.participant, s.name, s.role);
      for (; voices_written < voices; ++voices_written) {
        const QueuedVoice& w = writing_[voices_written];
        writer_.append_voice(w.participant, w.sequence, w.frame, w.capture_us,
                             std::span(w.opus).first(w.bytes));
      }
      // Drawing in the order received (checked when pushed: only a failed write throws here).
      for (; !drawings.empty(); drawings.pop_front())
        writer_.append_drawing(drawings.front().type, drawings.front().received_us,
                               drawings.front().payload);
      if (!f.body.empty()) writer_.append(f.body);
    } catch (const Error& e) {
      error = e.what();
      spdlog::error("{}", error);
    }
    f = {};  // the tier may reuse the buffer
    std::lock_guard lock(mutex_);
    stats_.bytes = writer_.bytes();
    stats_.frame_sets = writer_.frame_sets();
    stats_.voice_packets = writer_.voices();
    stats_.drawings = writer_.drawings();
    if (!error.empty()) {
      stats_.error = error;
      stats_.dropped += queue_.size();
      queue_.clear();
      stats_.voice_dropped += voice_count_ + (voices - voices_written);
      voice_count_ = 0;
      stats_.drawing_dropped += drawings_.size() + drawings.size();
      drawings_.clear();
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
