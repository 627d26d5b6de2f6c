// Opening a viewer's connection and what it asks for (client_connect.hpp).
#include "client_connect.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <thread>

#include "volcast/codec/registry.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/protocol/join.hpp"
#include "volcast/net/transport/tls.hpp"
#include "volcast/net/transport/trust.hpp"

namespace volcast {
namespace {

using Clock = std::chrono::steady_clock;

// A server whose door is full drops handshakes (TlsHandshakeDropped): try again after 100 ms,
// doubling up to 1.6 s, until connect_timeout_ms has passed since the first try, with one line
// per retry. Anything else (refused, a TLS alert, a wrong certificate) fails at once.
TlsClientConnection connect_tls_retrying(const ClientConfig& config) {
  const int budget_ms = std::max(config.connect_timeout_ms, 1);
  const auto give_up = Clock::now() + std::chrono::milliseconds(budget_ms);
  int wait_ms = 100;
  for (int attempt = 1;; ++attempt) {
    const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(give_up - Clock::now());
    try {
      return connect_tls(config.host, config.port, TlsContext::client(),
                         static_cast<int>(std::max<int64_t>(left.count(), 1)));
    } catch (const TlsHandshakeDropped&) {
      if (Clock::now() + std::chrono::milliseconds(wait_ms) >= give_up) throw;
      spdlog::warn("{}:{} dropped the TLS handshake (busy with others?): retry {} in {} ms",
                   config.host, config.port, attempt, wait_ms);
      std::this_thread::sleep_for(std::chrono::milliseconds(wait_ms));
      wait_ms = std::min(wait_ms * 2, 1600);
    }
  }
}

}  // namespace

std::unique_ptr<Connection> open_connection(const ClientConfig& config) {
  const std::string where = config.host + ":" + std::to_string(config.port);
  if (config.insecure) {
    if (!is_loopback_address(config.host))
      throw Error("--insecure (plain TCP) is allowed only to a loopback address, not " +
                  config.host + ": the stream shows an operating room");
    return connect_tcp(config.host, config.port, config.connect_timeout_ms);
  } else {
    if (config.fingerprint.empty() && config.known_servers.empty())
      throw Error("no certificate fingerprint to check " + where +
                  " against: join with the server's link (volcast://...)");
    TlsClientConnection tls = connect_tls_retrying(config);
    const TrustDecision trust = check_server_fingerprint(
        config.known_servers, where, tls.server_fingerprint, config.fingerprint);
    if (trust == TrustDecision::kFirstUse)
      spdlog::warn(
          "first connection to {}: trusting its certificate, SHA-256 {} (compare it with "
          "the fingerprint the server printed; pinned in {})",
          where, tls.server_fingerprint, config.known_servers);
    return std::move(tls.connection);
  }
}

protocol::Hello hello_for(const ClientConfig& config) {
  protocol::Hello hello;
  hello.token = config.token;
  hello.tier = config.tier;  // its frame divisor is not sent: 1 (Client checks it)
  hello.adapt = uint8_t((config.adapt ? protocol::Hello::kAdapt : 0) |
                        (config.keep_lossless ? protocol::Hello::kKeepLossless : 0) |
                        (config.keep_full_rate ? protocol::Hello::kKeepFullRate : 0) |
                        (config.notify ? protocol::Hello::kNotify : 0));
  hello.max_bits_per_s = config.max_bits_per_s;
  if (config.adapt) {  // only ladder rungs this build decodes (one without the video codecs)
    for (const auto& c : all_depth_codecs()) hello.decodes.push_back(std::string(c.name));
    for (const auto& c : all_color_codecs())
      if (std::find(hello.decodes.begin(), hello.decodes.end(), c.name) == hello.decodes.end())
        hello.decodes.push_back(std::string(c.name));
    if (hello.decodes.size() > protocol::kMaxDecodableCodecs) hello.decodes.clear();
  }
  return hello;
}

ClientConfig client_config_from_link(const std::string& text) {
  const JoinLink link = parse_join_link(text);
  ClientConfig c;
  c.host = link.host;
  c.port = link.port;
  c.token = link.token;
  c.fingerprint = link.fingerprint;
  c.insecure = link.insecure;
  return c;
}

}  // namespace volcast
