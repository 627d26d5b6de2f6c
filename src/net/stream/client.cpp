#include "volcast/net/stream/client.hpp"

#include <spdlog/spdlog.h>

#include <sys/eventfd.h>
#include <unistd.h>
#include <algorithm>
#include <atomic>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <deque>
#include <mutex>
#include <optional>
#include <thread>

#include "client_connect.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/codec/registry.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/core/worker_pool.hpp"
#include "volcast/net/protocol/frame_set.hpp"
#include "volcast/net/stream/seal.hpp"
#include "volcast/net/stream/session_port.hpp"
#include "volcast/net/transport/connection.hpp"

namespace volcast {

namespace {

using Clock = std::chrono::steady_clock;
using Kind = ClientError::Kind;

// A payload is read this much at a time, its buffer growing only as bytes arrive: a header that
// promises a large payload and is followed by silence costs little.
constexpr size_t kReadChunkBytes = 1 << 20;
// Session messages posted while a long message arrives (a participant's pose while the case's
// megabytes do) leave after at most this much more of it has been read, not after all of it.
constexpr size_t kSendBetweenBytes = 64 << 10;

}  // namespace

struct Client::Impl {
  ClientConfig config;
  std::unique_ptr<Connection> connection;
  std::atomic<int> socket{-1};  // connection's fd() once connected, for other threads
  protocol::Welcome welcome;
  uint32_t frame_set_limit = 0;  // protocol::frame_set_payload_limit(welcome)
  int64_t clock_offset_us = 0;
  std::unique_ptr<FrameSetDecoder> decoder;  // the tier's decoders (frame_set.hpp), after Welcome
  std::unique_ptr<WorkerPool> pool;
  protocol::FrameSetView unopened;  // a sealed frame set a receive-only viewer did not open
  std::vector<uint8_t> buffer;      // the last message's payload is its first payload_bytes bytes
  size_t payload_bytes = 0;
  size_t wire_bytes = 0;          // the last message's bytes on the wire (sealed body included)
  protocol::SealedFrameSet seal;  // the last SealedFrameSet's descriptor (chunk list reused)
  std::atomic<bool> closed{false};
  uint64_t undecodable = 0;
  TierState tier;
  // Repeated frames: each camera's last decoded bytes, and the object they were decoded into.
  bool stateless = false;  // both codecs non-temporal
  const ReceivedFrameSet* last_out = nullptr;
  std::vector<std::vector<uint8_t>> last_depth, last_color;
  // Session channel: the handler, and messages waiting for the receiving thread to send them.
  std::mutex handler_mutex;  // the two below: set from any thread (a participant moving off)
  SessionHandler session_handler;
  std::function<uint32_t(uint8_t)> session_max_payload;
  std::mutex outbox_mutex;
  std::deque<std::pair<uint64_t, std::vector<uint8_t>>> outbox;
  std::atomic<bool> outbox_posted{false};  // set by post_session, cleared by flush_outbox
  int wake_fd = ::eventfd(0, EFD_NONBLOCK | EFD_CLOEXEC);
  std::vector<std::vector<uint8_t>> sending;

  ~Impl() { ::close(wake_fd); }

  // Writes the queued session messages (on the receiving thread).
  void flush_outbox() {
    uint64_t v;
    [[maybe_unused]] const auto n = ::read(wake_fd, &v, sizeof v);
    outbox_posted = false;
    sending.clear();
    {
      std::lock_guard lock(outbox_mutex);
      for (auto& m : outbox) sending.push_back(std::move(m.second));
      outbox.clear();
    }
    for (const auto& m : sending) send(m);
  }

  // Waits until a message starts arriving, sending queued session messages meanwhile. False when
  // `deadline` passed first (the read that follows then times out).
  void wait_for_message(std::optional<Clock::time_point> deadline) {
    while (!closed) {
      const int left = ms_left(deadline);
      const Connection::Ready ready = connection->wait(wake_fd, left);
      if (ready.woken) flush_outbox();
      if (ready.readable || (!ready.woken && left >= 0)) return;  // data, or time is up
    }
  }

  std::span<const uint8_t> payload() const { return {buffer.data(), payload_bytes}; }

