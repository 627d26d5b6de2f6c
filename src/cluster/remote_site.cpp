#include "volcast/cluster/remote_site.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <climits>
#include <cstdlib>
#include <cstring>

#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/frame_pool.hpp"

namespace volcast::cluster {
namespace {

using Clock = std::chrono::steady_clock;
constexpr size_t kRecent = 4;  // frame sets kept to choose from by capture time

}  // namespace

struct RemoteSite::State {
  struct Received {
    uint64_t number = 0;     // 1, 2, ... as decoded here
    int64_t capture_us = 0;  // the node's capture time (its wall clock)
    Clock::time_point at;    // when it was decoded here
    std::vector<std::shared_ptr<const CameraFrame>> frames;
  };
  RemoteSiteOptions options;
  std::mutex mutex;  // the fields below
  std::condition_variable changed;
  std::vector<protocol::CameraInfo> cameras;
  std::vector<uint8_t> cameras_bytes;  // the Welcome's camera list, serialized
  std::deque<Received> recent;         // oldest first, at most kRecent
  uint64_t decoded = 0;
  RemoteSiteStats stats;
  bool closed = false;
  FramePool pool{0};  // the tier's thread only
};

namespace {

// Camera `index` of a capture node: the received frame set nearest the site's tick.
class NodeCamera final : public FrameSource {
 public:
  NodeCamera(std::shared_ptr<RemoteSite::State> state, size_t index)
      : state_(std::move(state)),
        index_(index),
        calibration_(state_->cameras[index].calibration),
        description_("capture node '" + state_->options.site +
                     "': " + state_->cameras[index].description) {}
  const CameraCalibration& calibration() const override { return calibration_; }
  double fps() const override { return state_->options.fps; }
  int frame_count() const override { return INT_MAX; }  // live: no end
  int color_frame_count() const override { return INT_MAX; }
  std::string description() const override { return description_; }

  void next(CameraFrame& out) override {
    State& s = *state_;
    const RemoteSiteOptions& o = s.options;
    const int64_t tick_us = wall_clock_us();
    const int64_t half_us = static_cast<int64_t>(5e5 / o.fps);
    std::shared_ptr<const CameraFrame> frame;
    {
      std::unique_lock lock(s.mutex);
      const auto current = [&] {
        return s.closed || (!s.recent.empty() && s.recent.back().capture_us >= tick_us - half_us);
      };
      if (!current()) {  // the newest is more than half a frame old: a newer one may be coming
        if (s.changed.wait_for(lock, std::chrono::milliseconds(o.max_wait_ms), current) &&
            !s.closed)
          ++s.stats.waited;
      }
      if (s.closed) throw Error(description_ + ": the node's subscription has ended");
      if (s.recent.empty()) throw Error(description_ + ": no frame set from the node yet");
      const auto quiet = Clock::now() - s.recent.back().at;
      if (quiet > std::chrono::milliseconds(o.stale_ms))  // one text: the site logs it once
        throw Error(description_ + ": nothing from the node for over " +
                    std::to_string(o.stale_ms) + " ms");
      const State::Received* best = &s.recent.back();
      for (const auto& r : s.recent)
        if (std::llabs(r.capture_us - tick_us) < std::llabs(best->capture_us - tick_us)) best = &r;
      if (best->number == last_) ++s.stats.repeated;
      last_ = best->number;
      frame = best->frames[index_];
    }
    out.depth = frame->depth;  // copies into out's buffers (reused once warm)
    out.color = frame->color;
    out.device_timestamp_us = frame->device_timestamp_us;
  }

