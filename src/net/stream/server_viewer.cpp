// Each viewer's thread of the Server: its Welcome, then its tier's frame sets paced by its Acks,
// with its session messages (server_impl.hpp).
#include <spdlog/spdlog.h>
#include <time.h>

#include <algorithm>

#include "server_impl.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

// CPU time of the calling thread, milliseconds.
double thread_cpu_ms() {
  timespec t{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) / 1e6;
}

}  // namespace

void Server::Impl::update(Viewer& v, const std::function<void(ViewerReport&)>& f) {
  std::lock_guard lock(mutex);
  f(v.report);
}

void Server::Impl::serve_viewer(Viewer& v) {
  Connection& c = *v.connection;
  try {
    protocol::Welcome welcome{cameras, wall_clock_us()};
    c.write_all(protocol::message(protocol::MessageType::kWelcome, protocol::serialize(welcome)),
                config.stall_timeout_ms);
    spdlog::info("viewer {} connected (tier {}{})", v.report.peer, to_string(v.tier->encoder.key()),
                 adaptive(v) ? ", adaptive" : "");
    if (adaptive(v))  // its first tier, and why (its Hello named the best it wants, if a rung)
      send_tier_change(v,
                       v.floor.decodes.empty()
                           ? "starting on the best tier of this server's ladder that your floor "
                             "and cap allow"
                           : "starting on the best tier of this server's ladder that your floor, "
                             "cap and decoders allow",
                       0);
    stream(v);
  } catch (const std::exception& e) {
    if (!stopping) spdlog::info("viewer {} ended: {}", v.report.peer, e.what());
    update(v, [&](ViewerReport& r) { r.error = e.what(); });
  }
  unsubscribe(*v.tier, v.wake);
  c.shutdown();
  std::string why;
  update(v, [&](ViewerReport& r) {
    r.connected = false;
    why = r.error.empty() ? "server stopping" : r.error;
    v.outbox.clear();
  });
  if (config.session) {
    try {
      config.session->on_viewer_left(v.id, why);
    } catch (const std::exception& e) {
      spdlog::error("session: viewer {} left: {}", v.id, e.what());
    }
  }
  v.done = true;
}

// Writes the session messages queued for `v` (in order); throws Error if it was kicked. Small
// messages are copied one after another into `joined` and written together: one TLS record (per
// 16 KiB) and one send(2) for a burst of voice packets instead of one each; over WebSocket, one
// WebSocket message (the page reads them as one byte stream, web/page/worker.js). A large message
// is not copied: it goes out in the same write as the small ones before it.
//
// Queued stream messages alone (voice packets) wait until each talker heard lately has one queued,
// or the oldest is stream_coalesce_us old, so that talkers' packets reaching the server a few ms
// apart go out together: one wake-up of this thread and one write for several packets. Any other
// message sends them at once.
int64_t Server::Impl::flush_session(Viewer& v,
                                    std::vector<std::shared_ptr<const std::vector<uint8_t>>>& batch,
                                    std::vector<uint8_t>& joined) {
  {
    std::lock_guard lock(mutex);
    if (!v.kicked.empty()) throw Error(v.kicked);
    const auto taken = v.outbox.take(steady_us(), config.stream_coalesce_us, batch);
    if (batch.empty()) return taken.due_us;
    ++v.report.session_flushes;
    if (taken.disarm) v.wake.at(-1);
  }
  constexpr size_t kCopiedBelow = 16 << 10;  // bytes: a message this long or longer is not copied
  constexpr size_t kJoinedBytes = 64 << 10;  // at most this much is joined into one write
  // `joined` keeps its capacity between calls: no allocation once warm.
  joined.clear();
  for (const auto& m : batch) {
    if (m->size() >= kCopiedBelow) {
      std::span<const uint8_t> parts[2];
      size_t n = 0;
      if (!joined.empty()) parts[n++] = joined;
      parts[n++] = *m;
      v.connection->write_all(std::span(parts, n), config.stall_timeout_ms);
      joined.clear();
      continue;
    }
    if (joined.size() + m->size() > kJoinedBytes) {
      v.connection->write_all(joined, config.stall_timeout_ms);
      joined.clear();
    }
    joined.insert(joined.end(), m->begin(), m->end());
  }
  if (!joined.empty()) v.connection->write_all(joined, config.stall_timeout_ms);
  return -1;
}