  // Takes a TierChange: decoders for the new tier (the next frame set is its key frame set), or a
  // notice. A change the viewer did not allow (it pinned its tier, or keeps depth lossless) ends
  // the connection: the medical rule is checked here too, not only trusted to the server.
  void change_tier() {
    protocol::TierChange c;
    try {
      c = protocol::parse_tier_change(payload());
      const bool same = c.tier == tier.tier;
      if (!same && !config.adapt)
        throw Error("the server changed the tier of a viewer that pinned it");
      const DepthCodecInfo* d = find_depth_codec(c.tier.depth_codec);
      if (!d || !find_color_codec(c.tier.color_codec))
        throw Error("the server changed to a tier with a codec this build lacks");
      if (!same && config.keep_lossless && !d->lossless)
        throw Error("the server changed to lossy depth (" + printable(c.tier.depth_codec) +
                    ") a viewer that keeps depth lossless");
      if (!same) {
        decoder = std::make_unique<FrameSetDecoder>(c.tier.depth_codec, c.tier.color_codec,
                                                    welcome.cameras);
        stateless = decoder->stateless();
        last_out = nullptr;
        ++tier.changes;
      } else if (!tier.reason.empty() || !config.adapt) {  // not an adaptive viewer's first word
        ++tier.notices;
      }
    } catch (const Error& e) {
      throw ClientError(Kind::kProtocol, std::string("TierChange from the server: ") + e.what());
    }
    tier.tier = c.tier;
    tier.path_mbit_s = c.path_kbit_s / 1e3;
    tier.reason = printable(c.reason);
    tier.lossless_depth = find_depth_codec(c.tier.depth_codec)->lossless;
    ++tier.messages;
  }

  // What the error messages of read_message() say ran out.
  std::string timeout_message(bool handshake) const {
    return handshake ? "no Welcome from the server within " +
                           std::to_string(config.handshake_timeout_ms) +
                           " ms of connecting (handshake timeout)"
                     : "no complete message from the server for " +
                           std::to_string(config.receive_timeout_ms) + " ms (receive timeout)";
  }

  // Reads one message whose payload may be at most `max_payload` bytes, all of it before
  // `deadline` (none: no limit); returns false on a clean close (by the peer between messages, or
  // close()). `handshake`: the Welcome is expected (else a FrameSet), for errors.
  bool read_message(protocol::Header& header, uint32_t max_payload,
                    std::optional<Clock::time_point> deadline, bool handshake) {
    uint8_t bytes[protocol::kHeaderBytes];
    try {
      if (!handshake) wait_for_message(deadline);
      connection->read_exact(bytes, ms_left(deadline));
    } catch (const Error& e) {
      if (closed || std::string(e.what()) == "peer closed the connection") return false;
      if (timed_out(e, deadline)) throw ClientError(Kind::kTimedOut, timeout_message(handshake));
      throw ClientError(Kind::kConnectionLost, std::string("connection lost: ") + e.what());
    }
    try {
      // A SealedFrameSet's payload is its descriptor, whose own limit may exceed a tiny site's.
      header = protocol::parse_header(bytes, handshake ? max_payload : protocol::kMaxPayloadBytes);
      uint32_t limit = header.type == protocol::MessageType::kSealedFrameSet
                           ? protocol::kMaxSealedFrameSetBytes
                           : max_payload;
      if (header.type == protocol::MessageType::kTierChange) limit = protocol::kMaxControlBytes;
      if (!handshake && header.channel == protocol::Channel::kSession) {
        const uint8_t t = static_cast<uint8_t>(static_cast<uint16_t>(header.type) & 0xff);
        std::lock_guard lock(handler_mutex);
        limit = session_max_payload ? session_max_payload(t) : protocol::kMaxControlBytes;
        if (limit == 0) throw Error("unknown session message type " + std::to_string(t));
      }
      if (header.payload_bytes > limit)
        throw Error("malformed header: payload of " + std::to_string(header.payload_bytes) +
                    " bytes exceeds the limit of " + std::to_string(limit));
    } catch (const Error& e) {
      throw ClientError(Kind::kProtocol, std::string(handshake ? "handshake" : "FrameSet") +
                                             " from the server: " + e.what());
    }
    // The decode workers wake while the frame set's body arrives, not after it.
    if (pool && (header.type == protocol::MessageType::kFrameSet ||
                 header.type == protocol::MessageType::kSealedFrameSet))
      pool->prewake(std::chrono::milliseconds(1));
    payload_bytes = 0;
    if (!read_bytes(0, header.payload_bytes, false, deadline, handshake)) return false;
    payload_bytes = header.payload_bytes;
    wire_bytes = protocol::kHeaderBytes + payload_bytes;
    return true;
  }

