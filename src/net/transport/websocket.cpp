#include "volcast/net/transport/websocket.hpp"

#include <poll.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <cstring>
#include <fstream>
#include <map>
#include <utility>

#include "volcast/core/error.hpp"

namespace volcast::detail {

namespace {

constexpr uintmax_t kMaxAssetBytes = 16u << 20, kMaxAssetsBytes = 64u << 20;

std::string content_type(const std::filesystem::path& p) {
  static const std::map<std::string, std::string> types = {
      {".html", "text/html; charset=utf-8"},
      {".js", "text/javascript; charset=utf-8"},
      {".mjs", "text/javascript; charset=utf-8"},
      {".css", "text/css; charset=utf-8"},
      {".wasm", "application/wasm"},
      {".json", "application/json"},
      {".png", "image/png"},
      {".svg", "image/svg+xml"},
      {".ico", "image/x-icon"}};
  const auto it = types.find(p.extension().string());
  return it == types.end() ? "application/octet-stream" : it->second;
}

using Clock = std::chrono::steady_clock;

int ms_left(Clock::time_point deadline) {
  return static_cast<int>(std::max<int64_t>(
      0, std::chrono::duration_cast<std::chrono::milliseconds>(deadline - Clock::now()).count()));
}

}  // namespace

WebAssets load_web_assets(const std::filesystem::path& dir) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(dir / "index.html", ec))
    throw Error("web viewer: no index.html in " + dir.string() +
                " (build the web viewer: it needs Emscripten; or pass --web-root)");
  WebAssets assets;
  uintmax_t total = 0;
  for (const auto& e : std::filesystem::recursive_directory_iterator(dir)) {
    if (!e.is_regular_file()) continue;
    const uintmax_t size = e.file_size();
    total += size;
    if (size > kMaxAssetBytes || total > kMaxAssetsBytes)
      throw Error("web viewer: " + e.path().string() + " makes the page assets too large");
    std::ifstream in(e.path(), std::ios::binary);
    std::string bytes(size, '\0');
    if (!in.read(bytes.data(), static_cast<std::streamsize>(size)))
      throw Error("web viewer: cannot read " + e.path().string());
    const std::string url = "/" + std::filesystem::relative(e.path(), dir).generic_string();
    assets[url] = WebFile{content_type(e.path()), std::move(bytes)};
  }
  return assets;
}

WebSocketConnection::WebSocketConnection(std::unique_ptr<Connection> inner,
                                         std::span<const uint8_t> already_read,
                                         std::shared_ptr<const WebAssets> assets,
                                         size_t max_message_bytes, size_t read_budget)
    : inner_(std::move(inner)),
      engine_(std::move(assets), max_message_bytes),
      read_(already_read.size()),
      read_budget_(read_budget) {
  engine_.feed(already_read.data(), already_read.size());
}

WebSocketConnection::~WebSocketConnection() = default;

WebSocketConnection::Http WebSocketConnection::http() const {
  switch (engine_.state()) {
    case WsEngine::State::kRequest:
      return Http::kReading;
    case WsEngine::State::kResponded:
      return Http::kAnswered;
    default:
      return Http::kOpen;
  }
}

std::string WebSocketConnection::path() const {
  return engine_.path();
}

std::string WebSocketConnection::take_response() {
  return std::exchange(engine_.output(), {});
}

std::unique_ptr<Connection> WebSocketConnection::release_inner() {
  return std::move(inner_);
}

void WebSocketConnection::authenticated(size_t max_message_bytes) {
  engine_.set_max_message_bytes(max_message_bytes);
  engine_.set_answer_pings(true);
  read_budget_ = SIZE_MAX;
}

void WebSocketConnection::pump() {
  if (read_ >= read_budget_)
    throw Error("over the limit of " + std::to_string(read_budget_) +
                " bytes before the Hello (for a connection not yet authenticated: its request, "
                "pings and frames all count)");
  uint8_t buffer[16384];
  for (size_t pumped = 0; pumped < kPumpBytes && read_ < read_budget_;) {
    const size_t want = std::min(sizeof(buffer), read_budget_ - read_);
    const size_t n = inner_->read_available(std::span(buffer, want));
    if (n == 0) break;
    read_ += n;
    pumped += n;
    engine_.feed(buffer, n);
    if (n < want) break;
  }
}

