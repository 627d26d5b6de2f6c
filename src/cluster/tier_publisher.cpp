#include "volcast/cluster/tier_publisher.hpp"

#include <spdlog/spdlog.h>

#include <chrono>

#include "volcast/cluster/chunks.hpp"
#include "volcast/core/error.hpp"

namespace volcast::cluster {

TierPublisher::TierPublisher(NatsConnection& nats, std::string site, protocol::Welcome welcome,
                             int welcome_interval_ms)
    : nats_(nats), site_(std::move(site)), welcome_(protocol::serialize(welcome)) {
  const std::string subject = welcome_subject(site_);  // checks the site name
  if (welcome_.size() > nats_.max_payload())
    throw Error("NATS: the site's Welcome (" + std::to_string(welcome_.size()) +
                " bytes) exceeds the server's max_payload");
  publish_welcome();
  welcome_thread_ = std::thread([this, welcome_interval_ms] {
    auto next = std::chrono::steady_clock::now();
    while (!stop_) {
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
      if (std::chrono::steady_clock::now() < next) continue;
      next += std::chrono::milliseconds(welcome_interval_ms);
      publish_welcome();
    }
  });
}

TierPublisher::~TierPublisher() {
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

void TierPublisher::publish_tier(Server& server, const std::string& depth_codec,
                                 const std::string& color_codec, int color_quality) {
  const std::string subject = tier_subject(site_, depth_codec, color_codec, color_quality);
  const size_t max_message = nats_.max_payload();
  server.add_tier_tap(
      depth_codec, color_codec, color_quality, [this, subject, max_message](const TierFrameSet& f) {
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
}

PublisherStats TierPublisher::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

}  // namespace volcast::cluster
