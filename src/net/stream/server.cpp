#include "volcast/net/stream/server.hpp"

#include <fmt/format.h>
#include <fmt/ranges.h>
#include <spdlog/spdlog.h>

#include <algorithm>

#include "server_impl.hpp"
#include "volcast/codec/registry.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/transport/websocket.hpp"

namespace volcast {

// Runs on the door's thread for each authenticated viewer: applies the server's policy, then
// gives the viewer a tier and a thread. Throws Error (the door sends it as a Reject).
void Server::Impl::admit(detail::Admitted& a) {
  join_retired();
  std::lock_guard lock(mutex);
  reap_finished();
  const protocol::Hello& hello = a.hello;
  try {
    int active = 0;
    for (const auto& v : viewers) active += !v.done;
    if (active >= config.max_viewers)
      throw Error("server full (" + std::to_string(config.max_viewers) + " viewers)");
    const bool adapt = (hello.adapt & protocol::Hello::kAdapt) && !ladder.rungs.empty();
    if (!adapt) check_offered(hello);  // the ladder's tiers count as offered to adaptive viewers
    Viewer& v = viewers.emplace_back();
    v.id = next_viewer_id++;
    v.report.id = v.id;
    v.address = a.address;
    v.floor.adapt = hello.adapt;
    v.floor.max_bits_per_s = hello.max_bits_per_s;
    v.floor.decodes = hello.decodes;
    v.floor.hello_tier = hello.tier;  // every frame set: a Hello carries no divisor
    try {
      v.tier = adapt ? subscribe_adaptive(v) : subscribe(hello.tier, &v.wake, &v.address);
    } catch (...) {
      viewers.pop_back();
      throw;
    }
    v.connection = std::move(a.connection);
    v.report.peer = v.connection->peer();
    v.report.connected = true;
    const Tier& key = v.tier->encoder.key();  // known codecs: subscribe checked them
    v.report.tier = key;
    v.report.adaptive = adapt;
    v.report.rung = adapt ? rung_of(v) : -1;
    v.thread = std::thread([this, &v] { serve_viewer(v); });
  } catch (const Error& e) {
    ViewerReport r;
    r.peer = a.connection->peer();
    r.error = e.what();
    ended.push_back(std::move(r));
    if (ended.size() > kEndedReportsKept) ended.pop_front();
    throw;
  }
}

// Throws Error naming the offered tiers if the viewer's is not one of them.
void Server::Impl::check_offered(const protocol::Hello& hello) const {
  if (detail::offered(offers, hello.tier)) return;
  throw Error("this server does not offer that tier; it offers " +
              fmt::format("{}", fmt::join(config.offered_tiers, ", ")));
}

Server::Server(std::vector<protocol::CameraInfo> cameras, ServerConfig config)
    : impl_(std::make_unique<Impl>()) {
  if (config.max_window < 1) throw Error("server: --max-window must be at least 1");
  if (config.latency_budget_ms < 1) throw Error("server: --latency-budget must be at least 1 ms");
  if (config.max_viewers < 1) throw Error("server: --max-viewers must be at least 1");
  if (config.seal_from_viewers < 1) throw Error("server: seal_from_viewers must be at least 1");
  if (config.key_frame_interval < 1) throw Error("server: --key-frame-interval must be at least 1");
  if (!(config.tier_cpu_budget >= 0) || config.tier_cpu_budget > 1e6)
    throw Error("server: --tier-cpu-budget must be a number of cores, 0 for the default");
  if (config.max_tiers_per_address < 1)
    throw Error("server: --max-tiers-per-address must be at least 1");
  if (cameras.empty() || static_cast<int>(cameras.size()) > protocol::kMaxCameras)
    throw Error("server: a site needs 1 to " + std::to_string(protocol::kMaxCameras) + " cameras");
  // What every viewer would refuse (protocol.hpp's limits) is refused here, at start.
  uint64_t pixels = 0;
  for (const auto& cam : cameras) {
    const Intrinsics& k = cam.calibration.depth;
    if (k.width < 1 || k.height < 1 || k.width > protocol::kMaxCameraSide ||
        k.height > protocol::kMaxCameraSide)
      throw Error("server: camera '" + cam.description + "' is " + std::to_string(k.width) + "x" +
                  std::to_string(k.height) + "; viewers accept 1 to " +
                  std::to_string(protocol::kMaxCameraSide) + " pixels per side");
    pixels += uint64_t(k.width) * uint64_t(k.height);
  }
  if (pixels > protocol::kMaxSitePixels)
    throw Error("server: the site's cameras have " + std::to_string(pixels) +
                " pixels together; viewers accept at most " +
                std::to_string(protocol::kMaxSitePixels));
  if (protocol::serialize(protocol::Welcome{cameras, 0}).size() > protocol::kMaxWelcomeBytes)
    throw Error("server: the Welcome would exceed the viewers' limit (camera names too long?)");
  if (config.handshake_timeout_ms < 1 || config.max_pending < 1 ||
      config.max_pending_per_address < 1)
    throw Error("server: handshake timeout and pending-handshake limits must be at least 1");
  // An offered tier and a publisher's (passed-through) tier carry every frame set: @N is the
  // ladder's alone.
  impl_->offers = detail::parse_offers(config.offered_tiers);
  if (!config.passed_through_tier.empty())
    impl_->budget.passed_through = parse_tier(
        config.passed_through_tier, "server: passed-through tier", TierRate::kEveryFrameSet);
  impl_->ladder = detail::make_ladder(config, impl_->offers);
  const std::string bind = resolve_bind_address(config.bind_address);
  if (config.insecure && !is_loopback_address(bind))
    throw Error(
        "server: --insecure (plain TCP, no encryption) is allowed only on a loopback "
        "address, not " +
        config.bind_address + ": the stream shows an operating room; drop --insecure to use TLS");
  impl_->door.token = config.token ? *config.token : random_join_token();
  if (!config.insecure)
    impl_->door.tls = TlsContext::server(config.identity.certificate_pem.empty()
                                             ? make_self_signed_identity("volcast server")
                                             : config.identity);
  if (!config.web_root.empty())
    impl_->door.web =
        std::make_shared<const detail::WebAssets>(detail::load_web_assets(config.web_root));
  impl_->door.handshake_timeout_ms = config.handshake_timeout_ms;
  impl_->door.max_pending = config.max_pending;
  impl_->door.max_pending_per_address = config.max_pending_per_address;
  impl_->door.free_wrong_tokens = kFreeWrongTokens;
  impl_->budget.cores = config.tier_cpu_budget > 0
                            ? config.tier_cpu_budget
                            : std::max(1.0, double(std::thread::hardware_concurrency()) / 2);
  impl_->budget.site_pixels = pixels;
  impl_->config = std::move(config);
  impl_->cameras = std::move(cameras);
  impl_->pool = std::make_unique<WorkerPool>(impl_->config.encode_threads);
  impl_->listener = std::make_unique<TcpListener>(bind, impl_->config.port);
  impl_->admit_fn = [this](detail::Admitted& a) { impl_->admit(a); };
  impl_->door_thread = std::thread([this] {
    detail::run_door(*impl_->listener, impl_->door, impl_->stopping, impl_->admit_fn,
                     impl_->door_counters);
  });
}

uint64_t Server::add_tier_tap(const volcast::Tier& wanted,
                              std::function<void(const TierFrameSet&)> tap) {
  if (wanted.frame_divisor != 1)
    throw Error("server: a tier tap takes every frame set, not " + to_string(wanted));
  std::lock_guard lock(impl_->mutex);
  if (impl_->stopping) throw Error("server: stopped");
  auto tier = impl_->subscribe(wanted, nullptr, nullptr);
  double total = 0;
  for (const auto& t : impl_->tiers) total += impl_->budget.cores_of(t->encode_ns);
  if (total > impl_->budget.cores)
    spdlog::warn(
        "server: with the tap on tier {}, the tiers cost about {:.2f} CPU cores, over the "
        "budget of {:.2f} (--tier-cpu-budget): viewers asking for a new tier are refused",
        to_string(wanted), total, impl_->budget.cores);
  const uint64_t id = impl_->next_tap_id++;
  tier->taps.push_back(
      {id, std::make_shared<std::function<void(const TierFrameSet&)>>(std::move(tap)), false});
  return id;
}

void Server::remove_tier_tap(uint64_t id) {
  {
    std::lock_guard lock(impl_->mutex);
    for (const auto& tier : impl_->tiers)
      std::erase_if(tier->taps, [id](const Impl::Producer::Tap& t) { return t.id == id; });
    impl_->reap_finished();  // a tier nobody watches or taps any more stops encoding
  }
  impl_->join_retired();
}

void Server::request_key_frame(const volcast::Tier& key) {
  std::lock_guard lock(impl_->mutex);
  for (const auto& tier : impl_->tiers)
    if (tier->encoder.key() == key && !tier->stop) tier->key_wanted = true;
}

Server::~Server() {
  stop();
}

uint16_t Server::port() const {
  return impl_->listener->port();
}

const JoinToken& Server::token() const {
  return impl_->door.token;
}

std::string Server::fingerprint() const {
  return impl_->door.tls ? impl_->door.tls->fingerprint() : std::string();
}

std::string Server::join_link(const std::string& host) const {
  JoinLink link;
  link.host = host;
  link.port = port();
  link.token = token();
  link.fingerprint = fingerprint();
  link.insecure = !impl_->door.tls;
  return format_join_link(link);
}

std::string Server::web_link(const std::string& host) const {
  if (!impl_->door.web) return {};
  const bool v6 = host.find(':') != std::string::npos;
  return std::string(impl_->door.tls ? "https://" : "http://") + (v6 ? "[" : "") + host +
         (v6 ? "]" : "") + ":" + std::to_string(port()) + "/#token=" + to_hex(token());
}

double Server::tier_cpu_budget() const {
  return impl_->budget.cores;
}

DoorReport Server::door() const {
  const auto& c = impl_->door_counters;
  return {c.admitted,   c.wrong_token, c.backed_off, c.failed,
          c.over_limit, c.web_files,   c.web_viewers};
}

void Server::publish(std::shared_ptr<const CapturedFrameSet> frames) {
  if (!frames || frames->cameras.size() != impl_->cameras.size())
    throw Error("server: frame set has the wrong number of cameras");
  for (const auto& f : frames->cameras)
    if (!f) throw Error("server: frame set has a missing camera frame");
  {
    std::lock_guard lock(impl_->mutex);
    impl_->captured = std::move(frames);
    impl_->budget.note_published(Impl::steady_us());
  }
  impl_->captured_changed.notify_all();
  // The tiers' threads wake to encode it on the pool: wake its workers now too, not after them.
  impl_->pool->prewake(std::chrono::milliseconds(2));
}

// Queues `message` for `v` (mutex held): false if `v` is gone or being dropped.
bool Server::Impl::queue_session(Viewer& v, std::shared_ptr<const std::vector<uint8_t>> message,
                                 uint64_t coalesce_key) {
  if (v.done || !v.kicked.empty()) return false;
  if (v.outbox.size() >= detail::SessionOutbox::kMaxMessages) {
    v.kicked = fmt::format("session messages piled up ({} unsent): the viewer does not read",
                           v.outbox.size());
    v.wake.signal();
    return true;
  }
  const auto behind = [&v] { return v.connection && v.connection->send_buffer_full(); };
  switch (v.outbox.queue(std::move(message), coalesce_key, steady_us(), config.stream_coalesce_us,
                         behind, v.report.session_dropped)) {
    case detail::SessionOutbox::Wake::kNow:
      v.wake.signal();
      break;
    case detail::SessionOutbox::Wake::kAt:
      v.wake.at(v.outbox.timer_due_us());
      break;
    case detail::SessionOutbox::Wake::kNone:
      break;
  }
  return true;
}

bool Server::send_session(uint64_t viewer, std::shared_ptr<const std::vector<uint8_t>> message,
                          uint64_t coalesce_key) {
  std::lock_guard lock(impl_->mutex);
  for (auto& v : impl_->viewers)
    if (v.id == viewer) return impl_->queue_session(v, std::move(message), coalesce_key);
  return false;
}

void Server::disconnect(uint64_t viewer, const std::string& why) {
  std::lock_guard lock(impl_->mutex);
  for (auto& v : impl_->viewers)
    if (v.id == viewer && !v.done) {
      if (v.kicked.empty()) v.kicked = why;
      v.wake.signal();
    }
}

std::vector<ViewerReport> Server::viewers() const {
  std::lock_guard lock(impl_->mutex);
  std::vector<ViewerReport> out(impl_->ended.begin(), impl_->ended.end());
  for (const auto& v : impl_->viewers) out.push_back(v.report);
  return out;
}

std::vector<TierReport> Server::tiers() const {
  std::lock_guard lock(impl_->mutex);
  std::vector<TierReport> out;
  for (const auto& t : impl_->tiers) out.push_back(t->report_now(impl_->budget.cores_of(1)));
  return out;
}

void Server::stop() {
  if (impl_->stopping.exchange(true)) return;
  impl_->listener->close();
  if (impl_->door_thread.joinable()) impl_->door_thread.join();
  {
    std::lock_guard lock(impl_->mutex);
    for (auto& v : impl_->viewers) v.connection->shutdown();
  }
  impl_->captured_changed.notify_all();
  // The door's thread has ended, so the viewer list no longer changes; viewer threads notice
  // `stopping` within 100 ms and must be joined without holding the mutex they report through.
  for (auto& v : impl_->viewers)
    if (v.thread.joinable()) v.thread.join();
  {
    std::lock_guard lock(impl_->mutex);
    for (auto& t : impl_->tiers) impl_->retired.push_back(std::move(t->thread));
  }
  impl_->captured_changed.notify_all();
  impl_->join_retired();
}

}  // namespace volcast
