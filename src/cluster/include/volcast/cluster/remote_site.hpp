#pragma once
// Capture nodes (issue 17, part 3): the cameras of another machine joined to this site. A capture
// node is an ordinary `volcast serve --nats ... --nats-site NODE --camera-only` publishing a
// lossless-depth tier of its own cameras; the site's server takes that tier from NATS here and
// reads each of the node's cameras as one more FrameSource, in lockstep with its own cameras
// (SitePlayer), so everything after capture -- filters, tiers, recording, relays -- sees one site.
//
// Assembly by capture time: the site reads its sources once a tick. A node camera's next() gives
// the received frame set whose capture time (the node's wall clock: keep the machines' clocks in
// step, NTP or PTP) is nearest the site's tick, waiting at most `max_wait_ms` for a newer one when
// the newest is more than half a frame older than the tick. A late node is not waited for longer:
// its camera repeats its last frame set for this tick. A node that sends nothing for `stale_ms`
// makes next() throw, so the site skips its camera (repeating the last frame) and marks it failed
// after SiteOptions::max_read_failures such ticks; the other cameras go on, and the camera recovers
// with the node's next frame set.
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <vector>

#include "volcast/capture/source.hpp"
#include "volcast/cluster/chunks.hpp"
#include "volcast/cluster/nats.hpp"
#include "volcast/cluster/tier_publisher.hpp"
#include "volcast/codec/tier.hpp"
#include "volcast/net/protocol/frame_set.hpp"
#include "volcast/net/protocol/protocol.hpp"

namespace volcast::cluster {

struct RemoteSiteOptions {
  std::string site;  ///< the capture node's site token (its serve --nats-site)
  /// The node's published tier (its --nats-tier): lossless depth keeps the node's depth exact.
  Tier tier{"volcast", "jpeg"};
  double fps = 30;                 ///< the site's frame-set rate: the node cameras' fps()
  int welcome_timeout_ms = 10000;  ///< give up unless the node's Welcome arrives this soon
  int max_wait_ms = 10;            ///< longest a tick waits for a node's newer frame set
  int stale_ms = 1000;             ///< nothing newer for this long: next() throws
};

struct RemoteSiteStats {
  uint64_t frame_sets = 0;   ///< decoded from the node
  uint64_t undecodable = 0;  ///< dropped: corrupt, or a delta without the frame set before it
  uint64_t waited = 0;       ///< ticks that waited for a newer frame set (and got one)
  uint64_t repeated = 0;     ///< ticks given a frame set a camera had already returned
  ReassemblyStats chunks;    ///< what came in
  int64_t nats_dropped = 0;  ///< messages libnats dropped: the site fell behind
  std::string last_error;
};

class RemoteSite {
 public:
  /// Subscribes to the node's Welcome and waits for it (welcome_timeout_ms), then to its tier,
  /// saying that it wants it (TierInterest). Throws Error naming the node and subject when no
  /// Welcome comes, or what NATS refused. `nats` must outlive the RemoteSite.
  RemoteSite(NatsConnection& nats, RemoteSiteOptions options);
  ~RemoteSite();  ///< unsubscribes; sources() already handed out then throw on next()
  RemoteSite(const RemoteSite&) = delete;
  RemoteSite& operator=(const RemoteSite&) = delete;

  /// The node's cameras as its Welcome named them (calibration: its intrinsics and extrinsics).
  const std::vector<protocol::CameraInfo>& cameras() const;
  /// One FrameSource per camera of the node, in its order, for the site's SitePlayer. They share
  /// this RemoteSite's received frame sets and may outlive it.
  std::vector<std::unique_ptr<FrameSource>> sources();
  RemoteSiteStats stats() const;

  struct State;  // what the sources share with the subscription (remote_site.cpp)

 private:
  void on_welcome(std::span<const uint8_t> data);
  void on_chunk(std::span<const uint8_t> data);

  NatsConnection& nats_;
  RemoteSiteOptions options_;
  std::shared_ptr<State> state_;
  // The tier's thread (libnats' callback) owns these.
  std::unique_ptr<Reassembler> reassembler_;
  std::unique_ptr<FrameSetDecoder> decoder_;
  FrameSet decoded_;
  std::vector<uint8_t> message_;
  bool have_previous_ = false;
  uint64_t previous_ = 0;
  std::unique_ptr<NatsConnection::Subscription> welcome_sub_, tier_sub_;
  std::unique_ptr<TierInterest> interest_;
};

}  // namespace volcast::cluster