  // Reads `n` bytes into buffer[at, at + n) -- through the transport, or `raw` (outside TLS) --
  // growing the buffer only as they arrive, all before `deadline`; false after close(). Through
  // the transport after the handshake, session messages posted meanwhile are sent every
  // kSendBetweenBytes: the server hears from a participant while a long message reaches it over a
  // slow path or on a loaded machine (hub.cpp's presence timeout). Throws ClientError like
  // read_message.
  bool read_bytes(size_t at, size_t n, bool raw, std::optional<Clock::time_point> deadline,
                  bool handshake) {
    const bool send_between = !raw && !handshake;
    for (size_t done = 0; done < n;) {
      const size_t end = std::min(n, done + (send_between ? kSendBetweenBytes : kReadChunkBytes));
      if (buffer.size() < at + end) buffer.resize(at + end);  // capacity at least doubles
      const auto chunk = std::span(buffer).subspan(at + done, end - done);
      const int left_ms = ms_left(deadline);
      try {
        if (send_between && outbox_posted) flush_outbox();
        if (raw)
          connection->read_raw(chunk, left_ms);
        else
          connection->read_exact(chunk, left_ms);
      } catch (const ClientError&) {
        throw;  // from flush_outbox: the connection was lost while sending
      } catch (const Error& e) {
        if (closed) return false;
        if (timed_out(e, deadline))
          throw ClientError(Kind::kTimedOut, timeout_message(handshake) + " (" +
                                                 std::to_string(done) + " of " + std::to_string(n) +
                                                 " bytes of a message received)");
        throw ClientError(Kind::kConnectionLost,
                          std::string("connection lost in the middle of a message: ") + e.what());
      }
      done = end;
    }
    return true;
  }

  // After a SealedFrameSet's descriptor (in `buffer`): reads its sealed body from outside TLS
  // and, if `open`, checks and opens it, leaving the frame set's payload (send time + body) in
  // `buffer` as a FrameSet would (unopened, `buffer` holds the sealed bytes). False after close().
  // Throws ClientError kProtocol on a malformed descriptor, a body above the site's bound (before
  // reading it) or one that fails its digest or tag.
  bool read_sealed_body(std::optional<Clock::time_point> deadline, bool open) {
    if (!connection->encrypted())
      throw ClientError(Kind::kProtocol,
                        "a sealed frame set arrived over a connection without TLS");
    try {
      protocol::parse_sealed_frame_set(payload(), seal);
    } catch (const Error& e) {
      throw ClientError(Kind::kProtocol, e.what());
    }
    if (8 + uint64_t{seal.body_bytes} > frame_set_limit)
      throw ClientError(Kind::kProtocol, "sealed frame set of " + std::to_string(seal.body_bytes) +
                                             " bytes exceeds the limit of " +
                                             std::to_string(frame_set_limit) + " for this site");
    if (!open) {
      if (!read_bytes(8, seal.body_bytes, true, deadline, false)) return false;
      wire_bytes += seal.body_bytes;
      return true;
    }
    // Each chunk is opened as soon as it has arrived, while the next is still on the way: on a
    // real link little is left to open after the last byte.
    for (size_t i = 0, at = 0; i < seal.chunks.size(); ++i, at += seal.chunk_bytes) {
      const size_t n = std::min<size_t>(seal.chunk_bytes, seal.body_bytes - at);
      if (!read_bytes(8 + at, n, true, deadline, false)) return false;
      // The decode workers wake while the last chunk is opened, not after it.
      if (pool && i + 1 == seal.chunks.size()) pool->prewake(std::chrono::milliseconds(1));
      try {
        open_sealed_chunk(seal, i, std::span(buffer).subspan(8 + at, n));
      } catch (const Error& e) {
        throw ClientError(Kind::kProtocol, e.what());
      }
    }
    if (buffer.size() < 8) buffer.resize(8);  // an empty body
    wire::store<int64_t>(buffer.data(), seal.send_us);
    payload_bytes = 8 + seal.body_bytes;
    wire_bytes += seal.body_bytes;
    return true;
  }

