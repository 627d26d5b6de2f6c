#pragma once
// The streaming server: accepts viewers, encodes each frame set once per tier and hands the same
// bytes to every viewer of that tier, paced per viewer to what its path carries.
//
// Tiers. A tier is (depth codec, color codec, color quality). Each tier with at least one viewer
// has one encoder per camera and a thread that encodes the newest published frame set (the
// cameras in parallel on a shared worker pool) into one immutable FrameSet body. Every viewer of
// the tier is sent those bytes (a gather write of a 20-byte per-viewer prefix and the shared body),
// so 16 viewers cost about what one costs. A tier that falls behind skips frame sets. A new tier
// must fit the server's CPU budget for encoding (ServerConfig::tier_cpu_budget), and the tiers
// one address holds alone its share (max_tiers_per_address, half the budget).
//
// Key frames. Temporal codecs (trvl, volcast-t, h264, hevc) code deltas against the tier's last
// frame set, so a viewer can only be sent a delta if it was sent the tier's previous frame set. A
// viewer that joins, skips frame sets (pacing, latency budget) or asks for one (KeyFrameRequest)
// waits for the tier's next key frame set; the tier makes one on request at most every
// `min_key_interval_ms`, and every `key_frame_interval` frame sets anyway.
//
// Security (door.hpp): TLS 1.3 by default with the server's certificate (a new self-signed one
// for this Server if the config gives none); `insecure` (plain TCP) only on a loopback address.
// Every viewer must send the session's join token in its Hello; one thread runs all pending
// handshakes (no thread per unauthenticated peer), with a handshake timeout, limits on pending
// handshakes in total and per address, and a back-off for wrong tokens (a right one always gets
// in). Only then does a viewer get a thread, a tier, and count against `max_viewers`.
//
// Rate adaptation (rate_control.hpp). A viewer whose Hello asks for it (protocol.hpp kAdapt) is
// moved along the server's tier ladder (ServerConfig::ladder: the best first; each rung a tier
// encoded once for all its viewers) as its path allows: it starts on the best rung its floors and
// cap allow (its Hello's tier, if a rung, is the best it gets), steps down within about a
// quarter of a second of congestion being measured and probes back up after a hold, each switch
// a TierChange (protocol.hpp 0.6) and then a key frame set of the new tier. Floors are the
// viewer's: kKeepLossless (never lossy depth), kKeepFullRate; a viewer that asked for one, or
// pinned its tier (no kAdapt), is never moved past it: with kNotify it is told instead, when its
// path cannot carry its tier. A rung must fit the tiers' total CPU budget (a tier nobody watches
// any more not counted), not the per-address share: the ladder is the operator's list and an
// adaptive viewer holds one of its tiers at a time, so no viewer makes the server encode a tier
// its policy does not list. A rung the budget refuses is left out for 10 s.
//
// Pacing (per viewer, from Ack timing, after BBR: Cardwell et al., ACM Queue 2016): the server
// estimates the path's round-trip time (windowed minimum of send -> Ack) and bottleneck rate
// (windowed maximum of the delivery rate), and keeps about two bandwidth-delay products of bytes in
// flight (at least one frame set, at most `max_window`). It always sends the newest frame set and
// never one captured more than `latency_budget_ms` ago, so a slow viewer or path skips whole frame
// sets instead of building latency, and never slows the publisher or another viewer. The one
// exception: a frame set the site finished encoding only past the budget (a machine too loaded
// to meet it) is sent while it is the newest -- the next would be as old, and skipping every one
// would leave the viewer with no picture.
#include <cstdint>
#include <filesystem>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "volcast/codec/tier.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/net/protocol/join.hpp"
#include "volcast/net/protocol/protocol.hpp"
#include "volcast/net/stream/rate_control.hpp"
#include "volcast/net/stream/session_port.hpp"
#include "volcast/net/transport/tls.hpp"

