#pragma once
// "Erase my last": what the window's Backspace and the headset's erase button do. A press erases
// the newest annotation this participant drew; one it sent that has not come back numbered yet
// (0x51, annotations.hpp) is waited for, up to kWaitUs (one the server refused never comes back),
// so a quick press after drawing erases what was just drawn and not the one before it. The server
// decides whether the erase is allowed (hub.hpp anyone_erases). Plain state, no threads: the caller
// feeds it the tags it sent, presses and snapshots, and sends the erase it returns
// (Participant::erase).
#include <cstdint>
#include <optional>
#include <vector>

#include "volcast/session/participant.hpp"

namespace volcast::session {

class EraseLast {
 public:
  /// How long a press waits for annotations sent but not yet back from the server, µs.
  static constexpr int64_t kWaitUs = 3'000'000;

  /// This participant sent an annotation with `tag` (Participant::annotate's; 0, not sent, is
  /// ignored) at `now_us` (a steady clock, µs, as every call's).
  void sent(uint32_t tag, int64_t now_us);
  /// The erase key or button went down at `now_us`. Call it after sending what the same frame
  /// finished (a stroke let go just before the key went down is sent by that frame, and must
  /// count as sent before the press). A second press while one waits is the same press.
  void pressed(int64_t now_us);
  /// Once a frame: forgets the annotations back in `snapshot` (numbered, author snapshot.id) and
  /// those waited for longer than kWaitUs; if a press waits and nothing sent before it is still
  /// out, returns the id of the newest annotation in `snapshot` that this participant drew (the
  /// press is then done; nullopt, and done, when it drew none standing).
  std::optional<uint32_t> due(const SessionSnapshot& snapshot, int64_t now_us);
  /// Whether a press waits.
  bool waiting() const { return pressed_; }

 private:
  struct Sent {
    uint32_t tag = 0;
    int64_t at_us = 0;
  };
  std::vector<Sent> unconfirmed_;  // sent, not yet in a snapshot numbered
  bool pressed_ = false;
  int64_t pressed_us_ = 0;
};

}  // namespace volcast::session
