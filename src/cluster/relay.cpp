#include "volcast/cluster/relay.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cstring>

#include "volcast/core/error.hpp"

namespace volcast::cluster {

Relay::Relay(NatsConnection& nats, RelayOptions options)
    : nats_(nats), options_(std::move(options)) {
  const std::string welcome = welcome_subject(options_.site);  // checks the site name
  const std::string tier = tier_subject(options_.site, options_.tier);
  welcome_sub_ = nats_.subscribe(
      welcome, [this](const std::string&, std::span<const uint8_t> data) { on_welcome(data); });
  {
    std::unique_lock lock(mutex_);
    if (!welcomed_.wait_for(lock, std::chrono::milliseconds(options_.welcome_timeout_ms),
                            [this] { return !cameras_.empty(); }))
      throw Error("relay: no Welcome from site '" + options_.site + "' on " + welcome + " within " +
                  std::to_string(options_.welcome_timeout_ms) +
                  " ms (is `volcast serve --nats ... --nats-site " + options_.site +
                  "` running on this cluster?)");
  }
  const protocol::Welcome w{cameras_, 0};
  reassembler_ = std::make_unique<Reassembler>(protocol::frame_set_payload_limit(w));
  decoder_ = std::make_unique<FrameSetDecoder>(options_.tier.depth_codec, options_.tier.color_codec,
                                               cameras_);  // throws for a codec we lack
  pool_ = std::make_unique<FramePool>(cameras_.size());
  if (options_.session) {
    session_ = std::make_unique<SessionForwarder>(nats_, options_.site, options_.relay_name);
    options_.server.session = session_.get();
  }
  // The upstream tier arrives encoded and passes through: free for the CPU budget, also for a
  // viewer that connects before the first frame set has come.
  if (options_.server.passed_through_tier.empty())
    options_.server.passed_through_tier = to_string(options_.tier);
  server_ = std::make_unique<Server>(cameras_, options_.server);
  if (session_) session_->attach(server_.get());
  tier_sub_ = nats_.subscribe(
      tier, [this](const std::string&, std::span<const uint8_t> data) { on_chunk(data); });
  interest_ = std::make_unique<TierInterest>(nats_, options_.site, options_.tier);
  spdlog::info("relay: site '{}' ({} camera(s)) from {}", options_.site, cameras_.size(), tier);
}

Relay::~Relay() {
  interest_.reset();
  tier_sub_.reset();  // no more frame sets (waits for a callback in progress)
  welcome_sub_.reset();
  // Stopping the server tells the site's hub each viewer has left (through session_).
  if (server_) server_->stop();
  if (session_) session_->attach(nullptr);
}

void Relay::on_welcome(std::span<const uint8_t> data) {
  protocol::Welcome w;
  try {
    w = protocol::parse_welcome(data);
  } catch (const Error& e) {
    std::lock_guard lock(mutex_);
    stats_.last_error = std::string("a malformed Welcome: ") + e.what();
    return;
  }
  if (w.cameras.empty()) return;
  const std::vector<uint8_t> bytes = protocol::serialize(protocol::Welcome{w.cameras, 0});
  std::lock_guard lock(mutex_);
  if (cameras_.empty()) {
    cameras_ = std::move(w.cameras);
    cameras_bytes_ = bytes;
    welcomed_.notify_all();
  } else if (bytes != cameras_bytes_) {
    if (stats_.welcome_changes++ == 0)
      spdlog::warn(
          "relay: site '{}' now names other cameras than this relay serves: its frame sets are "
          "dropped until the relay is restarted",
          options_.site);
  }
}

void Relay::on_chunk(std::span<const uint8_t> data) {
  const bool complete = reassembler_->add(data);
  {
    std::lock_guard lock(mutex_);
    stats_.chunks = reassembler_->stats();
  }
  if (complete) relay(reassembler_->done());
}

bool Relay::need_images() const {
  if (!decoder_->stateless() || last_images_.empty()) return true;  // deltas: decode every one
  for (const TierReport& t : server_->tiers())
    if (t.tier != options_.tier)
      return true;  // a tier encoded here, from the images (server_tiers: only one of every
                    // frame set with the published codecs passes the published bytes through)
  return false;
}

void Relay::relay(const ChunkedFrameSet& f) {
  const auto drop = [&](const std::string& why) {
    std::lock_guard lock(mutex_);
    if (stats_.undecodable++ == 0 || why != stats_.last_error)
      spdlog::warn("relay: frame set {} of site '{}' dropped: {}", f.sequence, options_.site, why);
    stats_.last_error = why;
  };
  {
    std::lock_guard lock(mutex_);
    if (stats_.welcome_changes) return drop("the site's cameras changed");
  }
  // A delta decodes only after the frame set before it (a gap: NATS dropped some, or the link
  // came back): wait for the next key frame set.
  const bool follows = have_previous_ && f.sequence == previous_ + 1;
  if (!decoder_->stateless() && !f.key && !follows) {
    have_previous_ = false;
    interest_->request_key();
    return drop("a delta without the frame set before it (waiting for a key frame set)");
  }
  auto frames = std::make_shared<CapturedFrameSet>();
  frames->sequence = ++published_;
  frames->capture_time_us = f.capture_us;  // the site's: latency runs from its capture
  message_.resize(8 + f.body.size());
  std::memset(message_.data(), 0, 8);
  std::memcpy(message_.data() + 8, f.body.data(), f.body.size());
  try {
    protocol::parse_frame_set(message_, view_);  // the head's times; a malformed body is dropped
    if (view_.cameras.size() != cameras_.size())
      throw Error(std::to_string(view_.cameras.size()) + " cameras, the site has " +
                  std::to_string(cameras_.size()));
  } catch (const Error& e) {
    return drop(e.what());
  }
  frames->filter_done_us = view_.times.filter_done_us;
  const bool decoded_now = need_images();
  if (decoded_now) {
    have_previous_ = false;
    try {
      decoder_->decode(message_, decoded_);
    } catch (const Error& e) {
      return drop(e.what());
    }
    have_previous_ = true;
    last_images_.clear();
    for (size_t i = 0; i < cameras_.size(); ++i) {
      std::shared_ptr<CameraFrame> frame = pool_->take(i);
      std::swap(decoded_.cameras[i], *frame);
      last_images_.push_back(std::move(frame));
    }
  }
  previous_ = f.sequence;
  // Not decoded (every tier passes the site's bytes through): the last decoded images stand in,
  // marked stale, so that a tier beginning before the next frame set is decoded skips them.
  frames->cameras = last_images_;
  frames->images_stale = !decoded_now;
  auto body = std::make_shared<EncodedFrameSetBody>();
  body->tier = options_.tier;
  body->position = f.sequence;
  body->key = f.key;
  body->body.assign(f.body.begin(), f.body.end());
  frames->encoded = std::move(body);
  server_->publish(std::move(frames));
  std::lock_guard lock(mutex_);
  ++stats_.frame_sets;
  stats_.decoded += decoded_now;
}

RelayStats Relay::stats() const {
  std::lock_guard lock(mutex_);
  RelayStats s = stats_;
  if (tier_sub_) s.nats_dropped = tier_sub_->dropped();
  return s;
}

}  // namespace volcast::cluster