namespace volcast {

/// The default tier ladder, lightest last: lossless depth with JPEG q70 color (3,488 KiB/s per
/// Azure Kinect at 30 fps, under the seed paper's 3,555), near-lossless depth (within 2 mm) with
/// JPEG q50, lossless depth with JPEG q50 at every second frame set (the step a viewer that keeps
/// depth lossless has), H.264 depth and color, then that at every second frame set.
std::vector<std::string> default_ladder();
/// The default ladder's sizes relative to its top (measured per Azure Kinect frame): what the rate
/// control assumes of a rung before it has run.
std::vector<double> default_ladder_sizes();

struct ServerConfig {
  std::string bind_address =
      "127.0.0.1";                ///< an address or host name; "0.0.0.0" for remote viewers
  uint16_t port = 7300;           ///< 0 picks a free port (see Server::port)
  int key_frame_interval = 60;    ///< frame sets between key frames of temporal tiers
  int min_key_interval_ms = 250;  ///< a tier makes requested key frames at most this often
  int max_window = 8;             ///< frame sets in flight (sent, not acknowledged) at most
  int latency_budget_ms = 150;    ///< a frame set captured longer ago is skipped (see the top)
  int max_viewers = 16;           ///< further viewers are rejected ("server full")
  int max_tiers = 8;  ///< distinct tiers at once; a viewer asking for another is rejected
  /// CPU the tiers' encoders may use together (cores: 1.0 is one core kept busy). A tier's cost
  /// is its codecs' encode_ns_per_pixel (codec/registry.hpp) times the site's pixels times the
  /// site's frame rate (publish()'s mean rate, its highest in 30 s; 30 fps before its first
  /// second), so HEVC costs about 30 times volcast/jpeg. A viewer asking for a tier that does not
  /// run yet is rejected if its cost would take the tiers' total past this, with both figures in
  /// the reject; tiers that run already, and viewers joining them, are never refused. Taps
  /// (add_tier_tap) are counted but not refused. 0: half this machine's cores, at least 1.
  double tier_cpu_budget = 0;
  /// The tier whose frame sets the publisher hands over encoded (CapturedFrameSet::encoded: a
  /// relay's upstream tier, "DEPTH/COLOR[/QUALITY]"): it passes their bytes through without
  /// encoding, so the CPU budget counts it as free, also before the first frame set has come.
  /// Empty: none. Throws Error (in Server's constructor) if it does not parse (parse_tier).
  std::string passed_through_tier;
  /// Tiers that the viewers of one address (IP) may hold alone, i.e. that no other address and
  /// no tap watches; together those may also cost at most half of tier_cpu_budget. A viewer
  /// that would go past either is rejected, naming the limit.
  int max_tiers_per_address = 4;
  int encode_threads = 0;           ///< worker threads for encoding (0 = cores - 1)
  int handshake_timeout_ms = 5000;  ///< a viewer must finish TLS and send Hello within this time
  int stall_timeout_ms = 10000;     ///< a viewer that accepts or acknowledges nothing this long is
                                    ///< disconnected
  /// The session service, or null: session messages are then read and skipped (at most
  /// protocol::kMaxControlBytes each). Must outlive the Server.
  SessionPort* session = nullptr;
  int max_pending = 64;             ///< handshakes at once (the oldest is dropped for a newcomer)
  int max_pending_per_address = 8;  ///< handshakes at once from one address (more are closed)
  /// Tiers offered, each "DEPTH/COLOR" or "DEPTH/COLOR/QUALITY" (e.g. "volcast/jpeg/90"); a viewer
  /// asking for another is rejected with the list. Empty: any codecs this build has.
  std::vector<std::string> offered_tiers;
  /// The tier ladder for adaptive viewers, best first, each "DEPTH/COLOR[/QUALITY][@N]" (@N: every
  /// Nth frame set; see the top). Empty: no adaptation (adaptive viewers are served as pinned).
  /// With offered_tiers, only its offered rungs are kept. The default (default_ladder()) keeps
  /// depth lossless on its top two rungs; its H.264 rungs are left out where the video codecs are
  /// not registered (codec_video's register_video_codecs). Another ladder's codecs must all exist.
  std::vector<std::string> ladder = default_ladder();
  /// Each rung's expected size relative to the others (any unit; empty, or another length than
  /// `ladder`: unknown). A rung not running is judged by a running one's rate times the ratio of
  /// their sizes, until it has run (then by what it produced).
  std::vector<double> ladder_sizes = default_ladder_sizes();
  RateControlConfig rate_control;  ///< the adaptation's thresholds and holds
  bool insecure = false;  ///< plain TCP instead of TLS; refused unless bind_address is loopback
  /// Over TLS, a tier with at least this many viewers seals each frame set once for all of them
  /// (protocol.hpp, SealedFrameSet); with fewer, each viewer's TLS encrypts it (FrameSet), which
  /// costs less then: sealing (AES-GCM + SHA-256 once) takes about as long as AES-GCM for 2.5
  /// viewers, and adds its time to the tier's latency. 1: always seal.
  int seal_from_viewers = 3;
  /// A viewer's queued session messages that are all of queued streams (kQueuedStreamKey: voice
  /// packets) wait until every stream that sent in the last 30 ms has one queued (each talker's
  /// packet of this 20 ms frame), until the oldest of them has waited this long (µs), or until
  /// another kind of message is queued, and then go out in one write: talkers' packets reaching
  /// the server a few ms apart cost one wake-up and one TLS write per listener together instead
  /// of one each. One talker's packets never wait; with several, a packet waits for those of
  /// the others' that come after it in the same frame, at most this long. 0: every message goes
  /// out at once.
  int64_t stream_coalesce_us = 20'000;
  TlsIdentity identity;  ///< certificate and key; empty: a new self-signed one for this server
  std::optional<JoinToken> token;  ///< the session's join token; empty: a random one
  /// The browser viewer's page (index.html, its scripts and the WebAssembly decoder, as the build
  /// puts them in build/PRESET/web), served on the same port: a peer that speaks HTTP after TLS
  /// gets the page, and a WebSocket on /stream carries this protocol unchanged (web_link()).
  /// Empty: Volcast peers only. Throws Error at start if it holds no index.html.
  std::filesystem::path web_root;
};

/// Wrong join tokens an address may send before it is backed off: its further wrong tokens are
/// refused for 1 s, doubling up to 60 s. A right token is always accepted.
inline constexpr int kFreeWrongTokens = 3;

/// What came to the server's door (counts since start).
struct DoorReport {
  uint64_t admitted = 0;  ///< viewers with the right token (then served, or rejected: full, tier)
  uint64_t wrong_token = 0;  ///< refused for a wrong join token
  uint64_t backed_off = 0;   ///< wrong tokens refused during their address's back-off
  uint64_t failed = 0;       ///< TLS or protocol errors and handshake timeouts
  uint64_t over_limit = 0;   ///< closed at once: too many pending handshakes
  uint64_t web_files = 0;    ///< page files answered to browsers (ServerConfig::web_root)
  uint64_t web_viewers = 0;  ///< viewers admitted over WebSocket (counted in `admitted` too)
};

/// One change of a viewer's tier (or a notice that it could not change: `to` == `from`).
struct TierSwitch {
  int64_t time_us = 0;   ///< the server's wall clock
  std::string from, to;  ///< tier names, e.g. "volcast/jpeg/80", "h264/h264/50@2"
  std::string reason;
};

/// What the server knows about one viewer (for logs, tests and the benchmark).
struct ViewerReport {
  uint64_t id = 0;  ///< this server's number for the viewer (1, 2, ...; SessionPort's `viewer`)
  std::string peer;
  Tier tier;                  ///< frame_divisor: its tier encodes every Nth site frame set
  bool adaptive = false;      ///< moved along the ladder (Hello kAdapt and a ladder)
  int rung = -1;              ///< its ladder rung now (0 the best); -1 when pinned
  double goodput_mbit_s = 0;  ///< acknowledged over the last half second
  double queue_ms = 0;        ///< standing queue: least round trip less its minimum in the window
  std::vector<TierSwitch> switches;  ///< every change and notice, oldest first (the last 64)
  uint64_t frames_sent = 0;
  uint64_t frames_dropped = 0;  ///< frame sets of its tier it skipped (pacing, budget, no key yet)
  uint64_t frames_stale = 0;    ///< of those, skipped for being older than the latency budget
  uint64_t key_requests = 0;    ///< KeyFrameRequests the viewer sent
  /// Session messages of a queued stream (voice) dropped, oldest first, for it being slow
  /// (session_port.hpp kQueuedStreamKey).
  uint64_t session_dropped = 0;
  /// Times its thread took the session messages queued for it and wrote them (small ones joined
  /// in one write): voice packets held together (stream_coalesce_us) make fewer of these.
  uint64_t session_flushes = 0;
  uint64_t bytes_sent = 0;
  double min_rtt_ms = 0;         ///< path round trip (send -> Ack), windowed minimum
  double bottleneck_mbit_s = 0;  ///< delivery-rate estimate, windowed maximum
  int window = 0;                ///< frame sets it may have in flight now
  /// CPU time (ms) of the thread that serves this viewer since it began streaming: writing frame
  /// sets (TLS records or plain bytes, the sealed body), reading Acks, pacing. Its tier's encoding
  /// and sealing are not in it.
  double send_cpu_ms = 0;
  bool connected = false;
  std::string error;  ///< why it ended, if it did
};

/// One tier's encoder figures.
struct TierReport {
  Tier tier;
  int viewers = 0;
  double mbit_s = 0;  ///< what it produced over the last second
  uint64_t frames_encoded = 0, key_frames = 0;
  double encode_ms_mean = 0;  ///< wall time to encode every camera of a frame set (and seal it)
  /// CPU time (ms, all threads) the codecs spent per frame set encoded, a moving average over
  /// about the last 30 (0 while frame sets are passed through from a recording).
  double cpu_ms_mean = 0;
  /// What the tier is charged against ServerConfig::tier_cpu_budget now (cores, estimated).
  double cost_cores = 0;
};

/// One frame set of a tier as encoded, for a consumer other than a viewer (a recorder): the
/// FrameSet body (protocol.hpp 1.1) every viewer of the tier was sent, byte for byte.
struct TierFrameSet {
  uint64_t sequence = 0;             ///< the site's frame-set sequence
  bool key = false;                  ///< every camera decodes on its own
  int64_t capture_us = 0;            ///< the server's wall clock (us)
  std::span<const uint8_t> body;     ///< valid while `keep` is held
  std::shared_ptr<const void> keep;  ///< holds the body's buffer (the tier reuses it once freed)
  /// The tier's own count, 1, 2, ...: a delta decodes after the frame set index - 1 (the tier
  /// skips site frame sets when it falls behind, so sequences may jump where indices do not).
  uint64_t index = 0;
};

class Server final : public SessionOutlet {
 public:
  /// Binds and starts accepting. Throws Error if the address or port cannot be bound or the
  /// configuration is invalid (e.g. `insecure` on a non-loopback address, an offered tier with an
  /// unknown codec, an unusable certificate).
  Server(std::vector<protocol::CameraInfo> cameras, ServerConfig config);
  ~Server();
  Server(const Server&) = delete;
  Server& operator=(const Server&) = delete;

