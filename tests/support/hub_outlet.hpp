#pragma once
// A SessionHub without a server, for tests: an outlet that keeps every message the hub sends,
// and viewers that join by calling the hub as the server would.
#include <cstdint>
#include <mutex>
#include <string>
#include <utility>
#include <vector>

#include "volcast/session/hub.hpp"
#include "volcast/session/messages.hpp"

namespace volcast::test {

struct Outlet final : SessionOutlet {
  std::mutex mutex;
  std::vector<std::pair<uint64_t, std::vector<uint8_t>>> sent;
  bool send_session(uint64_t viewer, std::shared_ptr<const std::vector<uint8_t>> m,
                    uint64_t) override {
    std::lock_guard lock(mutex);
    sent.emplace_back(viewer, *m);
    return true;
  }
  void disconnect(uint64_t, const std::string&) override {}
  /// The payloads of the messages of `type` sent to `viewer` (after the 12-byte header).
  std::vector<std::vector<uint8_t>> of(uint64_t viewer, session::Type type) {
    std::lock_guard lock(mutex);
    std::vector<std::vector<uint8_t>> out;
    for (const auto& [v, m] : sent)
      if (v == viewer && m[7] == static_cast<uint8_t>(type))
        out.emplace_back(m.begin() + 12, m.end());
    return out;
  }
};

/// Viewer `viewer` joins (or makes) session `session` as `name`, as its Join would.
inline void join(SessionHub& hub, uint64_t viewer, const std::string& session,
                 const std::string& name) {
  session::Join j;
  j.session = session;
  j.name = name;
  hub.on_message(viewer, static_cast<uint8_t>(session::Type::kJoin), session::serialize(j));
}

}  // namespace volcast::test
