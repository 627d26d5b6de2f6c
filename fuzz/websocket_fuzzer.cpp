// libFuzzer target: the server's HTTP and WebSocket engine (src/net/ws_engine.hpp, WebSocket++)
// on arbitrary bytes from a browser's side. With the first byte odd, a valid WebSocket upgrade on
// /stream comes first, so that the frame parser sees the rest; fed in pieces of the sizes the
// input's second byte picks. It may close, answer or drop; it must never crash, read past the
// input or buffer more than its message bound.
#include <algorithm>
#include <cstdint>
#include <memory>
#include <string>

#include "volcast/net/transport/ws_engine.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using volcast::detail::WsEngine;
  if (size < 2) return 0;
  auto assets = std::make_shared<volcast::detail::WebAssets>();
  (*assets)["/index.html"] = {"text/html", "<!doctype html>"};
  constexpr size_t kBound = 4108;  // a Hello's worth, as before authentication
  WsEngine engine(assets, kBound);
  if (data[0] & 1) {
    const std::string upgrade =
        "GET /stream HTTP/1.1\r\nHost: x\r\nUpgrade: websocket\r\nConnection: Upgrade\r\n"
        "Sec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\nSec-WebSocket-Version: 13\r\n\r\n";
    engine.feed(reinterpret_cast<const uint8_t*>(upgrade.data()), upgrade.size());
  }
  const size_t piece = 1 + data[1] % 64;
  for (size_t at = 2; at < size; at += piece) {
    engine.feed(data + at, std::min(piece, size - at));
    if (engine.inbox().size() > 2 * kBound) __builtin_trap();  // a message past its bound
    engine.inbox().clear();
    engine.output().clear();
  }
  return 0;
}