  uint16_t port() const;
  /// The session's join token.
  const JoinToken& token() const;
  /// SHA-256 of the server's certificate (64 hex digits); empty when insecure.
  std::string fingerprint() const;
  /// The join link for viewers reaching this server at `host` (join.hpp).
  std::string join_link(const std::string& host) const;
  /// The browser viewer's link for `host`: https://HOST:PORT/#token=TOKEN (http:// when
  /// insecure). The token is in the fragment, which a browser never sends: the page reads it and
  /// sends it in its Hello. Empty without ServerConfig::web_root.
  std::string web_link(const std::string& host) const;
  /// What came to the door so far.
  DoorReport door() const;
  /// ServerConfig::tier_cpu_budget as applied (cores; the default worked out).
  double tier_cpu_budget() const;
  /// Makes `frames` the newest frame set (one frame per camera, in camera order). Never blocks on
  /// encoders or viewers. Throws Error if the camera count differs from the site's.
  void publish(std::shared_ptr<const CapturedFrameSet> frames);
  /// Viewers connected now and the last 256 that left (including authenticated ones rejected for
  /// policy: server full, a tier not offered or over the CPU budget).
  std::vector<ViewerReport> viewers() const;
  /// Tiers with at least one viewer.
  std::vector<TierReport> tiers() const;
  /// Queues a whole session-channel message (protocol.hpp channel 2, header included) for viewer
  /// `viewer`, written by that viewer's thread ahead of its next frame set. `coalesce_key` != 0:
  /// replaces a message with the same key still queued for it (only the newest pose or avatar
  /// frame of a participant is sent on). Never blocks on the network; a viewer that lets more
  /// than 4096 messages pile up is disconnected. Returns false if there is no such viewer
  /// (gone). Thread-safe; `message` is shared, not copied, between viewers.
  bool send_session(uint64_t viewer, std::shared_ptr<const std::vector<uint8_t>> message,
                    uint64_t coalesce_key = 0) override;
  /// Ends viewer `viewer`'s connection (its thread logs `why`); SessionPort::on_viewer_left
  /// follows. Thread-safe; no-op for a viewer that has gone.
  void disconnect(uint64_t viewer, const std::string& why) override;
  /// Consumes `tier` (of every frame set: frame_divisor 1) like one more viewer that never falls
  /// behind: `tap` is called on the tier's thread with every frame set the tier encodes from its
  /// next key frame set on, in order, until stop(); the tier keeps encoding while the tap is there,
  /// viewers or none. `tap` must return quickly (queue the frame set and write it elsewhere: it
  /// holds up the tier's viewers while it runs); it must not throw. Returns the tap's id for
  /// remove_tier_tap. Throws Error for an unknown codec, a frame divisor other than 1, or when the
  /// server has max_tiers tiers already. Thread-safe.
  uint64_t add_tier_tap(const Tier& tier, std::function<void(const TierFrameSet&)> tap);
  /// Removes tap `id` (no-op for one removed already); a tier left with no viewer and no tap
  /// stops encoding. A frame set the tier is handing out as this runs may still reach the tap,
  /// none after. Thread-safe.
  void remove_tier_tap(uint64_t id);
  /// Asks `tier` for a key frame set, as a viewer's KeyFrameRequest does (made at most every
  /// min_key_interval_ms); no-op for a tier that does not run. Thread-safe.
  void request_key_frame(const Tier& tier);
  /// Stops accepting, disconnects every viewer and joins all threads. Idempotent.
  void stop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast
