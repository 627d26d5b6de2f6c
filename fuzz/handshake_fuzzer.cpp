// libFuzzer target for the server's door (src/net/door.cpp): the fuzz bytes are what a peer sends
// after connecting to a running Server on loopback. The first byte picks the way in:
//   0  raw bytes to a plain-TCP (--insecure) server: header and Hello parsing, token compare
//   1  raw bytes to a TLS server: OpenSSL's handshake as driven by the door
//   2  inside a completed TLS session: the Hello behind TLS
//   3  a Hello header and the right token, then the fuzz bytes, inside TLS: parse_hello past the
//      token, the tier policy and admission
// Each input's connection is then half-closed and read for at most 200 ms. Anything but a clean
// refusal or admission (a crash, a sanitizer report, a hang) is a finding. Run by scripts/fuzz.sh.
#include <poll.h>
#include <spdlog/spdlog.h>
#include <sys/socket.h>

#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <memory>
#include <vector>

#include "volcast/core/error.hpp"
#include "volcast/net/stream/server.hpp"
#include "volcast/net/transport/connection.hpp"
#include "volcast/net/transport/tls.hpp"

namespace {

using namespace volcast;

std::unique_ptr<Server> start(bool insecure) {
  std::vector<protocol::CameraInfo> cameras(1);
  cameras[0].calibration.depth = Intrinsics{8, 6, 5, 5, 4, 3};
  cameras[0].description = "camera 0";
  ServerConfig config;
  config.port = 0;
  config.insecure = insecure;
  config.handshake_timeout_ms = 2000;
  config.max_pending_per_address = 64;
  config.offered_tiers = {"raw/none", "rvl/jpeg/50"};
  return std::make_unique<Server>(cameras, config);
}

// Reads whatever the server answers until it closes or 200 ms pass.
void drain(Connection& c) {
  uint8_t buf[4096];
  for (int i = 0; i < 20; ++i) {
    pollfd p{c.fd(), POLLIN, 0};
    if (::poll(&p, 1, 10) <= 0) continue;
    try {
      while (c.read_available(buf) > 0) {
      }
    } catch (const Error&) {
      return;
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  // Made once and stopped at exit before spdlog's registry is destroyed (atexit handlers run in
  // reverse order of registration, and the registry exists before this one is registered).
  static Server* const plain = start(true).release();
  static Server* const tls = start(false).release();
  static const std::shared_ptr<TlsContext> client = TlsContext::client();
  static const bool stop_at_exit = [] {
    spdlog::default_logger();
    std::atexit([] {
      plain->stop();
      tls->stop();
    });
    return true;
  }();
  (void)stop_at_exit;
  if (size == 0) return 0;
  const int mode = data[0] % 4;
  const std::span<const uint8_t> body(data + 1, size - 1);
  try {
    std::unique_ptr<Connection> c =
        mode == 0   ? connect_tcp("127.0.0.1", plain->port(), 2000)
        : mode == 1 ? connect_tcp("127.0.0.1", tls->port(), 2000)
                    : connect_tls("127.0.0.1", tls->port(), client, 2000).connection;
    if (mode == 3) {
      uint8_t header[protocol::kHeaderBytes];
      const uint32_t payload = static_cast<uint32_t>(protocol::kTokenBytes + body.size());
      protocol::write_header(protocol::MessageType::kHello, payload, header);
      const auto& token = tls->token();
      const std::span<const uint8_t> parts[3] = {header, token, body};
      c->write_all(parts, 1000);
    } else {
      c->write_all(body, 1000);
    }
    ::shutdown(c->fd(), SHUT_WR);
    drain(*c);
  } catch (const Error&) {
  }
  return 0;
}