  // Whether a read that failed with `e` ran out of time.
  static bool timed_out(const Error& e, std::optional<Clock::time_point> deadline) {
    return deadline && (std::string_view(e.what()) == "timed out waiting for the peer" ||
                        Clock::now() >= *deadline);
  }

  // The time left until `deadline` for the next read (-1: no limit; 0 still reads what arrived).
  static int ms_left(std::optional<Clock::time_point> deadline) {
    if (!deadline) return -1;
    const auto left =
        std::chrono::ceil<std::chrono::milliseconds>(*deadline - Clock::now()).count();
    return static_cast<int>(std::clamp<int64_t>(left, 0, INT32_MAX));
  }

  static std::optional<Clock::time_point> deadline_in(int timeout_ms) {
    if (timeout_ms <= 0) return std::nullopt;
    return Clock::now() + std::chrono::milliseconds(timeout_ms);
  }

  // Hands the session message just read to the handler; an Error it throws is a kProtocol one.
  void to_session_handler(const protocol::Header& header) {
    std::lock_guard lock(handler_mutex);
    if (!session_handler) return;
    try {
      session_handler(static_cast<uint8_t>(static_cast<uint16_t>(header.type) & 0xff), payload());
    } catch (const ClientError&) {
      throw;
    } catch (const Error& e) {
      throw ClientError(Kind::kProtocol, std::string("session message: ") + e.what());
    }
  }

  // The frame set just read (its payload in `buffer`), read by the tier's FrameSetDecoder -- or,
  // for a sealed one a receive-only viewer did not open, taken from its descriptor. Throws
  // ClientError kProtocol on a malformed one, a descriptor whose copy of the head differs from the
  // opened body's, another camera count than the site's, or (when decoding or keeping the bytes)
  // a stream that declares another size than its camera's calibration.
  const protocol::FrameSetView& read_frame_set(bool sealed) {
    if (sealed && !config.decode && !config.keep_encoded) {
      unopened.sequence = seal.sequence;
      unopened.key = seal.key_frame_set;
      unopened.times = seal.times;
      unopened.times.send_us = seal.send_us;
      unopened.cameras.assign(welcome.cameras.size(), {});  // sizes and device times: in the body
      return unopened;
    }
    try {
      const protocol::FrameSetView& view = decoder->read(payload());
      if (sealed && (view.sequence != seal.sequence || view.key != seal.key_frame_set ||
                     view.times.capture_us != seal.times.capture_us ||
                     view.times.filter_done_us != seal.times.filter_done_us ||
                     view.times.encode_done_us != seal.times.encode_done_us))
        throw Error(
            "sealed frame set: the descriptor's copy of sequence, flags and times differs from "
            "the opened body's");
      if (config.decode || config.keep_encoded) decoder->check_declared_sizes();
      return view;
    } catch (const Error& e) {
      throw ClientError(Kind::kProtocol, e.what());
    }
  }

  // Fills `out` from `view`, all but the images: the sender's times on this clock, sizes, device
  // times, no camera repeated, and the encoded body when the config keeps it.
  void describe(const protocol::FrameSetView& view, int64_t received_us,
                ReceivedFrameSet& out) const {
    const size_t n = view.cameras.size();
    out.frames.sequence = view.sequence;
    out.frames.capture_time_us = view.times.capture_us - clock_offset_us;
    out.frames.cameras.resize(n);
    out.key = view.key;
    out.times.capture_us = view.times.capture_us - clock_offset_us;
    out.times.filter_done_us = view.times.filter_done_us - clock_offset_us;
    out.times.encode_done_us = view.times.encode_done_us - clock_offset_us;
    out.times.send_us = view.times.send_us - clock_offset_us;
    out.times.received_us = received_us;
    out.depth_bytes.resize(n);
    out.color_bytes.resize(n);
    out.repeated.assign(n, 0);
    out.message_bytes = wire_bytes;
    for (size_t i = 0; i < n; ++i) {
      out.frames.cameras[i].device_timestamp_us = view.cameras[i].device_timestamp_us;
      out.depth_bytes[i] = view.cameras[i].depth.size();
      out.color_bytes[i] = view.cameras[i].color.size();
    }
    if (config.keep_encoded) {
      const auto body = payload().subspan(8);
      out.encoded_body.assign(body.begin(), body.end());
    } else {
      out.encoded_body.clear();
    }
  }