// Reads one message from the viewer: an Ack, a KeyFrameRequest, or a session message (for the
// session service, else skipped). Anything else ends the connection.
void Server::Impl::read_control(Viewer& v, Pacer& pacer, RateController& rc,
                                std::vector<uint8_t>& payload) {
  Connection& c = *v.connection;
  uint8_t header_bytes[protocol::kHeaderBytes];
  c.read_exact(header_bytes, config.handshake_timeout_ms);
  const protocol::Header h = protocol::parse_header(header_bytes);
  const uint8_t session_type = static_cast<uint8_t>(static_cast<uint16_t>(h.type) & 0xff);
  const bool session = h.channel == protocol::Channel::kSession;
  const uint32_t limit = session && config.session ? config.session->max_payload(session_type)
                                                   : protocol::kMaxControlBytes;
  if (limit == 0)
    throw Error("viewer sent an unknown session message type " + std::to_string(session_type));
  if (h.payload_bytes > limit)
    throw Error("viewer sent a message of " + std::to_string(h.payload_bytes) +
                " bytes, over the limit of " + std::to_string(limit));
  payload.resize(h.payload_bytes);
  c.read_exact(payload, config.handshake_timeout_ms);
  if (session && config.session) {
    config.session->on_message(v.id, session_type, payload);
    return;
  }
  if (h.type == protocol::MessageType::kAck) {
    const int64_t now = steady_us();
    if (!pacer.on_ack(protocol::parse_ack(payload), now))
      throw Error("viewer acknowledged a frame set it was not sent");
    rc.on_ack(now, pacer.last_acked_bytes(), pacer.last_rtt_us(),
              static_cast<int64_t>(pacer.min_rtt_us()));
  } else if (h.type == protocol::MessageType::kKeyFrameRequest) {
    std::lock_guard lock(mutex);
    v.tier->key_wanted = true;
    ++v.report.key_requests;
  } else if (h.channel != protocol::Channel::kSession) {
    throw Error("viewer sent an unexpected message");
  }
}

