// Sealed frame sets (protocol 1.2): over TLS a frame set's body is encrypted once per tier, its
// key, tags and digests go inside each viewer's TLS session and the sealed bytes outside it. Real
// data: bodies of the hands sequence encoded as the server does; a relay on loopback records the
// wire.
#include <gtest/gtest.h>
#include <openssl/evp.h>
#include <openssl/sha.h>
#include <poll.h>

#include <algorithm>
#include <functional>
#include <future>
#include <mutex>
#include <thread>

#include "support/hands_site.hpp"
#include "support/raw_viewer.hpp"
#include "support/test_data.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/worker_pool.hpp"
#include "volcast/net/protocol/frame_set.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/net/stream/seal.hpp"
#include "volcast/net/transport/connection.hpp"
#include "volcast/net/transport/tls.hpp"

namespace volcast {
namespace {

using test::error_of;
using test::HandsSite;
using Bytes = std::vector<uint8_t>;

// The volcast-coded depth stream of hands frame set `sequence`: what the server puts in its body.
Bytes hands_depth_stream(uint64_t sequence) {
  Bytes out;
  make_depth_encoder("volcast")->encode(test::hands_source_frame(sequence), true, out);
  return out;
}

// A FrameSet body of real data: the volcast-coded depth of hands frames 1..cameras.
Bytes real_body(int cameras) {
  std::vector<protocol::EncodedCamera> encoded(static_cast<size_t>(cameras));
  for (int i = 0; i < cameras; ++i)
    encoded[static_cast<size_t>(i)].depth = hands_depth_stream(i + 1);
  Bytes body;
  protocol::serialize_frame_set_body(7, true, {}, encoded, body);
  return body;
}

bool contains(const Bytes& haystack, std::span<const uint8_t> needle) {
  return std::search(haystack.begin(), haystack.end(),
                     std::boyer_moore_horspool_searcher(needle.begin(), needle.end())) !=
         haystack.end();
}

TEST(SealedFrameSet, DescriptorRoundTripsAndRefusesBadChunking) {
  protocol::SealedFrameSet m;
  m.send_us = 123456789;
  m.sequence = 42;
  m.key_frame_set = true;
  m.times = {11, 22, 33, 0};
  m.body_bytes = 300000;
  m.chunk_bytes = 128 << 10;
  m.key[3] = 9;
  m.chunks.resize(3);
  m.chunks[2].tag[0] = 1;
  m.chunks[2].digest[31] = 2;
  Bytes rest;
  protocol::serialize_sealed_frame_set_rest(m, rest);
  const auto prefix = protocol::sealed_frame_set_prefix(rest.size(), m.send_us);
  const protocol::Header h = protocol::parse_header(prefix);
  EXPECT_EQ(h.type, protocol::MessageType::kSealedFrameSet);
  Bytes payload(prefix.begin() + protocol::kHeaderBytes, prefix.end());
  payload.insert(payload.end(), rest.begin(), rest.end());
  EXPECT_EQ(h.payload_bytes, payload.size());
  protocol::SealedFrameSet back;
  protocol::parse_sealed_frame_set(payload, back);
  EXPECT_EQ(back.send_us, m.send_us);
  EXPECT_EQ(back.sequence, 42u);
  EXPECT_TRUE(back.key_frame_set);
  EXPECT_EQ(back.times.capture_us, 11);
  EXPECT_EQ(back.times.filter_done_us, 22);
  EXPECT_EQ(back.times.encode_done_us, 33);
  EXPECT_EQ(back.body_bytes, m.body_bytes);
  EXPECT_EQ(back.chunk_bytes, m.chunk_bytes);
  EXPECT_EQ(back.key, m.key);
  ASSERT_EQ(back.chunks.size(), 3u);
  EXPECT_EQ(back.chunks[2].tag, m.chunks[2].tag);
  EXPECT_EQ(back.chunks[2].digest, m.chunks[2].digest);

  const auto refused = [&](const std::function<void(Bytes&)>& edit, const std::string& why) {
    Bytes bad = payload;
    edit(bad);
    protocol::SealedFrameSet out;
    const std::string e = error_of([&] { protocol::parse_sealed_frame_set(bad, out); });
    EXPECT_NE(e.find(why), std::string::npos) << e;
  };
  const auto set_u32 = [](Bytes& b, size_t at, uint32_t v) { std::memcpy(b.data() + at, &v, 4); };
  // Offsets: send time 0, sequence 8, flags 16, times 17..40, body length 41, chunk length 45.
  refused([&](Bytes& b) { b[16] = 2; }, "unknown flags 2");
  refused([&](Bytes& b) { set_u32(b, 45, 100000); }, "not a power of two");
  refused([&](Bytes& b) { set_u32(b, 45, 2048); }, "not a power of two");  // below the minimum
  refused([&](Bytes& b) { set_u32(b, 45, 32u << 20); }, "not a power of two");
  refused([&](Bytes& b) { set_u32(b, 41, 600000); }, "payload of");  // 5 chunks, 3 listed
  refused(
      [&](Bytes& b) {
        set_u32(b, 41, 200u << 20);
        set_u32(b, 45, 4096);
      },
      "chunks, more than");
  refused([&](Bytes& b) { b.pop_back(); }, "payload of");
  refused([&](Bytes& b) { b.push_back(0); }, "payload of");
  refused([&](Bytes& b) { b.resize(10); }, "truncated");
  // The sender refuses a descriptor that does not match its body too.
  m.chunks.resize(2);
  EXPECT_THROW(protocol::serialize_sealed_frame_set_rest(m, rest), Error);
}

TEST(Seal, OpensToTheBodyOfRealFramesWithFreshKeysAndNoPlaintextLeft) {
  const Bytes body = real_body(3);  // ~3 x 60 KB of coded depth
  WorkerPool pool(2);
  for (const uint32_t chunk : {protocol::kMinSealChunkBytes, kSealChunkBytes}) {
    for (WorkerPool* p : {static_cast<WorkerPool*>(nullptr), &pool}) {
      protocol::SealedFrameSet seal;
      Bytes sealed;
      seal_body(body, chunk, seal, sealed, p);
      EXPECT_EQ(seal.body_bytes, body.size());
      EXPECT_EQ(seal.chunks.size(), (body.size() + chunk - 1) / chunk);
      ASSERT_EQ(sealed.size(), body.size());
      // No 32-byte window of the coded depth survives in the sealed bytes.
      const Bytes depth = hands_depth_stream(2);
      for (size_t at = 0; at + 32 <= depth.size(); at += depth.size() / 16)
        EXPECT_FALSE(contains(sealed, std::span(depth).subspan(at, 32))) << "offset " << at;
      Bytes opened = sealed;
      open_sealed(seal, opened, p);
      EXPECT_EQ(opened, body);
    }
  }
  // The same body twice: two keys, two unrelated ciphertexts.
  protocol::SealedFrameSet a, b;
  Bytes sa, sb;
  seal_body(body, kSealChunkBytes, a, sa, nullptr);
  seal_body(body, kSealChunkBytes, b, sb, nullptr);
  EXPECT_NE(a.key, b.key);
  EXPECT_FALSE(contains(sb, std::span(sa).subspan(1000, 32)));
}

TEST(Seal, AnAlteredByteOrTagIsRefusedNamingItsChunk) {
  const Bytes body = real_body(2);
  protocol::SealedFrameSet seal;
  Bytes sealed;
  seal_body(body, 16 << 10, seal, sealed, nullptr);
  ASSERT_GT(seal.chunks.size(), 4u);
  Bytes altered = sealed;
  altered[3 * (16 << 10) + 100] ^= 0x01;  // chunk 4
  std::string e = error_of([&] { open_sealed(seal, altered, nullptr); });
  EXPECT_NE(e.find("chunk 4 of " + std::to_string(seal.chunks.size())), std::string::npos) << e;
  EXPECT_NE(e.find("SHA-256"), std::string::npos) << e;

  protocol::SealedFrameSet wrong_tag = seal;
  wrong_tag.chunks[1].tag[5] ^= 0x80;
  altered = sealed;
  e = error_of([&] { open_sealed(wrong_tag, altered, nullptr); });
  EXPECT_NE(e.find("chunk 2 of"), std::string::npos) << e;
  EXPECT_NE(e.find("tag"), std::string::npos) << e;

  protocol::SealedFrameSet wrong_key = seal;
  wrong_key.key[0] ^= 1;
  altered = sealed;
  e = error_of([&] { open_sealed(wrong_key, altered, nullptr); });
  EXPECT_NE(e.find("tag"), std::string::npos) << e;

  altered.pop_back();
  EXPECT_FALSE(error_of([&] { open_sealed(seal, altered, nullptr); }).empty());
}

TEST(Seal, ChunksOpenOneByOneAsTheyArrive) {
  const Bytes body = real_body(2);
  protocol::SealedFrameSet seal;
  Bytes sealed;
  seal_body(body, 16 << 10, seal, sealed, nullptr);
  ASSERT_GT(seal.chunks.size(), 2u);
  Bytes opened = sealed;
  for (size_t i = 0, at = 0; i < seal.chunks.size(); ++i, at += seal.chunk_bytes)
    open_sealed_chunk(seal, i,
                      std::span(opened).subspan(at, std::min<size_t>(16 << 10, body.size() - at)));
  EXPECT_EQ(opened, body);
  // A chunk's bytes with another chunk's index, a short chunk, an index past the end: refused.
  Bytes first(sealed.begin(), sealed.begin() + (16 << 10));
  EXPECT_NE(error_of([&] { open_sealed_chunk(seal, 1, first); }).find("chunk 2 of"),
            std::string::npos);
  first.pop_back();
  EXPECT_NE(error_of([&] { open_sealed_chunk(seal, 0, first); }).find("do not match"),
            std::string::npos);
  EXPECT_FALSE(error_of([&] { open_sealed_chunk(seal, seal.chunks.size(), first); }).empty());
}

// AES-128-GCM of `plain` under `key` with chunk 0's nonce (protocol.hpp): what anyone holding a
// frame set's key can compute. Returns the ciphertext; `tag` receives its tag.
Bytes gcm_encrypt(const std::array<uint8_t, 16>& key, const Bytes& plain,
                  std::array<uint8_t, 16>& tag) {
  EVP_CIPHER_CTX* ctx = EVP_CIPHER_CTX_new();
  const uint8_t nonce[12] = {};
  Bytes out(plain.size());
  int n = 0, tail = 0;
  EXPECT_EQ(EVP_EncryptInit_ex(ctx, EVP_aes_128_gcm(), nullptr, key.data(), nonce), 1);
  EXPECT_EQ(EVP_EncryptUpdate(ctx, out.data(), &n, plain.data(), static_cast<int>(plain.size())),
            1);
  EXPECT_EQ(EVP_EncryptFinal_ex(ctx, out.data() + n, &tail), 1);
  EXPECT_EQ(EVP_CIPHER_CTX_ctrl(ctx, EVP_CTRL_GCM_GET_TAG, 16, tag.data()), 1);
  EVP_CIPHER_CTX_free(ctx);
  return out;
}

// Another viewer of the tier holds the frame set's key. If it could alter another viewer's stream
// on the way, GCM alone would not stop it: it can encrypt a forged body under that key with a
// valid tag (and, knowing the key, could even keep the original tag: GHASH is linear). The digest,
// sent through the victim's own TLS session, is what stops it.
TEST(Seal, ATierMateHoldingTheKeyCannotForgeABody) {
  const Bytes body = real_body(1);
  protocol::SealedFrameSet seal;
  Bytes sealed;
  seal_body(body, kSealChunkBytes, seal, sealed, nullptr);
  ASSERT_EQ(seal.chunks.size(), 1u);
  // Sanity: the test's own GCM gives the server's ciphertext and tag.
  std::array<uint8_t, 16> tag{};
  EXPECT_EQ(gcm_encrypt(seal.key, body, tag), sealed);
  EXPECT_EQ(tag, seal.chunks[0].tag);

  // The insider's forgery: another depth stream, encrypted under the victim's key.
  Bytes forged_body = body;
  forged_body[body.size() / 2] ^= 0xff;
  std::array<uint8_t, 16> forged_tag{};
  const Bytes forged = gcm_encrypt(seal.key, forged_body, forged_tag);
  // GCM is content with it: with the forger's own tag and digest it opens to the forged body.
  protocol::SealedFrameSet insider = seal;
  insider.chunks[0].tag = forged_tag;
  SHA256(forged.data(), forged.size(), insider.chunks[0].digest.data());
  Bytes opened = forged;
  open_sealed(insider, opened, nullptr);
  EXPECT_EQ(opened, forged_body);
  // The victim's descriptor carries the server's digest: refused by it, whatever the tag says.
  protocol::SealedFrameSet victim = seal;
  victim.chunks[0].tag = forged_tag;
  opened = forged;
  const std::string e = error_of([&] { open_sealed(victim, opened, nullptr); });
  EXPECT_NE(e.find("SHA-256"), std::string::npos) << e;
}

// ---------------------------------------------------------------------------------------------
// On the wire: a relay on loopback between a viewer and the server records what the server sends.

class RecordingRelay {
 public:
  explicit RecordingRelay(uint16_t server_port) : listener_("127.0.0.1", 0) {
    thread_ = std::thread([this, server_port] {
      std::unique_ptr<Connection> viewer = listener_.accept();
      if (!viewer) return;
      std::unique_ptr<Connection> server = connect_tcp("127.0.0.1", server_port, 5000);
      Bytes chunk(64 << 10);
      try {
        while (!stop_) {
          pollfd p[2] = {{viewer->fd(), POLLIN, 0}, {server->fd(), POLLIN, 0}};
          if (::poll(p, 2, 100) <= 0) continue;
          if (p[0].revents) {
            const size_t n = viewer->read_available(chunk);
            if (n) server->write_all(std::span(chunk).first(n), 5000);
          }
          if (p[1].revents) {
            const size_t n = server->read_available(chunk);
            if (!n) continue;
            {
              std::lock_guard lock(mutex_);
              downstream_.insert(downstream_.end(), chunk.begin(), chunk.begin() + n);
            }
            viewer->write_all(std::span(chunk).first(n), 5000);
          }
        }
      } catch (const Error&) {
        // either side closed
      }
    });
  }
  ~RecordingRelay() {
    stop_ = true;
    listener_.close();
    thread_.join();
  }
  uint16_t port() const { return listener_.port(); }
  Bytes downstream() {  // server -> viewer bytes so far
    std::lock_guard lock(mutex_);
    return downstream_;
  }

