#pragma once
// The session benchmarks' site and people (session_bench.cpp, drawing_bench.cpp; internal to
// volcast_bench): a server with a SessionHub on a free loopback port (TLS), the real `sources`
// at 30 fps, streaming or idle, and headless participants whose receiving thread reads and
// acknowledges the frame sets without decoding them.
#include <atomic>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "volcast/net/stream/client.hpp"
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
  /// Stops the site, then the server (its participants' connections end: BenchPerson::end).
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

/// A participant of a BenchSite: its connection (no decoding, no receive timeout: an idle site
/// sends no frame sets), its SessionClient started on it, and the thread reading the stream.
struct BenchPerson {
  std::unique_ptr<Client> client;
  std::unique_ptr<SessionClient> session;
  std::thread receiver;
  std::string error;  ///< why receiving failed before end(), if it did

  BenchPerson(const std::string& link, SessionClientOptions options) {
    ClientConfig c = client_config_from_link(link);
    c.decode = false;
    c.receive_timeout_ms = 0;
    client = std::make_unique<Client>(c);
    session = std::make_unique<SessionClient>(std::move(options));
    session->start(*client);
    receiver = std::thread([this] {
      ReceivedFrameSet rx;
      try {
        while (client->receive(rx)) {
        }
      } catch (const std::exception& e) {
        if (!ending) error = e.what();
      }
    });
  }
  /// Stops its threads (call before the site stops, so that the end is not an error).
  void stop() {
    ending = true;
    session->stop();
  }
  /// Closes the connection and joins the receiving thread.
  void end() {
    ending = true;
    client->close();
    if (receiver.joinable()) receiver.join();
  }
  ~BenchPerson() { end(); }
  Participant& participant() { return *session->participant(); }

 private:
  std::atomic<bool> ending{false};
};

}  // namespace volcast::bench
