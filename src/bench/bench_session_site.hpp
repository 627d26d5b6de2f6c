#pragma once
// The session benchmarks' site and people (session_bench.cpp, drawing_bench.cpp; internal to
// volcast_bench): a server with a SessionHub on a free loopback port (TLS), the real `sources`
// at 30 fps, streaming or idle, and headless participants (HeadlessParticipant) that read and
// acknowledge the frame sets without decoding them.
#include <memory>
#include <string>
#include <vector>

#include "volcast/core/error.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/headless_participant.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/pipeline/session_client.hpp"
#include "volcast/session/hub.hpp"

namespace volcast::bench {

struct BenchSite {
  SitePlayer site;
  SessionHub hub;
  Server server;
  std::string link;  ///< the join link on 127.0.0.1

  /// Starts streaming `sources` at once when `stream` (else the site is idle: no frame sets).
  BenchSite(std::vector<std::unique_ptr<FrameSource>> sources, bool stream)
      : site(std::move(sources), 30), server(site.cameras(), config(hub)) {
    hub.attach(&server);
    if (stream) site.start(server);
    link = server.join_link("127.0.0.1");
  }
  /// Stops the site, then the server (end its participants first: end_bench).
  void stop() {
    site.stop();
    hub.attach(nullptr);
    server.stop();
  }
  ~BenchSite() { stop(); }

 private:
  static ServerConfig config(SessionHub& hub) {
    ServerConfig c;
    c.port = 0;
    c.session = &hub;
    c.max_pending_per_address = 64;  // every participant connects from 127.0.0.1 at once
    return c;
  }
};

/// A participant of a BenchSite (or any bench server at `link`): a HeadlessParticipant on the
/// viewer's own lifecycle (it rejoins after a cut), reading and acknowledging the frame sets
/// without decoding them, with no receive timeout (an idle site sends no frame sets). Waits until
/// it has joined; throws Error if it did not in 20 s.
inline std::unique_ptr<HeadlessParticipant> join_bench(const std::string& link,
                                                       SessionClientOptions options,
                                                       ParticipantLife life = {}) {
  ClientConfig c = client_config_from_link(link);
  c.receive_timeout_ms = 0;
  auto p = std::make_unique<HeadlessParticipant>(c, std::move(options), std::move(life));
  if (!p->wait_joined(20'000))
    throw Error("bench participant did not join: " +
                (p->error().empty() ? std::string("not in 20 s") : p->error()));
  return p;
}

/// Ends `people` (HeadlessParticipant::end; before the server stops) and throws Error if one
/// failed before.
inline void end_bench(std::vector<std::unique_ptr<HeadlessParticipant>>& people) {
  for (auto& p : people) p->end();
  for (auto& p : people)
    if (!p->error().empty()) throw Error("bench participant failed: " + p->error());
}

}  // namespace volcast::bench
