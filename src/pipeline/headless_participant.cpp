#include "volcast/pipeline/headless_participant.hpp"

#include <chrono>
#include <thread>

namespace volcast {

HeadlessParticipant::HeadlessParticipant(ClientConfig connection, SessionClientOptions session,
                                         ParticipantLife life)
    : session_(std::move(session)) {
  connection.decode = false;
  viewer_.client = std::move(connection);
  viewer_.render = false;
  viewer_.stop = &stop_;
  viewer_.reconnect = true;  // after a cut it rejoins as itself
  auto joined = std::move(life.joined);
  life.joined = [this, joined = std::move(joined)](SessionClient& c) {
    if (joined) joined(c);
    std::lock_guard lock(mutex_);
    joined_ = true;
    changed_.notify_all();
  };
  live_in_viewer(session_, viewer_, std::move(life));
  thread_ = std::thread([this] {
    std::string why;
    ViewerResult r;
    try {
      r = run_viewer(viewer_);
    } catch (const ViewerError& e) {
      r = e.result();
      why = e.what();
    } catch (const std::exception& e) {
      why = e.what();
    }
    std::lock_guard lock(mutex_);
    result_ = std::move(r);
    if (!stop_) error_ = why;
    ended_ = true;
    changed_.notify_all();
  });
}

HeadlessParticipant::~HeadlessParticipant() {
  end();
}

bool HeadlessParticipant::wait_joined(int timeout_ms) {
  const auto until = std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
  {
    std::unique_lock lock(mutex_);
    changed_.wait_until(lock, until, [&] { return joined_ || ended_; });
    if (!joined_ || ended_) return false;
  }
  // Connected and its Join sent: until the hub's Joined comes back.
  while (!session_.participant()->joined()) {
    if (std::chrono::steady_clock::now() >= until) return false;
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  }
  return true;
}

Participant& HeadlessParticipant::participant() {
  return *session_.participant();
}

void HeadlessParticipant::end() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
  session_.stop();  // run_viewer's on_finished stopped it already unless it never connected
}

std::string HeadlessParticipant::error() const {
  std::lock_guard lock(mutex_);
  return error_;
}

}  // namespace volcast