  // Decodes the frame set the decoder read into `out`, in parallel; a camera whose bytes equal
  // those decoded into this same `out` last time is not decoded again (stateless codecs only:
  // the same bytes decode to the same images). False if it cannot be decoded (a delta whose
  // reference is missing, or corrupt bytes). Throws Error if an image differs from its
  // calibration.
  bool decode(ReceivedFrameSet& out) {
    const protocol::FrameSetView& view = decoder->view();
    const size_t n = view.cameras.size();
    const bool same_out = stateless && last_out == &out;
    for (size_t i = 0; i < n; ++i)
      out.repeated[i] = same_out && std::ranges::equal(view.cameras[i].depth, last_depth[i]) &&
                        std::ranges::equal(view.cameras[i].color, last_color[i]);
    try {
      decoder->decode_cameras(out.frames, pool.get(), out.repeated);
    } catch (const Error& e) {
      last_out = nullptr;  // `out` holds partly decoded images now
      if (undecodable++ == 0)
        spdlog::warn("frame set {} not decoded: {}", out.frames.sequence, e.what());
      return false;
    }
    last_out = &out;
    if (stateless)
      for (size_t i = 0; i < n; ++i) {
        last_depth[i].assign(view.cameras[i].depth.begin(), view.cameras[i].depth.end());
        last_color[i].assign(view.cameras[i].color.begin(), view.cameras[i].color.end());
      }
    for (size_t i = 0; i < n; ++i) {
      if (out.repeated[i]) continue;  // not decoded: what the caller left there
      const CameraFrame& f = out.frames.cameras[i];
      const Intrinsics& k = welcome.cameras[i].calibration.depth;
      if (f.depth.width != k.width || f.depth.height != k.height)
        throw Error("camera " + std::to_string(i) +
                    ": depth frame size differs from its calibration");
      if (!f.color.empty() && (f.color.width != k.width || f.color.height != k.height))
        throw Error("camera " + std::to_string(i) + ": color frame is not registered to depth");
    }
    return true;
  }

