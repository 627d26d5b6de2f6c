#pragma once
// The viewer's side of the stream protocol: connects, names its tier, receives the calibration,
// then frame sets, decoding the cameras in parallel, and acknowledges each one.
#include <cstdint>
#include <functional>
#include <memory>
#include <span>
#include <string>
#include <vector>

#include "volcast/codec/tier.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/net/protocol/join.hpp"
#include "volcast/net/protocol/protocol.hpp"

namespace volcast {

struct ClientConfig {
  std::string host = "127.0.0.1";
  uint16_t port = 7300;
  JoinToken token{};        ///< the session's join token (from the join link)
  std::string fingerprint;  ///< the server certificate's SHA-256 (64 hex) from the link; may be
                            ///< empty only if `known_servers` pins it or is to learn it
  /// The pin store (trust.hpp): checked, and updated on first use or from the link; empty: none,
  /// so `fingerprint` must be given.
  std::string known_servers;
  bool insecure = false;  ///< plain TCP: refused unless `host` is a loopback address
  /// TCP connect and TLS handshake, retries included: a handshake the server drops (its door is
  /// full: tls.hpp TlsHandshakeDropped) is retried after 100 ms, doubling up to 1.6 s, one
  /// warning line per retry, until this many milliseconds have passed since the first try.
  int connect_timeout_ms = 5000;
  /// The tier asked for (its frame divisor must be 1: the server's ladder skips frame sets).
  Tier tier{"volcast", "jpeg"};
  /// Rate adaptation (server.hpp): the server may move this viewer along its tier ladder (the
  /// tier above is then the best it wants, if the ladder has it; else the ladder's best).
  bool adapt = false;
  bool keep_lossless = false;   ///< floor: never lossy depth (the server is told; checked here too)
  bool keep_full_rate = false;  ///< floor: never a tier that skips site frame sets
  uint64_t max_bits_per_s = 0;  ///< cap on the stream's rate (bits/s); 0: none
  /// Tell the server this viewer understands TierChange: when pinned, it is told if its path cannot
  /// carry its tier (TierState::notices, reason).
  bool notify = true;
  /// false: receive-only -- frame sets are read and acknowledged but not decoded (a load
  /// generator measuring the server, or a relay). A sealed one (protocol.hpp 1.2) is not even
  /// opened: its sequence, key flag and times come from the descriptor, and its per-camera sizes
  /// and device times are reported as 0.
  bool decode = true;
  /// Also hand over each frame set's encoded body (ReceivedFrameSet::encoded_body; a sealed one
  /// is opened for it): a recorder keeps the bytes the tier sent, with or without decoding.
  bool keep_encoded = false;
  int decode_threads = 0;  ///< worker threads for decoding (0 = cores - 1)
  /// The server's Welcome (or Reject) must arrive within this many milliseconds of the
  /// connection being made, or the constructor throws ClientError kTimedOut (<= 0: no limit).
  int handshake_timeout_ms = 5000;
  /// receive() throws ClientError kTimedOut when no complete message arrives for this many
  /// milliseconds of waiting (a server sends frame sets at the site's rate, e.g. 30 per second;
  /// <= 0: no limit).
  int receive_timeout_ms = 10000;
};

/// What Client throws once it has connected: an Error (callers that catch Error still do) that
/// says what ended the session, for callers that report it. Strings from the server in what()
/// are sanitised (volcast/core/text.hpp).
class ClientError : public Error {
 public:
  enum class Kind {
    kTimedOut,        ///< the server was silent past the handshake or receive timeout
    kRejected,        ///< the server sent Reject (its reason is in what())
    kProtocol,        ///< a malformed or oversized message, or a frame of the wrong size
    kConnectionLost,  ///< the connection broke (reset, or closed in the middle of a message)
  };
  ClientError(Kind kind, const std::string& message) : Error(message), kind_(kind) {}
  Kind kind() const { return kind_; }

