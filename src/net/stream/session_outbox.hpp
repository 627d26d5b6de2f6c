#pragma once
// Internal to volcast_net_stream: one viewer's session messages waiting for its thread, and the
// holding of voice packets so that several talkers' go out in one write
// (ServerConfig::stream_coalesce_us, server.hpp). Plain state and steps with the time passed in:
// the Server guards it with its mutex and does the waking (wake_fd.hpp).
#include <array>
#include <cstdint>
#include <deque>
#include <functional>
#include <memory>
#include <utility>
#include <vector>

namespace volcast::detail {

class SessionOutbox {
 public:
  using Message = std::shared_ptr<const std::vector<uint8_t>>;

  // A queued stream (session_port.hpp kQueuedStreamKey; voice: one a talker) is active while its
  // messages come less than this far apart (µs): a talker sends one every 20 ms.
  static constexpr int64_t kActiveStreamUs = 30'000;
  // More waiting than this: the viewer does not read, and is dropped.
  static constexpr size_t kMaxMessages = 4096;

  // What the viewer's thread must be told after queue(): nothing (it was told already, or the
  // message is held), wake now, or wake at timer_due_us.
  enum class Wake { kNone, kNow, kAt };

  // Queues `message` under coalesce key `key` (0: none; session_port.hpp queue_session_message)
  // at steady time `now_us`. Messages of queued streams alone are held while another stream active
  // at `now_us` has none here, for at most `coalesce_us` after the oldest (0: never held).
  // `behind()` says whether the viewer's connection is full (drops the oldest of a stream); the
  // count of messages dropped or replaced is added to `dropped`. Caller checks kMaxMessages first.
  Wake queue(Message message, uint64_t key, int64_t now_us, int64_t coalesce_us,
             const std::function<bool()>& behind, uint64_t& dropped);

  // What take() found.
  struct Taken {
    int64_t due_us = -1;  // held messages go out then (steady µs); -1: none held
    bool disarm = false;  // the timer was armed for later than now: disarm it
  };
  // Moves every waiting message, in order, into `batch` (cleared first) -- unless the outbox
  // holds only queued streams' messages that are held at `now_us` (see queue()): then `batch`
  // stays empty and due_us says when they go.
  Taken take(int64_t now_us, int64_t coalesce_us, std::vector<Message>& batch);

  bool empty() const { return messages_.empty(); }
  size_t size() const { return messages_.size(); }
  void clear() { messages_.clear(); }
  // The steady time (µs) the thread's timer is armed for; -1: not armed.
  int64_t timer_due_us() const { return timer_due_us_; }

 private:
  // Whether every stream active at `now_us` has a message here.
  bool streams_complete(int64_t now_us) const;
  void note_stream(uint64_t key, int64_t now_us);

  struct RecentStream {
    uint64_t key = 0;
    int64_t last_us = INT64_MIN / 2;
  };
  std::deque<std::pair<uint64_t, Message>> messages_;  // coalesce key and message, in send order
  // The outbox holds only queued streams' messages, the oldest queued at since_us; empty or not,
  // false once another kind is queued.
  bool streams_only_ = true;
  int64_t since_us_ = 0;
  bool woken_ = false;  // the thread was told of what the outbox holds
  // The streams lately queued, and when each last was; bit i of stream_mask_: recent_[i] has a
  // message here.
  std::array<RecentStream, 8> recent_{};
  uint32_t stream_mask_ = 0;
  int64_t timer_due_us_ = -1;
};

}  // namespace volcast::detail
