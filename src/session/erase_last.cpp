// "Erase my last" (erase_last.hpp).
#include "volcast/session/erase_last.hpp"

#include <algorithm>

namespace volcast::session {

void EraseLast::sent(uint32_t tag, int64_t now_us) {
  if (tag != 0) unconfirmed_.push_back({tag, now_us});
}

void EraseLast::pressed(int64_t now_us) {
  if (pressed_) return;
  pressed_ = true;
  pressed_us_ = now_us;
}

std::optional<uint32_t> EraseLast::due(const SessionSnapshot& snapshot, int64_t now_us) {
  std::erase_if(unconfirmed_, [&](const Sent& sent) {
    return now_us - sent.at_us > kWaitUs ||
           std::any_of(
               snapshot.annotations.begin(), snapshot.annotations.end(),
               [&](const Annotation& a) { return a.author == snapshot.id && a.tag == sent.tag; });
  });
  if (!pressed_) return std::nullopt;
  // Erased once what was sent before the press is back (or given up on).
  if (std::any_of(unconfirmed_.begin(), unconfirmed_.end(),
                  [&](const Sent& sent) { return sent.at_us <= pressed_us_; }))
    return std::nullopt;
  pressed_ = false;
  for (auto it = snapshot.annotations.rbegin(); it != snapshot.annotations.rend(); ++it)
    if (it->author == snapshot.id) return it->id;
  return std::nullopt;
}

}  // namespace volcast::session
