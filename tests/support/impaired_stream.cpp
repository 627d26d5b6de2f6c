#include "support/impaired_stream.hpp"

#include <atomic>
#include <chrono>
#include <thread>

#include "volcast/capture/real_sites.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/pipeline/stage_stats.hpp"

namespace volcast {

namespace {

// Demand::kAheadOfThePath: `first`'s frames published again and again, a new frame set each time
// the server has sent (or skipped) the one before for its viewer, and every 50 ms besides (before
// a viewer is connected, or while a frame set waits past the latency budget), until `stop`: one
// always waits for the pacing window.
void publish_ahead(Server& server, const CapturedFrameSet& first, const std::atomic<bool>& stop) {
  uint64_t sequence = 0, handled_before = 0;
  auto last_publish = std::chrono::steady_clock::now() - std::chrono::seconds(1);
  while (!stop) {
    uint64_t handled = 0;
    for (const auto& v : server.viewers())
      if (v.connected) handled = v.frames_sent + v.frames_dropped;
    const auto now = std::chrono::steady_clock::now();
    if (handled == handled_before && now - last_publish < std::chrono::milliseconds(50)) {
      std::this_thread::sleep_for(std::chrono::milliseconds(1));
      continue;
    }
    handled_before = handled;
    auto set = std::make_shared<CapturedFrameSet>(first);
    set->sequence = ++sequence;
    set->capture_time_us = set->filter_done_us = wall_clock_us();
    server.publish(std::move(set));
    last_publish = now;
  }
}

}  // namespace

PathRun run_over_link(ImpairedLink& link, const std::filesystem::path& data, double seconds,
                      int max_window, Demand demand) {
  SitePlayer site(two_camera_site(data), 30);
  ServerConfig config;
  config.bind_address = link.server_address();
  config.port = 0;
  config.max_window = max_window;
  auto server =
      link.in_server_namespace([&] { return std::make_unique<Server>(site.cameras(), config); });
  std::atomic<bool> stop_publishing{false};
  std::thread ahead;
  if (demand == Demand::kSite) {
    site.start(*server);
  } else {
    CapturedFrameSet first;
    for (const auto& source : two_camera_site(data))
      first.cameras.push_back(std::make_shared<const CameraFrame>(source->next()));
    ahead = std::thread(
        [&, first = std::move(first)] { publish_ahead(*server, first, stop_publishing); });
  }
  ClientConfig c = client_config_from_link(server->join_link(link.server_address()));
  c.decode = false;  // the figure is the path's and the server's pacing
  auto client = link.in_client_namespace([&] { return std::make_unique<Client>(c); });
  ReceivedFrameSet rx;
  PathRun r;
  std::vector<double> latency;
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  const auto measure_from = start + std::chrono::seconds(1);
  const auto end = measure_from + std::chrono::duration<double>(seconds);
  while (clock::now() < end) {
    if (!client->receive(rx)) throw Error("server closed the stream");
    if (rx.times.encode_done_us - rx.times.capture_us > int64_t{config.latency_budget_ms} * 1000)
      ++r.encoded_late;
    else
      r.worst_send_age_ms =
          std::max(r.worst_send_age_ms, double(rx.times.send_us - rx.times.capture_us) / 1000.0);
    if (clock::now() < measure_from) continue;
    ++r.frames;
    latency.push_back(static_cast<double>(rx.times.received_us - rx.times.capture_us) / 1000.0);
  }
  r.fps = static_cast<double>(r.frames) / seconds;
  r.latency_ms_p50 = percentile(latency, 0.5);
  r.latency_ms_p99 = percentile(latency, 0.99);
  for (const auto& v : server->viewers())
    if (v.connected) {
      r.min_rtt_ms = v.min_rtt_ms;
      r.window = v.window;
      r.skipped = v.frames_dropped;
    }
  client->close();
  stop_publishing = true;
  if (ahead.joinable()) ahead.join();
  site.stop();
  server->stop();
  return r;
}

}  // namespace volcast
