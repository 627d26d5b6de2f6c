#include "volcast/net/client.hpp"

#include <asio.hpp>
#include <mutex>

#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

using asio::ip::tcp;

struct Client::Impl {
  asio::io_context io;
  tcp::socket socket{io};
  protocol::Welcome welcome;
  std::vector<std::unique_ptr<DepthDecoder>> depth;
  std::vector<std::unique_ptr<ColorDecoder>> color;
  protocol::EncodedFrameSet encoded;
  std::vector<uint8_t> payload;
  std::mutex close_mutex;
  bool closed = false;

  // Reads one message; returns false on a clean close.
  bool read_message(protocol::Header& header, uint32_t max_payload) {
    uint8_t bytes[protocol::kHeaderBytes];
    asio::error_code ec;
    asio::read(socket, asio::buffer(bytes), ec);
    if (ec == asio::error::eof || ec == asio::error::operation_aborted ||
        ec == asio::error::bad_descriptor)
      return false;
    if (ec) {
      std::lock_guard lock(close_mutex);
      if (closed) return false;
      throw Error("connection lost: " + ec.message());
    }
    header = protocol::parse_header(bytes, max_payload);
    payload.resize(header.payload_bytes);
    asio::read(socket, asio::buffer(payload), ec);
    if (ec) {
      std::lock_guard lock(close_mutex);
      if (closed) return false;
      throw Error("connection lost in the middle of a message: " + ec.message());
    }
    return true;
  }
};

Client::Client(const ClientConfig& config) : impl_(std::make_unique<Impl>()) {
  // Fail early, before connecting, on a codec this build does not have.
  make_depth_decoder(config.depth_codec);
  make_color_decoder(config.color_codec);
  try {
    tcp::resolver resolver(impl_->io);
    asio::connect(impl_->socket, resolver.resolve(config.host, std::to_string(config.port)));
    impl_->socket.set_option(tcp::no_delay(true));
  } catch (const std::system_error& e) {
    throw Error("cannot connect to " + config.host + ":" + std::to_string(config.port) + ": " +
                e.what());
  }
  const auto hello = protocol::message(
      protocol::MessageType::kHello,
      protocol::serialize(protocol::Hello{config.depth_codec, config.color_codec}));
  asio::error_code ec;
  asio::write(impl_->socket, asio::buffer(hello), ec);
  if (ec) throw Error("cannot send Hello: " + ec.message());
  protocol::Header header;
  if (!impl_->read_message(header, 1u << 20))
    throw Error("server closed the connection during the handshake");
  if (header.type == protocol::MessageType::kReject)
    throw Error("server rejected the connection: " + protocol::parse_reject(impl_->payload));
  if (header.type != protocol::MessageType::kWelcome)
    throw Error("expected Welcome from the server");
  impl_->welcome = protocol::parse_welcome(impl_->payload);
  for (size_t i = 0; i < impl_->welcome.cameras.size(); ++i) {
    impl_->depth.push_back(make_depth_decoder(config.depth_codec));
    impl_->color.push_back(make_color_decoder(config.color_codec));
  }
}

Client::~Client() {
  close();
}

const protocol::Welcome& Client::welcome() const {
  return impl_->welcome;
}

bool Client::receive(ReceivedFrameSet& out) {
  protocol::Header header;
  if (!impl_->read_message(header, protocol::kMaxPayloadBytes)) return false;
  if (header.type != protocol::MessageType::kFrameSet) throw Error("expected a FrameSet message");
  protocol::parse_frame_set(impl_->payload, impl_->encoded);
  const auto& cams = impl_->welcome.cameras;
  if (impl_->encoded.cameras.size() != cams.size())
    throw Error("frame set has " + std::to_string(impl_->encoded.cameras.size()) +
                " cameras, the site has " + std::to_string(cams.size()));
  out.frames.sequence = impl_->encoded.sequence;
  out.frames.capture_time_us = impl_->encoded.capture_time_us;
  out.frames.cameras.resize(cams.size());
  out.depth_bytes.resize(cams.size());
  out.color_bytes.resize(cams.size());
  out.message_bytes = protocol::kHeaderBytes + header.payload_bytes;
  for (size_t i = 0; i < cams.size(); ++i) {
    const protocol::EncodedCamera& e = impl_->encoded.cameras[i];
    CameraFrame& f = out.frames.cameras[i];
    f.device_timestamp_us = e.device_timestamp_us;
    impl_->depth[i]->decode(e.depth, f.depth);
    impl_->color[i]->decode(e.color, f.color);
    const Intrinsics& k = cams[i].calibration.depth;
    if (f.depth.width != k.width || f.depth.height != k.height)
      throw Error("camera " + std::to_string(i) +
                  ": depth frame size differs from its calibration");
    if (!f.color.empty() && (f.color.width != k.width || f.color.height != k.height))
      throw Error("camera " + std::to_string(i) + ": color frame is not registered to depth");
    out.depth_bytes[i] = e.depth.size();
    out.color_bytes[i] = e.color.size();
  }
  // Decoded: tell the server, which sends the next (newest) frame set only then.
  const auto ack =
      protocol::message(protocol::MessageType::kAck, protocol::serialize_ack(out.frames.sequence));
  asio::error_code ec;
  asio::write(impl_->socket, asio::buffer(ack), ec);
  if (ec) {
    std::lock_guard lock(impl_->close_mutex);
    if (!impl_->closed) throw Error("connection lost while acknowledging: " + ec.message());
  }
  return true;
}

void Client::close() {
  std::lock_guard lock(impl_->close_mutex);
  if (impl_->closed) return;
  impl_->closed = true;
  asio::error_code ec;
  impl_->socket.shutdown(tcp::socket::shutdown_both, ec);
}

}  // namespace volcast
