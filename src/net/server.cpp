#include "volcast/net/server.hpp"

#include <spdlog/spdlog.h>

#include <asio.hpp>
#include <condition_variable>
#include <deque>
#include <functional>
#include <list>
#include <mutex>
#include <thread>

#include "socket_io.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

using asio::ip::tcp;

struct Server::Impl {
  ServerConfig config;
  std::vector<protocol::CameraInfo> cameras;
  asio::io_context io;
  tcp::acceptor acceptor{io};
  std::thread accept_thread;
  std::atomic<bool> stopping{false};

  // The newest frame set; viewers wait on `fresh` for a newer sequence.
  mutable std::mutex mutex;
  std::condition_variable fresh;
  std::shared_ptr<const FrameSet> latest;

  struct Viewer {
    std::unique_ptr<tcp::socket> socket;
    std::thread thread;
    ViewerReport report;
    std::atomic<bool> done{false};
  };
  std::list<Viewer> viewers;       // guarded by mutex
  std::deque<ViewerReport> ended;  // reports of viewers that left, newest last (bounded)
  static constexpr size_t kEndedReportsKept = 256;

  void accept_loop() {
    while (!stopping) {
      asio::error_code ec;
      auto socket = std::make_unique<tcp::socket>(io);
      acceptor.accept(*socket, ec);
      if (stopping) break;
      if (ec) {
        spdlog::warn("accept failed: {}", ec.message());
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
        continue;
      }
      std::lock_guard lock(mutex);
      reap_finished();
      Viewer& v = viewers.emplace_back();
      v.socket = std::move(socket);
      v.report.connected = true;
      asio::error_code peer_ec;
      const auto ep = v.socket->remote_endpoint(peer_ec);
      v.report.peer = peer_ec ? "?" : ep.address().to_string() + ":" + std::to_string(ep.port());
      const bool full = static_cast<int>(viewers.size()) > config.max_clients;
      v.thread = std::thread([this, &v, full] { serve_viewer(v, full); });
    }
  }

  // Joins the threads of viewers that have ended and keeps only their reports. Caller holds mutex
  // (a finished thread no longer takes it).
  void reap_finished() {
    for (auto it = viewers.begin(); it != viewers.end();) {
      if (!it->done) {
        ++it;
        continue;
      }
      if (it->thread.joinable()) it->thread.join();
      ended.push_back(it->report);
      if (ended.size() > kEndedReportsKept) ended.pop_front();
      it = viewers.erase(it);
    }
  }

  void update(Viewer& v, const std::function<void(ViewerReport&)>& f) {
    std::lock_guard lock(mutex);
    f(v.report);
  }

  void serve_viewer(Viewer& v, bool full) {
    tcp::socket& s = *v.socket;
    try {
      s.non_blocking(true);
      s.set_option(tcp::no_delay(true));
      protocol::Hello hello;
      try {
        uint8_t header_bytes[protocol::kHeaderBytes];
        detail::read_exact(s, header_bytes, sizeof header_bytes, config.handshake_timeout_ms,
                           stopping);
        const protocol::Header header =
            protocol::parse_header(header_bytes, protocol::kMaxHelloBytes);
        if (header.type != protocol::MessageType::kHello)
          throw Error("expected Hello as first message");
        std::vector<uint8_t> payload(header.payload_bytes);
        detail::read_exact(s, payload.data(), payload.size(), config.handshake_timeout_ms,
                           stopping);
        hello = protocol::parse_hello(payload);
      } catch (const Error& e) {
        // Tell a confused peer why (wrong version, garbage, timeout) before closing; best effort.
        const auto msg = protocol::message(
            protocol::MessageType::kReject,
            protocol::serialize_reject(std::string("handshake failed: ") + e.what()));
        try {
          detail::write_all(s, msg.data(), msg.size(), 200, stopping);
        } catch (const Error&) {
        }
        throw;
      }
      update(v, [&](ViewerReport& r) {
        r.depth_codec = hello.depth_codec;
        r.color_codec = hello.color_codec;
      });
      std::vector<std::unique_ptr<DepthEncoder>> depth;
      std::vector<std::unique_ptr<ColorEncoder>> color;
      try {
        if (full) throw Error("server full (" + std::to_string(config.max_clients) + " viewers)");
        for (size_t i = 0; i < cameras.size(); ++i) {
          depth.push_back(make_depth_encoder(hello.depth_codec));
          color.push_back(make_color_encoder(hello.color_codec));
        }
      } catch (const Error& e) {
        const auto msg =
            protocol::message(protocol::MessageType::kReject, protocol::serialize_reject(e.what()));
        detail::write_all(s, msg.data(), msg.size(), config.stall_timeout_ms, stopping);
        throw;
      }
      const auto welcome = protocol::message(protocol::MessageType::kWelcome,
                                             protocol::serialize(protocol::Welcome{cameras}));
      detail::write_all(s, welcome.data(), welcome.size(), config.stall_timeout_ms, stopping);
      spdlog::info("viewer {} connected (depth {}, color {})", v.report.peer, hello.depth_codec,
                   hello.color_codec);
      stream(v, depth, color);
    } catch (const std::exception& e) {
      if (!stopping) spdlog::info("viewer {} ended: {}", v.report.peer, e.what());
      update(v, [&](ViewerReport& r) { r.error = e.what(); });
    }
    asio::error_code ec;
    s.shutdown(tcp::socket::shutdown_both, ec);
    s.close(ec);
    update(v, [](ViewerReport& r) { r.connected = false; });
    v.done = true;
  }

