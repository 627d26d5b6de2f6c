#include "session_outbox.hpp"

#include "volcast/net/stream/session_port.hpp"

namespace volcast::detail {

void SessionOutbox::note_stream(uint64_t key, int64_t now_us) {
  size_t at = 0;  // the stream's slot, else the one heard least recently
  for (size_t i = 0; i < recent_.size(); ++i) {
    if (recent_[i].key == key) {
      at = i;
      break;
    }
    if (recent_[i].last_us < recent_[at].last_us) at = i;
  }
  recent_[at] = {key, now_us};
  stream_mask_ |= 1u << at;
}

bool SessionOutbox::streams_complete(int64_t now_us) const {
  for (size_t i = 0; i < recent_.size(); ++i)
    if (now_us - recent_[i].last_us < kActiveStreamUs && !(stream_mask_ & (1u << i))) return false;
  return true;
}

// The viewer's thread takes the whole outbox once woken (take()): it is told once for what the
// outbox holds, not once more per message (a write(2) and a wake-up each). Queued streams'
// messages alone (voice packets) are held while several talk: the thread wakes when each talker's
// packet is there, or by its timer when the oldest has waited coalesce_us; one talker's packets
// have nothing to wait for.
SessionOutbox::Wake SessionOutbox::queue(Message message, uint64_t key, int64_t now_us,
                                         int64_t coalesce_us, const std::function<bool()>& behind,
                                         uint64_t& dropped) {
  const bool stream = (key & kQueuedStreamKey) != 0;
  if (messages_.empty()) {
    streams_only_ = true;
    since_us_ = now_us;
    stream_mask_ = 0;
  }
  if (stream) note_stream(key, now_us);
  streams_only_ = streams_only_ && stream;
  dropped += queue_session_message(messages_, key, std::move(message), behind);
  const bool hold = streams_only_ && coalesce_us > 0 && !streams_complete(now_us);
  if (!hold && !woken_) {
    woken_ = true;
    return Wake::kNow;
  }
  if (hold && timer_due_us_ < 0) {
    timer_due_us_ = since_us_ + coalesce_us;
    return Wake::kAt;
  }
  return Wake::kNone;
}

SessionOutbox::Taken SessionOutbox::take(int64_t now_us, int64_t coalesce_us,
                                         std::vector<Message>& batch) {
  batch.clear();
  Taken t;
  if (messages_.empty()) return t;
  if (streams_only_ && coalesce_us > 0) {
    const int64_t due = since_us_ + coalesce_us;
    if (now_us < due && !streams_complete(now_us)) {
      t.due_us = due;
      return t;
    }
  }
  for (auto& m : messages_) batch.push_back(std::move(m.second));
  messages_.clear();
  woken_ = false;
  stream_mask_ = 0;
  t.disarm = timer_due_us_ > now_us;  // taken before the timer: no wake-up for nothing
  timer_due_us_ = -1;
  return t;
}

}  // namespace volcast::detail
