#pragma once
// A test viewer speaking the stream protocol directly over TLS, keeping each frame set's shared
// body -- and, when the server sealed it, the sealed bytes as they came on the wire.
#include <array>
#include <memory>
#include <span>
#include <string>
#include <utility>
#include <vector>

#include "volcast/core/error.hpp"
#include "volcast/net/protocol/frame_set.hpp"
#include "volcast/net/stream/seal.hpp"
#include "volcast/net/stream/server.hpp"
#include "volcast/net/transport/connection.hpp"
#include "volcast/net/transport/tls.hpp"

namespace volcast::test {

struct RawViewer {
  std::unique_ptr<Connection> c;
  std::vector<uint8_t> payload;
  std::vector<uint8_t> sealed;  ///< the last frame set's sealed bytes; empty if it was not sealed
  std::array<uint8_t, protocol::kSealKeyBytes> key{};  ///< the last sealed frame set's key
  protocol::MessageType type{};                        ///< the last frame set's message type

  RawViewer(const Server& server, const std::string& depth = "volcast",
            const std::string& color = "jpeg") {
    c = connect_tls("127.0.0.1", server.port(), TlsContext::client(), 5000).connection;
    protocol::Hello hello;
    hello.token = server.token();
    hello.tier.depth_codec = depth;
    hello.tier.color_codec = color;
    c->write_all(protocol::message(protocol::MessageType::kHello, protocol::serialize(hello)),
                 5000);
    if (read().type != protocol::MessageType::kWelcome) throw Error("no Welcome");
  }
  protocol::Header read() {
    uint8_t bytes[protocol::kHeaderBytes];
    c->read_exact(bytes, 20000);
    const protocol::Header h = protocol::parse_header(bytes);
    payload.resize(h.payload_bytes);
    c->read_exact(payload, 20000);
    return h;
  }
  /// Reads the next frame set (1.1, or 1.2 opened as a viewer does) and returns its sequence and
  /// body (the payload after the 8-byte send time); `payload` is left as a 1.1 FrameSet's.
  std::pair<uint64_t, std::vector<uint8_t>> next_frame_set(bool ack = true) {
    type = read().type;
    sealed.clear();
    if (type == protocol::MessageType::kSealedFrameSet) {
      protocol::SealedFrameSet seal;
      protocol::parse_sealed_frame_set(payload, seal);
      key = seal.key;
      sealed.resize(seal.body_bytes);
      c->read_raw(sealed, 20000);
      payload.assign(8, 0);
      payload.insert(payload.end(), sealed.begin(), sealed.end());
      open_sealed(seal, std::span(payload).subspan(8), nullptr);
    } else if (type != protocol::MessageType::kFrameSet) {
      throw Error("expected a frame set");
    }
    protocol::FrameSetView view;
    protocol::parse_frame_set(payload, view);
    if (ack) c->write_all(protocol::ack_message(view.sequence), 5000);
    return {view.sequence, std::vector<uint8_t>(payload.begin() + 8, payload.end())};
  }
};

}  // namespace volcast::test