 private:
  TcpListener listener_;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  Bytes downstream_;
  std::thread thread_;
};

// Receives `n` frame sets through `relay` as a decoding viewer of `server` on the volcast/jpeg
// tier, checking each depth image against its source; returns the sequences received.
std::vector<uint64_t> view_through(const Server& server, const RecordingRelay& relay, int n) {
  ClientConfig c = client_config_from_link(server.join_link("127.0.0.1"));
  c.port = relay.port();
  Client client(c);
  ReceivedFrameSet rx;
  std::vector<uint64_t> got;
  while (static_cast<int>(got.size()) < n && client.receive(rx)) {
    EXPECT_EQ(rx.frames.cameras[0].depth, test::hands_source_frame(rx.frames.sequence));
    got.push_back(rx.frames.sequence);
  }
  return got;
}

// How many of `windows` 256-byte windows spread over `a` (its middle half) occur in `b`.
int shared_windows(const Bytes& a, const Bytes& b, int windows) {
  int found = 0;
  for (int i = 0; i < windows; ++i) {
    const size_t at = a.size() / 4 + (a.size() / 2) * static_cast<size_t>(i) / windows;
    found += contains(b, std::span(a).subspan(at, 256));
  }
  return found;
}

TEST(SealedStream, TheWireCarriesNoPlaintextAndViewersOfATierShareTheSealedBytes) {
  ServerConfig config;
  config.seal_from_viewers = 2;
  HandsSite site(15, config);
  RecordingRelay a(site.server.port()), b(site.server.port());
  auto fa = std::async(std::launch::async, [&] { return view_through(site.server, a, 20); });
  auto fb = std::async(std::launch::async, [&] { return view_through(site.server, b, 20); });
  const std::vector<uint64_t> seen = fa.get();
  ASSERT_EQ(seen.size(), 20u);
  ASSERT_EQ(fb.get().size(), 20u);
  const Bytes wire_a = a.downstream(), wire_b = b.downstream();
  ASSERT_GT(wire_a.size(), 20u * 30000);
  // No 48-byte window of any received frame's coded depth is on the wire.
  for (uint64_t sequence : {seen.front(), seen[10], seen.back()}) {
    const Bytes depth = hands_depth_stream(sequence);
    for (size_t at = 0; at + 48 <= depth.size(); at += depth.size() / 8)
      EXPECT_FALSE(contains(wire_a, std::span(depth).subspan(at, 48)))
          << "frame set " << sequence << ", offset " << at;
  }
  // Most of each stream is sealed bodies, the same bytes for both viewers (per-viewer encryption,
  // as TLS alone does, would share none).
  EXPECT_GE(shared_windows(wire_a, wire_b, 32), 16);
  const auto tiers = site.server.tiers();
  ASSERT_EQ(tiers.size(), 1u);
}

// Sealing costs about what TLS's own encryption costs 2.5 viewers: a tier seals only from
// seal_from_viewers viewers (3 by default) and goes back to TLS alone when they leave.
TEST(SealedStream, ATierSealsFromThreeViewersAndUsesTlsAloneBelow) {
  HandsSite site(15);
  test::RawViewer first(site.server);
  const auto next_type = [&] {
    first.next_frame_set();
    return first.type;
  };
  for (int i = 0; i < 5; ++i) EXPECT_EQ(next_type(), protocol::MessageType::kFrameSet);
  const auto type_within = [&](protocol::MessageType want) {
    for (int i = 0; i < 150; ++i)
      if (next_type() == want) return true;
    return false;
  };
  {
    std::atomic<bool> stop{false};
    std::vector<std::thread> others;
    for (int i = 0; i < 2; ++i)
      others.emplace_back([&] {
        Client client(client_config_from_link(site.server.join_link("127.0.0.1")));
        ReceivedFrameSet rx;
        while (!stop && client.receive(rx)) {
        }
      });
    EXPECT_TRUE(type_within(protocol::MessageType::kSealedFrameSet)) << "three viewers: sealed";
    stop = true;
    for (auto& t : others) t.join();
  }
  EXPECT_TRUE(type_within(protocol::MessageType::kFrameSet)) << "alone again: TLS alone";
}

// A receive-only viewer (a load generator) reads a sealed body but does not open it: it
// acknowledges from the descriptor, and the server's pacing, which follows Acks, keeps sending.
TEST(SealedStream, AReceiveOnlyViewerAcknowledgesSealedFrameSetsFromTheDescriptor) {
  ServerConfig config;
  config.seal_from_viewers = 1;
  HandsSite site(15, config);
  test::RawViewer raw(site.server);  // a second viewer: sees which message the tier sends
  raw.next_frame_set();
  EXPECT_EQ(raw.type, protocol::MessageType::kSealedFrameSet);
  ClientConfig c = client_config_from_link(site.server.join_link("127.0.0.1"));
  c.decode = false;
  Client client(c);
  ReceivedFrameSet rx;
  uint64_t last = 0;
  int got = 0, keys = 0;
  for (; got < 40 && client.receive(rx); ++got) {  // far more than the server keeps in flight
    if (got > 0) {
      EXPECT_GT(rx.frames.sequence, last);
    }
    last = rx.frames.sequence;
    keys += rx.key;
    EXPECT_GT(rx.times.capture_us, 0);
    EXPECT_LE(rx.times.capture_us, rx.times.encode_done_us);
    EXPECT_GT(rx.message_bytes, 20000u);  // descriptor and sealed body
    ASSERT_EQ(rx.depth_bytes.size(), 1u);
    EXPECT_EQ(rx.depth_bytes[0], 0u);  // in the unopened body
    if (got % 8 == 0) raw.next_frame_set();
  }
  EXPECT_EQ(got, 40);
  EXPECT_GE(keys, 1);  // the first frame set of a new viewer is a key frame set
}

// The same check's positive control: on plain TCP (--insecure, loopback) the coded depth is there
// to be found, so the test above would see it if the server sent it in the clear.
TEST(SealedStream, OnPlainTcpTheSameCheckFindsThePlaintext) {
  ServerConfig config;
  config.insecure = true;
  HandsSite site(15, config);
  RecordingRelay a(site.server.port());
  const std::vector<uint64_t> seen = view_through(site.server, a, 5);
  ASSERT_EQ(seen.size(), 5u);
  const Bytes depth = hands_depth_stream(seen.back());
  EXPECT_TRUE(contains(a.downstream(), std::span(depth).subspan(depth.size() / 2, 48)));
}

// ---------------------------------------------------------------------------------------------
// A hostile server speaking TLS: it sends a Welcome, then one hand-made sealed frame set.

using Script = std::function<void(Connection&)>;

// Runs `script` as the server of one viewer over TLS (or plain TCP when `tls` is false) and
// returns how the viewer's receive() ended.
std::string viewer_error(const Script& script, bool tls = true) {
  TcpListener listener("127.0.0.1", 0);
  const auto context = TlsContext::server(make_self_signed_identity("hostile"));
  std::atomic<bool> done{false};
  std::thread server([&] {
    AcceptedSocket s;
    while (!done && (s = listener.accept_nonblocking()).fd < 0) {
      pollfd p{listener.fd(), POLLIN, 0};
      ::poll(&p, 1, 100);
    }
    if (s.fd < 0) return;
    std::unique_ptr<Connection> c =
        tls ? accept_tls(s.fd, s.peer, context) : make_tcp_connection(s.fd, s.peer);
    try {
      while (const int want = c->handshake_step()) {
        pollfd p{c->fd(), static_cast<short>(want), 0};
        ::poll(&p, 1, 100);
      }
      uint8_t header[protocol::kHeaderBytes];
      c->read_exact(header, 5000);
      Bytes hello(protocol::parse_header(header).payload_bytes);
      c->read_exact(hello, 5000);
      protocol::CameraInfo cam;
      cam.calibration.depth.width = 640;
      cam.calibration.depth.height = 360;
      cam.calibration.depth.fx = cam.calibration.depth.fy = 460;
      c->write_all(protocol::message(protocol::MessageType::kWelcome,
                                     protocol::serialize(protocol::Welcome{{cam}, 0})),
                   5000);
      script(*c);
      while (!done) std::this_thread::sleep_for(std::chrono::milliseconds(20));
    } catch (const Error&) {
      // the viewer hung up
    }
  });
  std::string why;
  try {
    ClientConfig config;
    config.port = listener.port();
    config.fingerprint = context->fingerprint();
    config.insecure = !tls;
    config.receive_timeout_ms = 3000;
    Client client(config);
    ReceivedFrameSet rx;
    why = client.receive(rx) ? "received a frame set" : "closed";
  } catch (const ClientError& e) {
    why =
        std::string(e.kind() == ClientError::Kind::kProtocol ? "protocol: " : "other: ") + e.what();
  }
  done = true;
  server.join();
  return why;
}

// Sends a frame set of real hands depth sealed as the server does, after `edit` changed it.
Script sealed_frame_set(
    const std::function<void(protocol::SealedFrameSet&, Bytes& sealed)>& edit = {},
    bool body_inside_tls = false, size_t extra_bytes_in_record = 0,
    uint32_t chunk_bytes = kSealChunkBytes) {
  return [=](Connection& c) {
    std::vector<protocol::EncodedCamera> cams(1);
    cams[0].depth = hands_depth_stream(1);
    Bytes body, sealed, rest;
    protocol::serialize_frame_set_body(1, true, {}, cams, body);
    protocol::SealedFrameSet seal;
    seal_body(body, chunk_bytes, seal, sealed, nullptr);
    seal.sequence = 1;  // the body's copied head, as the server fills it
    seal.key_frame_set = true;
    if (edit) edit(seal, sealed);
    protocol::serialize_sealed_frame_set_rest(seal, rest);
    const auto prefix = protocol::sealed_frame_set_prefix(rest.size(), 0);
    Bytes message(prefix.begin(), prefix.end());
    message.insert(message.end(), rest.begin(), rest.end());
    message.insert(message.end(), extra_bytes_in_record, 0);
    const std::span<const uint8_t> parts[1] = {message};
    if (body_inside_tls) {
      c.write_all(message, 5000);
      c.write_all(sealed, 5000);
    } else {
      c.write_with_raw(parts, sealed, 5000);
    }
  };
}

TEST(SealedStream, ServerRefusesSealingFromZeroViewers) {
  ServerConfig config;
  config.seal_from_viewers = 0;
  EXPECT_NE(error_of([&] { HandsSite site(15, config); }).find("seal_from_viewers"),
            std::string::npos);
}

TEST(HostileSealedServer, AWellFormedSealedFrameSetIsReceived) {
  EXPECT_EQ(viewer_error(sealed_frame_set()), "received a frame set");
}

TEST(HostileSealedServer, ABodyAboveTheSitesBoundIsRefusedBeforeItIsRead) {
  const std::string e = viewer_error([](Connection& c) {
    protocol::SealedFrameSet seal;
    seal.body_bytes = 200u << 20;  // 200 MiB for one 640x360 camera, then silence
    seal.chunk_bytes = 16u << 20;
    seal.chunks.resize(13);
    Bytes rest;
    protocol::serialize_sealed_frame_set_rest(seal, rest);
    const auto prefix = protocol::sealed_frame_set_prefix(rest.size(), 0);
    const std::span<const uint8_t> parts[2] = {prefix, rest};
    c.write_all(parts, 5000);
  });
  EXPECT_NE(e.find("protocol: sealed frame set of 209715200 bytes exceeds the limit"),
            std::string::npos)
      << e;
}

TEST(HostileSealedServer, AlteredSealedBytesAreRefused) {
  const std::string e =
      viewer_error(sealed_frame_set([](auto&, Bytes& sealed) { sealed[10] ^= 4; }));
  EXPECT_NE(e.find("protocol: sealed frame set: chunk 1 of 1 does not match its SHA-256"),
            std::string::npos)
      << e;
}

// The descriptor's copy of the head must match the body: a receive-only viewer acknowledges
// from the copy, so a server must not tell the two kinds of viewer different things.
TEST(HostileSealedServer, ADescriptorWhoseHeadDiffersFromTheBodyIsRefused) {
  const std::string e =
      viewer_error(sealed_frame_set([](auto& seal, Bytes&) { seal.sequence = 2; }));
  EXPECT_NE(e.find("protocol: sealed frame set: the descriptor's copy of sequence, flags and "
                   "times differs from the opened body's"),
            std::string::npos)
      << e;
}

TEST(HostileSealedServer, AnAlteredLaterChunkIsRefusedNamingIt) {
  const std::string e = viewer_error(
      sealed_frame_set([](auto&, Bytes& sealed) { sealed[2 * 4096 + 7] ^= 0x20; }, false, 0, 4096));
  EXPECT_NE(e.find("protocol: sealed frame set: chunk 3 of "), std::string::npos) << e;
  EXPECT_NE(e.find("does not match its SHA-256"), std::string::npos) << e;
}

TEST(HostileSealedServer, ABodySentInsideTlsInsteadOfAfterItIsRefused) {
  const std::string e = viewer_error(sealed_frame_set({}, true));
  EXPECT_NE(e.find("protocol: sealed frame set: chunk 1 of 1"), std::string::npos) << e;
}

TEST(HostileSealedServer, ATlsRecordStraddlingTheSealedBytesIsRefused) {
  const std::string e = viewer_error(sealed_frame_set({}, false, 16));
  EXPECT_NE(e.find("TLS bytes are buffered where raw bytes should begin"), std::string::npos) << e;
}

TEST(HostileSealedServer, ASealedFrameSetOverPlainTcpIsRefused) {
  const std::string e = viewer_error(sealed_frame_set(), false);
  EXPECT_NE(e.find("protocol: a sealed frame set arrived over a connection without TLS"),
            std::string::npos)
      << e;
}

}  // namespace
}  // namespace volcast