 private:
  using State = RemoteSite::State;
  std::shared_ptr<State> state_;
  size_t index_;
  CameraCalibration calibration_;
  std::string description_;
  uint64_t last_ = 0;
};

}  // namespace

RemoteSite::RemoteSite(NatsConnection& nats, RemoteSiteOptions options)
    : nats_(nats), options_(std::move(options)), state_(std::make_shared<State>()) {
  if (!(options_.fps > 0 && options_.fps <= 1000)) throw Error("capture node: fps must be 0..1000");
  if (options_.max_wait_ms < 0 || options_.stale_ms < 1)
    throw Error("capture node: max_wait_ms >= 0 and stale_ms >= 1");
  state_->options = options_;
  const std::string welcome = welcome_subject(options_.site);  // checks the name
  const std::string tier = tier_subject(options_.site, options_.tier);
  welcome_sub_ = nats_.subscribe(
      welcome, [this](const std::string&, std::span<const uint8_t> data) { on_welcome(data); });
  std::vector<protocol::CameraInfo> cameras;
  {
    std::unique_lock lock(state_->mutex);
    if (!state_->changed.wait_for(lock, std::chrono::milliseconds(options_.welcome_timeout_ms),
                                  [this] { return !state_->cameras.empty(); }))
      throw Error("capture node '" + options_.site + "': no Welcome on " + welcome + " within " +
                  std::to_string(options_.welcome_timeout_ms) +
                  " ms (is `volcast serve --nats ... --nats-site " + options_.site +
                  " --camera-only` running on this cluster?)");
    cameras = state_->cameras;
  }
  reassembler_ = std::make_unique<Reassembler>(
      protocol::frame_set_payload_limit(protocol::Welcome{cameras, 0}));
  decoder_ = std::make_unique<FrameSetDecoder>(options_.tier.depth_codec, options_.tier.color_codec,
                                               cameras);  // throws for a codec we lack
  state_->pool = FramePool(cameras.size());
  tier_sub_ = nats_.subscribe(
      tier, [this](const std::string&, std::span<const uint8_t> data) { on_chunk(data); });
  interest_ = std::make_unique<TierInterest>(nats_, options_.site, options_.tier);
  spdlog::info("capture node '{}': {} camera(s) from {}", options_.site, cameras.size(), tier);
}

RemoteSite::~RemoteSite() {
  interest_.reset();
  tier_sub_.reset();  // waits for a callback in progress
  welcome_sub_.reset();
  std::lock_guard lock(state_->mutex);
  state_->closed = true;
  state_->changed.notify_all();
}

const std::vector<protocol::CameraInfo>& RemoteSite::cameras() const {
  return state_->cameras;  // set once, before the constructor returns
}

std::vector<std::unique_ptr<FrameSource>> RemoteSite::sources() {
  std::vector<std::unique_ptr<FrameSource>> out;
  for (size_t i = 0; i < state_->cameras.size(); ++i)
    out.push_back(std::make_unique<NodeCamera>(state_, i));
  return out;
}

RemoteSiteStats RemoteSite::stats() const {
  std::lock_guard lock(state_->mutex);
  RemoteSiteStats s = state_->stats;
  if (tier_sub_) s.nats_dropped = tier_sub_->dropped();
  return s;
}

void RemoteSite::on_welcome(std::span<const uint8_t> data) {
  protocol::Welcome w;
  try {
    w = protocol::parse_welcome(data);
  } catch (const Error& e) {
    std::lock_guard lock(state_->mutex);
    state_->stats.last_error = std::string("a malformed Welcome: ") + e.what();
    return;
  }
  if (w.cameras.empty()) return;
  const std::vector<uint8_t> bytes = protocol::serialize(protocol::Welcome{w.cameras, 0});
  std::lock_guard lock(state_->mutex);
  if (state_->cameras.empty()) {
    state_->cameras = std::move(w.cameras);
    state_->cameras_bytes = bytes;
    state_->changed.notify_all();
  } else if (bytes != state_->cameras_bytes && state_->stats.last_error.empty()) {
    state_->stats.last_error = "the node now names other cameras (restart the site to take them)";
    spdlog::warn("capture node '{}': {}", options_.site, state_->stats.last_error);
  }
}

void RemoteSite::on_chunk(std::span<const uint8_t> data) {
  const bool complete = reassembler_->add(data);
  {
    std::lock_guard lock(state_->mutex);
    state_->stats.chunks = reassembler_->stats();
  }
  if (!complete) return;
  const ChunkedFrameSet& f = reassembler_->done();
  const auto drop = [&](const std::string& why) {
    std::lock_guard lock(state_->mutex);
    if (state_->stats.undecodable++ == 0 || why != state_->stats.last_error)
      spdlog::warn("capture node '{}': frame set {} dropped: {}", options_.site, f.sequence, why);
    state_->stats.last_error = why;
  };
  if (!decoder_->stateless() && !f.key && !(have_previous_ && f.sequence == previous_ + 1)) {
    have_previous_ = false;
    interest_->request_key();
    return drop("a delta without the frame set before it (waiting for a key frame set)");
  }
  message_.resize(8 + f.body.size());
  std::memset(message_.data(), 0, 8);
  std::memcpy(message_.data() + 8, f.body.data(), f.body.size());
  have_previous_ = false;
  try {
    decoder_->decode(message_, decoded_);
  } catch (const Error& e) {
    return drop(e.what());
  }
  have_previous_ = true;
  previous_ = f.sequence;
  State::Received r;
  r.capture_us = f.capture_us;
  r.at = Clock::now();
  for (size_t i = 0; i < decoded_.cameras.size(); ++i) {
    std::shared_ptr<CameraFrame> frame = state_->pool.take(i);
    std::swap(decoded_.cameras[i], *frame);
    r.frames.push_back(std::move(frame));
  }
  std::lock_guard lock(state_->mutex);
  r.number = ++state_->decoded;
  state_->recent.push_back(std::move(r));
  if (state_->recent.size() > kRecent) state_->recent.pop_front();
  ++state_->stats.frame_sets;
  state_->changed.notify_all();
}

}  // namespace volcast::cluster
