#pragma once
// Internal to volcast_net_stream: how a Client (client.cpp) opens its connection and what its Hello
// asks for.
#include <memory>

#include "volcast/net/protocol/protocol.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/net/transport/connection.hpp"

namespace volcast {

/// The connection to config.host:config.port: plain TCP only to a loopback address (insecure),
/// else TLS with the server's certificate checked against config.fingerprint and pinned in
/// config.known_servers (trust on first use, said in a warning). A door that is full drops TLS
/// handshakes: tried again after 100 ms, doubling up to 1.6 s, until connect_timeout_ms has passed
/// since the first try; anything else (refused, a TLS alert, a wrong certificate) throws Error at
/// once.
std::unique_ptr<Connection> open_connection(const ClientConfig& config);

/// The Hello for `config`: its join token, tier, flags (adapt, keep lossless, keep full rate,
/// notify), bandwidth cap and, when it adapts, the codecs this build decodes (none when they are
/// more than protocol::kMaxDecodableCodecs).
protocol::Hello hello_for(const ClientConfig& config);

}  // namespace volcast