  void stream(Viewer& v, std::vector<std::unique_ptr<DepthEncoder>>& depth,
              std::vector<std::unique_ptr<ColorEncoder>>& color) {
    protocol::EncodedFrameSet encoded;
    encoded.cameras.resize(cameras.size());
    std::vector<uint8_t> wire;
    uint64_t last_sequence = 0;
    bool first = true;
    uint64_t since_key = 0;
    uint64_t in_flight = 0;
    auto last_ack = std::chrono::steady_clock::now();
    uint8_t ack_header[protocol::kHeaderBytes];
    std::vector<uint8_t> ack_payload;
    // Reads one Ack (or any other message, which is a protocol error at this point).
    auto read_ack = [&] {
      detail::read_exact(*v.socket, ack_header, sizeof ack_header, config.handshake_timeout_ms,
                         stopping);
      const protocol::Header h = protocol::parse_header(ack_header, 64);
      if (h.type != protocol::MessageType::kAck) throw Error("viewer sent an unexpected message");
      ack_payload.resize(h.payload_bytes);
      detail::read_exact(*v.socket, ack_payload.data(), ack_payload.size(),
                         config.handshake_timeout_ms, stopping);
      const uint64_t acked = protocol::parse_ack(ack_payload);
      if (acked > last_sequence || in_flight == 0)
        throw Error("viewer acknowledged a frame set it was not sent");
      --in_flight;
      last_ack = std::chrono::steady_clock::now();
    };
    while (!stopping) {
      while (detail::wait_ready(*v.socket, POLLIN, 0)) read_ack();
      if (in_flight >= static_cast<uint64_t>(config.window)) {
        if (std::chrono::steady_clock::now() - last_ack >
            std::chrono::milliseconds(config.stall_timeout_ms))
          throw Error("viewer stalled: acknowledged nothing for " +
                      std::to_string(config.stall_timeout_ms) + " ms");
        if (detail::wait_ready(*v.socket, POLLIN, 50)) read_ack();
        continue;
      }
      std::shared_ptr<const FrameSet> frames;
      {
        std::unique_lock lock(mutex);
        fresh.wait_for(lock, std::chrono::milliseconds(100), [&] {
          return stopping || (latest && (first || latest->sequence > last_sequence));
        });
        if (stopping) return;
        if (!latest || (!first && latest->sequence <= last_sequence)) continue;
        frames = latest;
        if (!first) v.report.frames_dropped += frames->sequence - last_sequence - 1;
      }
      const bool key = first || ++since_key >= static_cast<uint64_t>(config.key_frame_interval);
      if (key) since_key = 0;
      encoded.sequence = frames->sequence;
      encoded.capture_time_us = frames->capture_time_us;
      for (size_t i = 0; i < cameras.size(); ++i) {
        const CameraFrame& f = frames->cameras[i];
        encoded.cameras[i].device_timestamp_us = f.device_timestamp_us;
        depth[i]->encode(f.depth, key, encoded.cameras[i].depth);
        color[i]->encode(f.color, key, encoded.cameras[i].color);
      }
      protocol::serialize(encoded, wire);
      detail::write_all(*v.socket, wire.data(), wire.size(), config.stall_timeout_ms, stopping);
      if (in_flight++ == 0) last_ack = std::chrono::steady_clock::now();
      first = false;
      last_sequence = frames->sequence;
      update(v, [&](ViewerReport& r) {
        ++r.frames_sent;
        r.bytes_sent += wire.size();
      });
    }
  }
};

Server::Server(std::vector<protocol::CameraInfo> cameras, ServerConfig config)
    : impl_(std::make_unique<Impl>()) {
  if (config.window < 1) throw Error("server: window must be at least 1");
  if (cameras.empty() || static_cast<int>(cameras.size()) > protocol::kMaxCameras)
    throw Error("server: a site needs 1 to " + std::to_string(protocol::kMaxCameras) + " cameras");
  impl_->config = std::move(config);
  impl_->cameras = std::move(cameras);
  try {
    const tcp::endpoint ep(asio::ip::make_address(impl_->config.bind_address), impl_->config.port);
    impl_->acceptor.open(ep.protocol());
    impl_->acceptor.set_option(tcp::acceptor::reuse_address(true));
    impl_->acceptor.bind(ep);
    impl_->acceptor.listen();
  } catch (const std::system_error& e) {
    throw Error("cannot listen on " + impl_->config.bind_address + ":" +
                std::to_string(impl_->config.port) + ": " + e.what());
  }
  impl_->accept_thread = std::thread([this] { impl_->accept_loop(); });
}

Server::~Server() {
  stop();
}

uint16_t Server::port() const {
  return impl_->acceptor.local_endpoint().port();
}

void Server::publish(std::shared_ptr<const FrameSet> frames) {
  if (!frames || frames->cameras.size() != impl_->cameras.size())
    throw Error("server: frame set has the wrong number of cameras");
  {
    std::lock_guard lock(impl_->mutex);
    impl_->latest = std::move(frames);
  }
  impl_->fresh.notify_all();
}

std::vector<ViewerReport> Server::viewers() const {
  std::lock_guard lock(impl_->mutex);
  std::vector<ViewerReport> out(impl_->ended.begin(), impl_->ended.end());
  for (const auto& v : impl_->viewers) out.push_back(v.report);
  return out;
}

void Server::stop() {
  if (impl_->stopping.exchange(true)) return;
  impl_->fresh.notify_all();
  asio::error_code ec;
  // Unblock accept(): shutdown + close of the listening socket.
  ::shutdown(impl_->acceptor.native_handle(), SHUT_RDWR);
  impl_->acceptor.close(ec);
  if (impl_->accept_thread.joinable()) impl_->accept_thread.join();
  // The accept thread has ended, so the list no longer changes; viewer threads notice `stopping`
  // within 100 ms and must be joined without holding the mutex they report through.
  for (auto& v : impl_->viewers)
    if (v.thread.joinable()) v.thread.join();
}

}  // namespace volcast
