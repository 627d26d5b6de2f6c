#pragma once
// A participant that watches no picture -- a benchmark's or a test's crowd -- on the one
// lifecycle of a viewer's participant (live_in_viewer, session_client.hpp): run_viewer on a thread
// of its own, neither decoding nor drawing (it reads and acknowledges the site's frame sets), joins
// once connected and, after a cut, connects again and rejoins as itself.
#include <atomic>
#include <condition_variable>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/session_client.hpp"

namespace volcast {

class HeadlessParticipant {
 public:
  /// Starts connecting with `connection` (decoding turned off; its receive_timeout_ms as given:
  /// 0 for a site that may send nothing) and joins with `session`; `life` as live_in_viewer's.
  /// Returns at once: wait_joined() waits. Throws Error for a camera source that cannot be opened
  /// (SessionClient's constructor).
  HeadlessParticipant(ClientConfig connection, SessionClientOptions session,
                      ParticipantLife life = {});
  /// end().
  ~HeadlessParticipant();
  HeadlessParticipant(const HeadlessParticipant&) = delete;
  HeadlessParticipant& operator=(const HeadlessParticipant&) = delete;

  /// Waits up to `timeout_ms` until it has joined its session on its first connection (the hub's
  /// Joined came back): true; false when the time passed first or it ended (error() says why).
  bool wait_joined(int timeout_ms);
  /// The participant; valid once wait_joined() returned true, until destruction.
  Participant& participant();
  /// Ends it as a closed application does: stops its threads (no Leave is sent), closes the
  /// connection (within 50 ms: run_viewer's watchdog) and joins its thread. Idempotent. Call it
  /// before the server stops, or it reconnects until then.
  void end();
  /// Why it ended before end() was called (run_viewer's error: a refused or failed connection,
  /// a cut it could not recover from); empty if it did not.
  std::string error() const;
  /// How its run_viewer ended, with its session figures (valid after end()).
  const ViewerResult& result() const { return result_; }

 private:
  SessionClient session_;
  ViewerOptions viewer_;
  std::atomic<bool> stop_{false};
  mutable std::mutex mutex_;
  std::condition_variable changed_;
  bool joined_ = false;  // guarded by mutex_
  bool ended_ = false;   // guarded by mutex_
  std::string error_;    // guarded by mutex_
  ViewerResult result_;
  std::thread thread_;
};

}  // namespace volcast