void Server::Impl::stream(Viewer& v) {
  Connection& c = *v.connection;
  Pacer pacer(config.max_window);
  // Rate control: on the ladder for an adaptive viewer, else on its one tier (for notices).
  const bool adapt = adaptive(v);
  const bool notify = adapt || (v.floor.adapt & protocol::Hello::kNotify);
  RateController rc(adapt ? ladder.rungs.size() : 1, adapt ? size_t(std::max(0, rung_of(v))) : 0,
                    config.rate_control);
  std::vector<double> rung_bits(adapt ? ladder.rungs.size() : 1);
  std::vector<char> allowed;
  RateDecision decision;
  std::vector<uint8_t> payload;
  uint64_t last_sequence = 0;       // the site sequence last sent (or skipped)
  uint64_t last_index = 0;          // the tier index last sent; a delta needs index == last + 1
  uint64_t last_blocked = 0;        // the newest frame set the pacer held back
  uint64_t blocked_since_send = 0;  // held back since the last send (told to the rate control)
  bool synced = false;
  auto last_progress = std::chrono::steady_clock::now();
  const double cpu_start_ms = thread_cpu_ms();
  std::vector<std::shared_ptr<const std::vector<uint8_t>>> batch;
  std::vector<uint8_t> joined;  // flush_session's buffer, kept between calls
  int64_t session_due = -1;     // steady_us() when the waiting voice packets go out; -1: none wait
  while (!stopping) {
    int timeout_ms = 100;
    if (session_due >= 0)  // rounded up: poll(2) waits whole ms
      timeout_ms = int(std::clamp<int64_t>((session_due - steady_us() + 999) / 1000, 0, 100));
    const Connection::Ready ready = c.wait(v.wake.fd, timeout_ms);
    if (ready.woken) v.wake.drain();
    if (ready.readable) {
      read_control(v, pacer, rc, payload);
      last_progress = std::chrono::steady_clock::now();
    }
    if (notify) {
      const int64_t now = steady_us();
      {
        std::lock_guard lock(mutex);
        if (adapt) {
          ladder_bits(rung_bits);
          detail::allowed_rungs(ladder, v.floor, rung_bits, now, allowed);  // caps: measured only
          // A rung that has not run yet: a measured one's rate scaled by their sizes.
          detail::estimate_unmeasured(ladder, rc.rung(), rung_bits);
        } else {
          rung_bits[0] = tier_bits(v.tier->encoder.key());
          allowed.assign(1, 1);
        }
        v.report.goodput_mbit_s = rc.goodput_bits(now) / 1e6;
        v.report.queue_ms = rc.queue_ms();
      }
      if (rc.decide(now, rung_bits, allowed, decision)) {
        const double goodput = rc.goodput_bits(now);
        if (decision.notice) {
          switch_tier(v, decision, goodput);
        } else if (switch_tier(v, decision, goodput)) {
          rc.switched(decision.rung, steady_us(), decision.up);
          synced = false;  // the new tier's next key frame set comes first
          last_sequence = 0;
        }
      }
    }
    Producer& tier = *v.tier;
    session_due = flush_session(v, batch, joined);  // session messages go ahead of frame sets
    if (!batch.empty())
      update(v, [&](ViewerReport& r) { r.send_cpu_ms = thread_cpu_ms() - cpu_start_ms; });
    if (pacer.frames_in_flight() > 0 && std::chrono::steady_clock::now() - last_progress >
                                            std::chrono::milliseconds(config.stall_timeout_ms))
      throw Error("viewer stalled: acknowledged nothing for " +
                  std::to_string(config.stall_timeout_ms) + " ms");
    std::shared_ptr<const detail::EncodedFrames> frames;
    {
      std::lock_guard lock(mutex);
      frames = tier.latest;
    }
    if (!frames || frames->sequence <= last_sequence) continue;
    if (!pacer.can_send(frames->body.size() + protocol::kFrameSetPrefixBytes)) {
      // Held back by the path: a sign of congestion for the rate control, counted as it happens
      // (a path that acknowledges nothing would otherwise show none).
      if (synced && frames->sequence != last_blocked) {
        last_blocked = frames->sequence;
        ++blocked_since_send;
        rc.on_skip(steady_us());
      }
      continue;
    }
    const int64_t now_wall = wall_clock_us();
    const bool decodable = frames->key || (synced && frames->index == last_index + 1);
    // Older than the budget: skipped for the next, fresher one -- unless the site finished
    // encoding it only past the budget (an overloaded machine): the next would be as old, and
    // skipping them all would leave the viewer with no picture at all.
    const int64_t budget_us = int64_t{config.latency_budget_ms} * 1000;
    const bool stale = now_wall - frames->capture_us > budget_us &&
                       frames->encode_done_us - frames->capture_us <= budget_us;
    if (!decodable || stale) {
      // Skip it: too old, or a delta whose reference this viewer lacks (it waits for a key). Too
      // old is the path's sign only when the path held frame sets back since the last send;
      // otherwise it aged waiting for this thread (a loaded server), which no rung cures.
      if (stale ? blocked_since_send > 0 : synced) rc.on_skip(steady_us());
      std::lock_guard lock(mutex);
      ++v.report.frames_dropped;
      v.report.frames_stale += stale;
      if (!decodable) tier.key_wanted = true;
      synced = false;
      last_sequence = frames->sequence;
      continue;
    }
    // The round trip counts from the write's start: a clock read after it returned is late by
    // however long this thread then waited for a core, and a round trip shorter than the path's
    // (a loaded run measured 96.7 ms on a 100 ms path) would shrink the window below it.
    const int64_t send_us = steady_us();
    size_t bytes = 0;
    if (c.encrypted() && c.carries_raw() && !frames->sealed.empty()) {
      // Key, tags and digests inside this viewer's TLS session; the sealed body after them,
      // outside TLS: the same bytes for every viewer of the tier (protocol.hpp, 1.2).
      const auto prefix = protocol::sealed_frame_set_prefix(frames->seal_rest.size(), now_wall);
      const std::span<const uint8_t> parts[2] = {prefix, frames->seal_rest};
      c.write_with_raw(parts, frames->sealed, config.stall_timeout_ms);
      bytes = prefix.size() + frames->seal_rest.size() + frames->sealed.size();
    } else {
      const auto prefix = protocol::frame_set_prefix(frames->body.size(), now_wall);
      const std::span<const uint8_t> parts[2] = {prefix, frames->body};
      c.write_all(parts, config.stall_timeout_ms);
      bytes = prefix.size() + frames->body.size();
    }
    if (pacer.frames_in_flight() == 0) last_progress = std::chrono::steady_clock::now();
    rc.on_send(send_us, pacer.frames_in_flight() == 0);
    pacer.on_send(frames->sequence, bytes, send_us);
    std::lock_guard lock(mutex);
    const uint64_t step = uint64_t(tier.encoder.key().frame_divisor);  // the tier's own spacing
    if (last_sequence > 0 && frames->sequence > last_sequence + step) {
      const uint64_t missed = (frames->sequence - last_sequence) / step - 1;
      v.report.frames_dropped += missed;
      // Missed while the path held them back: the path's sign. Missed while nothing held them
      // back (the pacer never blocked since the last send): this thread ran late, as on a loaded
      // server -- not the path's, or every viewer of a busy server would step down together.
      if (blocked_since_send > 0 && missed > blocked_since_send)
        rc.on_skip(steady_us(), missed - blocked_since_send);
    }
    blocked_since_send = 0;
    last_sequence = frames->sequence;
    last_index = frames->index;
    synced = true;
    ++v.report.frames_sent;
    v.report.bytes_sent += bytes;
    v.report.min_rtt_ms = pacer.min_rtt_us() / 1000;
    v.report.bottleneck_mbit_s = pacer.bottleneck_bytes_per_us() * 8;
    v.report.window = pacer.window_frames();
    v.report.send_cpu_ms = thread_cpu_ms() - cpu_start_ms;
  }
}

}  // namespace volcast