  void send(std::span<const uint8_t> message) {
    try {
      connection->write_all(message, 10000);
    } catch (const Error& e) {
      if (!closed)
        throw ClientError(Kind::kConnectionLost,
                          std::string("connection lost while acknowledging: ") + e.what());
    }
  }
};

Client::Client(const ClientConfig& config) : impl_(std::make_unique<Impl>()) {
  impl_->config = config;
  // Fail early, before connecting, on a codec this build does not have.
  make_depth_decoder(config.tier.depth_codec);
  make_color_decoder(config.tier.color_codec);
  if (config.tier.color_quality < 0 || config.tier.color_quality > 100)
    throw Error("color quality must be 1..100 (0 = the codec's default)");
  if (config.tier.frame_divisor != 1)
    throw Error("a viewer asks for every frame set (tier " + to_string(config.tier) +
                "): the server's ladder skips them");
  impl_->connection = open_connection(config);
  impl_->socket = impl_->connection->fd();
  const auto deadline = Impl::deadline_in(config.handshake_timeout_ms);
  const int64_t sent_us = wall_clock_us();
  const protocol::Hello hello = hello_for(config);
  try {
    impl_->connection->write_all(
        protocol::message(protocol::MessageType::kHello, protocol::serialize(hello)),
        config.handshake_timeout_ms > 0 ? config.handshake_timeout_ms : 10000);
  } catch (const Error& e) {
    throw ClientError(Kind::kConnectionLost, std::string("cannot send Hello: ") + e.what());
  }
  protocol::Header header;
  if (!impl_->read_message(header, protocol::kMaxWelcomeBytes, deadline, true))
    throw ClientError(Kind::kConnectionLost, "server closed the connection during the handshake");
  const int64_t received_us = wall_clock_us();
  try {
    if (header.type == protocol::MessageType::kReject)
      throw ClientError(Kind::kRejected, "server rejected the connection: " +
                                             printable(protocol::parse_reject(impl_->payload())));
    if (header.type != protocol::MessageType::kWelcome)
      throw ClientError(Kind::kProtocol, "expected Welcome from the server");
    impl_->welcome = protocol::parse_welcome(impl_->payload());
  } catch (const ClientError&) {
    throw;
  } catch (const Error& e) {
    throw ClientError(Kind::kProtocol, e.what());
  }
  impl_->frame_set_limit = protocol::frame_set_payload_limit(impl_->welcome);
  // Offset = server clock - ours, from the server's time at Welcome and our handshake midpoint;
  // uncertain by half the handshake's round trip, within which the clocks count as one.
  const int64_t offset = impl_->welcome.server_time_us - (sent_us + received_us) / 2;
  if (std::llabs(offset) > (received_us - sent_us) / 2) impl_->clock_offset_us = offset;
  impl_->decoder = std::make_unique<FrameSetDecoder>(
      config.tier.depth_codec, config.tier.color_codec, impl_->welcome.cameras);
  impl_->tier.tier = config.tier;
  impl_->tier.lossless_depth = depth_codec_info(config.tier.depth_codec).lossless;
  if (config.decode) impl_->pool = std::make_unique<WorkerPool>(config.decode_threads);
  impl_->stateless = impl_->decoder->stateless();
  impl_->last_depth.resize(impl_->welcome.cameras.size());
  impl_->last_color.resize(impl_->welcome.cameras.size());
}

Client::~Client() {
  close();
}

const protocol::Welcome& Client::welcome() const {
  return impl_->welcome;
}

int64_t Client::clock_offset_us() const {
  return impl_->clock_offset_us;
}

const TierState& Client::tier() const {
  return impl_->tier;
}

uint64_t Client::frames_undecodable() const {
  return impl_->undecodable;
}

bool Client::receive(ReceivedFrameSet& out) {
  Impl& m = *impl_;
  while (true) {
    protocol::Header header;
    const auto deadline = Impl::deadline_in(m.config.receive_timeout_ms);
    if (!m.read_message(header, m.frame_set_limit, deadline, false)) return false;
    if (header.channel == protocol::Channel::kSession) {
      m.to_session_handler(header);
      continue;
    }
    if (header.type == protocol::MessageType::kTierChange) {
      m.change_tier();
      continue;
    }
    const bool sealed = header.type == protocol::MessageType::kSealedFrameSet;
    if (sealed) {
      // A receive-only viewer has no use for the body: it acknowledges from the descriptor.
      if (!m.read_sealed_body(deadline, m.config.decode || m.config.keep_encoded)) return false;
    } else if (header.type != protocol::MessageType::kFrameSet) {
      throw ClientError(Kind::kProtocol, "expected a FrameSet message");
    }
    const int64_t received_us = wall_clock_us();
    m.describe(m.read_frame_set(sealed), received_us, out);
    const bool decoded = !m.config.decode || m.decode(out);
    out.times.decoded_us = wall_clock_us();
    // Tell the server, whose pacing follows these Acks.
    m.send(protocol::ack_message(out.frames.sequence));
    if (decoded) return true;
    m.send(protocol::message(protocol::MessageType::kKeyFrameRequest, {}));
  }
}

void Client::set_session_handler(SessionHandler handler,
                                 std::function<uint32_t(uint8_t)> max_payload) {
  std::lock_guard lock(impl_->handler_mutex);
  impl_->session_handler = std::move(handler);
  impl_->session_max_payload = std::move(max_payload);
}

void Client::post_session(std::vector<uint8_t> message, uint64_t coalesce_key) {
  Impl& m = *impl_;
  {
    std::lock_guard lock(m.outbox_mutex);
    queue_session_message(m.outbox, coalesce_key, std::move(message),
                          [&] { return send_buffer_full(m.socket.load()); });
  }
  m.outbox_posted = true;
  const uint64_t one = 1;
  [[maybe_unused]] const auto n = ::write(m.wake_fd, &one, sizeof one);
}

bool Client::session_queued(uint64_t coalesce_key) const {
  std::lock_guard lock(impl_->outbox_mutex);
  return std::any_of(impl_->outbox.begin(), impl_->outbox.end(),
                     [&](const auto& m) { return m.first == coalesce_key; });
}

void Client::close() {
  if (impl_->closed.exchange(true)) return;
  if (impl_->connection) impl_->connection->shutdown();
}

}  // namespace volcast
