#pragma once
// The virtual OR's current state kept in a JetStream key-value bucket (issue 17, part 4): where
// each organ was left and how the monitor was set survive a restart of the site's server, and
// anyone with read access to the bucket (an operator's `nats kv get`) sees who is in which session
// and who holds what. The site's SessionHub stays the arbiter; the bucket is its mirror.
//
// Bucket "volcast-<site>-sessions"; one key per session: the session name with every character
// outside A-Z a-z 0-9 _ - written as =XX (hex). Value: JSON,
//   {"session": name, "case": the case's name ("" for none), "saved_us": wall-clock µs,
//    "members": [{"id": u32, "name": str, "role": "remote"|"OR site"}],
//    "objects": [{"object": u16, "owner": u32 (0: nobody), "sequence": u32,
//                 "position": [x, y, z] (metres, room frame), "orientation": [w, x, y, z]}],
//    "monitor": {"slice": u16, "center": HU, "width": HU, "overlay": bool}  (absent: no series)}
// (object poses are room_from_object, objects.hpp).
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <nlohmann/json_fwd.hpp>
#include <string>
#include <thread>

#include "volcast/cluster/nats.hpp"
#include "volcast/session/hub.hpp"

namespace volcast::cluster {

std::string session_state_bucket(const std::string& site);
/// The key of session `name` (above).
std::string session_state_key(const std::string& name);

/// Session `name`'s state as saved (without "saved_us"); null JSON if there is no such session.
nlohmann::json session_state_json(const SessionHub& hub, const std::string& name);
/// Puts a saved state back into `hub` (SessionHub::restore): false when it was saved for another
/// case than the hub's. Throws Error naming the field that is missing or out of range.
bool restore_session_state(SessionHub& hub, const nlohmann::json& state);

struct SessionStateStats {
  uint64_t writes = 0, errors = 0;
  uint64_t deletes = 0;  ///< states of sessions the hub removed, deleted from the bucket
  int restored = 0;      ///< sessions put back when the mirror started
  std::string last_error;
};

/// Opens (makes) the bucket, puts every saved session back into `hub` (those of another case are
/// skipped, with a log line), then writes each session's state whenever it changed, checked
/// every `period_ms`, on its own thread, and deletes the state of a session it wrote or restored
/// once the hub has removed it (a participants' session nobody is in any more: hub.hpp). Stop it
/// before the server, so that sessions emptied by the server stopping are kept for its restart.
/// Write failures (a node down) are counted and retried on the next change; the hub never waits for
/// NATS. Throws Error if the bucket cannot be opened (the cluster does not run JetStream). `nats`
/// and `hub` must outlive it.
class SessionStateMirror {
 public:
  SessionStateMirror(NatsConnection& nats, const std::string& site, SessionHub& hub,
                     int replicas = 1, int period_ms = 250);
  ~SessionStateMirror();  ///< writes what changed last, then stops
  SessionStateMirror(const SessionStateMirror&) = delete;
  SessionStateMirror& operator=(const SessionStateMirror&) = delete;
  SessionStateStats stats() const;

 private:
  void run();
  void write_changes();

  SessionHub& hub_;
  int period_ms_;
  std::unique_ptr<NatsConnection::KeyValue> kv_;
  std::map<std::string, std::string> written_;  // by key: the last state written (run() only)
  mutable std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  SessionStateStats stats_;
  std::thread thread_;
};

}  // namespace volcast::cluster