void WebSocketConnection::flush(int stall_ms) {
  std::string& out = engine_.output();
  if (out.empty()) return;
  const std::string bytes = std::exchange(out, {});
  inner_->write_all(std::span(reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size()),
                    stall_ms);
}

int WebSocketConnection::handshake_step() {
  if (engine_.state() == WsEngine::State::kRequest) pump();
  switch (engine_.state()) {
    case WsEngine::State::kRequest:
      return POLLIN;
    case WsEngine::State::kOpen:
      flush(1000);
      return 0;  // the 101 answer: a few hundred bytes
    case WsEngine::State::kResponded:
      return 0;
    case WsEngine::State::kClosed:
      break;
  }
  throw Error("HTTP request refused: " + engine_.error());
}

size_t WebSocketConnection::take(std::span<uint8_t> data) {
  std::string& inbox = engine_.inbox();
  const size_t n = std::min(data.size(), inbox.size() - inbox_offset_);
  std::memcpy(data.data(), inbox.data() + inbox_offset_, n);
  inbox_offset_ += n;
  if (inbox_offset_ == inbox.size()) {
    inbox.clear();
    inbox_offset_ = 0;
  } else if (inbox_offset_ > 65536 && inbox_offset_ * 2 > inbox.size()) {
    inbox.erase(0, inbox_offset_);  // keeps a long-lived inbox from growing
    inbox_offset_ = 0;
  }
  return n;
}

size_t WebSocketConnection::read_available(std::span<uint8_t> data) {
  if (engine_.inbox().size() == inbox_offset_) {
    if (engine_.state() == WsEngine::State::kOpen) pump();
    flush(1000);  // a pong or close frame the engine answered with
    if (engine_.inbox().size() == inbox_offset_ && engine_.state() != WsEngine::State::kOpen)
      throw Error(engine_.error().empty() ? "peer closed the connection" : engine_.error());
  }
  return take(data);
}

void WebSocketConnection::read_exact(std::span<uint8_t> data, int timeout_ms) {
  const auto deadline = Clock::now() + std::chrono::milliseconds(timeout_ms);
  size_t have = 0;
  while (have < data.size()) {
    const size_t n = read_available(data.subspan(have));
    have += n;
    if (have == data.size()) break;
    if (n == 0) {
      const int left = timeout_ms < 0 ? -1 : ms_left(deadline);
      if (timeout_ms >= 0 && left == 0) throw Error("timed out waiting for the peer");
      inner_->wait(-1, left < 0 ? 100 : std::min(left, 100));
    }
  }
}

void WebSocketConnection::read_raw(std::span<uint8_t>, int) {
  throw Error("WebSocket: the peer cannot send raw bytes (protocol error)");
}

void WebSocketConnection::write_all(std::span<const std::span<const uint8_t>> parts, int stall_ms) {
  if (engine_.state() != WsEngine::State::kOpen)
    throw Error(engine_.error().empty() ? "peer closed the connection" : engine_.error());
  flush(stall_ms);
  uint64_t bytes = 0;
  for (const auto& p : parts) bytes += p.size();
  const std::string header = WsEngine::binary_frame_header(bytes);
  constexpr size_t kMaxParts = 15;
  if (parts.size() > kMaxParts) throw Error("write_all: too many parts");
  std::span<const uint8_t> all[kMaxParts + 1];
  all[0] = std::span(reinterpret_cast<const uint8_t*>(header.data()), header.size());
  std::copy(parts.begin(), parts.end(), all + 1);
  inner_->write_all(std::span(all, parts.size() + 1), stall_ms);
}

void WebSocketConnection::write_with_raw(std::span<const std::span<const uint8_t>>,
                                         std::span<const uint8_t>, int) {
  throw Error("WebSocket: raw bytes cannot travel outside WebSocket messages");
}

bool WebSocketConnection::encrypted() const {
  return inner_->encrypted();
}

Connection::Ready WebSocketConnection::wait(int wake_fd, int timeout_ms) {
  if (engine_.inbox().size() > inbox_offset_ || engine_.state() != WsEngine::State::kOpen) {
    Ready r;
    r.readable = true;  // buffered bytes, or the close to report
    return r;
  }
  return inner_->wait(wake_fd, timeout_ms);
}

}  // namespace volcast::detail
