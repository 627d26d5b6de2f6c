#include "volcast/cluster/tier_publisher.hpp"

#include <spdlog/spdlog.h>

#include "volcast/cluster/chunks.hpp"
#include "volcast/core/error.hpp"

namespace volcast::cluster {

using Clock = std::chrono::steady_clock;

TierPublisher::TierPublisher(NatsConnection& nats, std::string site, protocol::Welcome welcome,
                             int welcome_interval_ms, int want_timeout_ms)
    : nats_(nats),
      site_(std::move(site)),
      welcome_(protocol::serialize(welcome)),
      want_timeout_ms_(want_timeout_ms) {
  const std::string subject = welcome_subject(site_);  // checks the site name
  if (welcome_.size() > nats_.max_payload())
    throw Error("NATS: the site's Welcome (" + std::to_string(welcome_.size()) +
                " bytes) exceeds the server's max_payload");
  publish_welcome();
  welcome_thread_ = std::thread([this, welcome_interval_ms] {
    auto next = Clock::now();
    while (!stop_) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      expire_wants();
      if (Clock::now() < next) continue;
      next += std::chrono::milliseconds(welcome_interval_ms);
      publish_welcome();
    }
  });
}

TierPublisher::~TierPublisher() {
  wants_.clear();  // no more wants (waits for one in progress)
  stop_ = true;
  if (welcome_thread_.joinable()) welcome_thread_.join();
}

void TierPublisher::publish_welcome() {
  std::lock_guard lock(mutex_);
  try {
    nats_.publish(welcome_subject(site_), welcome_);
    ++stats_.welcomes;
  } catch (const Error& e) {
    ++stats_.errors;
    stats_.last_error = e.what();
  }
}

void TierPublisher::publish_tier(Server& server, const Tier& tier) {
  Offered t;
  t.server = &server;
  t.tier = tier;
  t.subject = tier_subject(site_, tier);  // checks the names
  size_t index = 0;
  {
    std::lock_guard lock(demand_mutex_);
    index = offered_.size();
    offered_.push_back(std::move(t));
  }
  wants_.push_back(nats_.subscribe(
      want_subject(site_, tier),
      [this, index](const std::string&, std::span<const uint8_t> data) { on_want(index, data); }));
}

void TierPublisher::on_want(size_t index, std::span<const uint8_t> data) {
  std::lock_guard demand_lock(demand_mutex_);
  Offered& t = offered_[index];
  t.wanted = Clock::now();
  const bool key = !data.empty() && (data[0] & 1) != 0;
  try {
    if (!t.tap) {
      const size_t max_message = nats_.max_payload();
      t.tap = t.server->add_tier_tap(
          t.tier, [this, subject = t.subject, max_message](const TierFrameSet& f) {
            std::lock_guard lock(mutex_);
            try {
              uint64_t chunks = 0;
              chunk_frame_set({f.index, f.capture_us, f.key, f.body}, max_message, scratch_,
                              [&](std::span<const uint8_t> m) {
                                nats_.publish(subject, m);
                                ++chunks;
                              });
              ++stats_.frame_sets;
              stats_.chunks += chunks;
              stats_.bytes += f.body.size();
            } catch (const Error& e) {
              if (stats_.errors++ == 0)
                spdlog::warn("NATS: frame set {} of {} lost: {}", f.sequence, subject, e.what());
              stats_.last_error = e.what();
            }
          });
      spdlog::info("NATS: {} is wanted: publishing it", t.subject);
      std::lock_guard stats_lock(mutex_);
      ++stats_.starts;
    } else if (key) {  // a new tap begins at a key frame set anyway
      t.server->request_key_frame(t.tier);
      std::lock_guard stats_lock(mutex_);
      ++stats_.key_requests;
    }
  } catch (const Error& e) {  // the server stopped, or has max_tiers tiers already
    std::lock_guard stats_lock(mutex_);
    ++stats_.errors;
    stats_.last_error = e.what();
  }
}

void TierPublisher::expire_wants() {
  std::lock_guard lock(demand_mutex_);
  const auto now = Clock::now();
  for (Offered& t : offered_) {
    if (!t.tap || now - t.wanted < std::chrono::milliseconds(want_timeout_ms_)) continue;
    t.server->remove_tier_tap(t.tap);
    t.tap = 0;
    spdlog::info("NATS: nobody wants {} any more: not published", t.subject);
    std::lock_guard stats_lock(mutex_);
    ++stats_.stops;
  }
}

PublisherStats TierPublisher::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

TierInterest::TierInterest(NatsConnection& nats, const std::string& site, const Tier& tier,
                           int interval_ms)
    : nats_(nats), subject_(want_subject(site, tier)) {
  say(true);
  last_key_ = Clock::now();
  thread_ = std::thread([this, interval_ms] {
    auto next = Clock::now() + std::chrono::milliseconds(interval_ms);
    while (!stop_) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      if (Clock::now() < next) continue;
      next += std::chrono::milliseconds(interval_ms);
      say(false);
    }
  });
}

TierInterest::~TierInterest() {
  stop_ = true;
  if (thread_.joinable()) thread_.join();
}

void TierInterest::request_key() {
  {
    std::lock_guard lock(mutex_);
    const auto now = Clock::now();
    if (now - last_key_ < std::chrono::milliseconds(250)) return;
    last_key_ = now;
  }
  say(true);
}

void TierInterest::say(bool key) {
  const uint8_t flags = key ? 1 : 0;
  try {
    nats_.publish(subject_, std::span<const uint8_t>(&flags, 1));
  } catch (const Error&) {  // the link is down: the next interval tries again
  }
}

}  // namespace volcast::cluster