 private:
  Kind kind_;
};

/// Per-stage times of one frame set, all on this viewer's clock (wall clock, microseconds since
/// the Unix epoch): the sender's times are shifted by the estimated clock offset (zero when the
/// two clocks cannot be told apart, e.g. on one machine).
struct StageTimes {
  int64_t capture_us = 0, filter_done_us = 0, encode_done_us = 0, send_us = 0;  ///< sender
  int64_t received_us = 0;  ///< the whole message read
  int64_t decoded_us = 0;   ///< every camera decoded (= received_us when not decoding)
};

/// A decoded frame set plus what it cost on the wire.
struct ReceivedFrameSet {
  FrameSet frames;  ///< decoded depth (mm) and color per camera (empty images when not decoding)
  bool key = false;
  StageTimes times;
  /// Per camera: 1 if its encoded frame is byte-identical to the one this Client decoded into
  /// this same object last time (a camera slower than the site repeats frames) with non-temporal
  /// codecs; it was not decoded again and its images above are what the caller left there (the
  /// last decoded ones, unless the caller moved them out: decoders keep their own references, so
  /// a caller may swap decoded images out for other buffers, which are then overwritten).
  std::vector<char> repeated;
  std::vector<size_t> depth_bytes;  ///< encoded depth size per camera
  std::vector<size_t> color_bytes;  ///< encoded color size per camera
  size_t message_bytes = 0;         ///< whole message including headers
  /// With ClientConfig::keep_encoded: the FrameSet body (protocol.hpp 1.1, everything after the
  /// send time) exactly as the server's tier encoded it; else empty. Capacity reused.
  std::vector<uint8_t> encoded_body;
};

/// The tier a viewer is on, as the server last said (protocol.hpp TierChange), or as it asked.
struct TierState {
  Tier tier;
  bool lossless_depth = true;
  double path_mbit_s = 0;  ///< the server's estimate of the path when it last said
  std::string reason;      ///< why (sanitised); empty until the server said anything
  uint64_t changes = 0;    ///< tier changes taken
  uint64_t notices = 0;    ///< notices: the path cannot carry the tier, but the floor or pin holds
  uint64_t messages = 0;   ///< TierChanges received (the first may only say where it starts)
};

/// A config joining the session of `link` (join.hpp); codecs and the rest stay at their defaults.
/// Throws Error like parse_join_link.
ClientConfig client_config_from_link(const std::string& link);

class Client {
 public:
  /// Connects (TLS 1.3 unless `insecure`), checks the server's certificate fingerprint, and
  /// completes the handshake. Throws Error if a codec is unknown, the server cannot be reached
  /// within connect_timeout_ms, or it presents another certificate than the pinned one (trust.hpp;
  /// nothing secret was sent then); ClientError if the server rejects the token or the tier (its
  /// reason is in the message), answers with a malformed Welcome or one beyond the viewer's limits
  /// (protocol.hpp: cameras, sizes, Welcome bytes; checked before anything is allocated for them),
  /// or does not answer within handshake_timeout_ms.
  explicit Client(const ClientConfig& config);
  ~Client();
  Client(const Client&) = delete;
  Client& operator=(const Client&) = delete;

  const protocol::Welcome& welcome() const;
  /// Estimated server clock minus this clock, microseconds (0 when within the handshake's
  /// uncertainty).
  int64_t clock_offset_us() const;
  /// Blocks for the next frame set, decodes it into `out` (buffers reused) and acknowledges it.
  /// A frame set whose delta frames cannot be decoded (reference missing) is acknowledged,
  /// skipped, and a key frame requested; counted in frames_undecodable(). Returns false when the
  /// server closed the connection or close() was called (also from another thread, while
  /// blocked here). Throws ClientError: kTimedOut when no complete message arrives for
  /// receive_timeout_ms; kProtocol on a malformed message, a FrameSet larger than
  /// protocol::frame_set_payload_limit(welcome()) (refused from its header, before its bytes are
  /// read; a payload's buffer grows only as its bytes arrive, 1 MiB at a time), or a camera's
  /// depth or color stream whose own header declares another size than the camera's calibration
  /// (checked before decoding; the message names the camera); kConnectionLost if the connection
  /// breaks.
  bool receive(ReceivedFrameSet& out);
  uint64_t frames_undecodable() const;
  /// The tier now (changed inside receive(), before the first frame set of a new tier). Read it
  /// on the thread that calls receive().
  const TierState& tier() const;
  /// Session channel (protocol.hpp channel 2; src/session). `handler` is called on the thread in
  /// receive() with each session message's type (the byte after the channel) and payload (valid
  /// during the call), at most `max_payload(type)` bytes (0: an unknown type, a protocol error);
  /// an Error it throws ends receive() as kProtocol. Without a handler, session messages of up
  /// to kMaxControlBytes are skipped. Thread-safe (a participant moving to a new connection
  /// takes its handler off the old one); the handler must not call it.
  using SessionHandler = std::function<void(uint8_t type, std::span<const uint8_t> payload)>;
  void set_session_handler(SessionHandler handler, std::function<uint32_t(uint8_t)> max_payload);
  /// Queues a whole session message (header included) for the server; the thread in receive()
  /// writes it between messages, or within the next 64 KiB of a long one it is reading (a case
  /// of megabytes; not inside a sealed frame set's body, read outside TLS: within one). A
  /// `coalesce_key` != 0 replaces a queued message with the same key (only the newest pose is
  /// sent on). Thread-safe; returns at once. Messages queued while nobody is in receive() wait
  /// for it.
  void post_session(std::vector<uint8_t> message, uint64_t coalesce_key = 0);
  /// Whether a message posted with `coalesce_key` (!= 0) still waits to be written. Thread-safe.
  bool session_queued(uint64_t coalesce_key) const;
  /// Closes the connection; a receive() blocked in another thread returns false. Thread-safe.
  void close();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast
