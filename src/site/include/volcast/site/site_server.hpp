#pragma once
// One OR site's server as a whole: its cameras (or a recording replayed), the virtual OR's
// sessions and the case shown in them, the OR's own voice, the stream server, the recorder and
// the NATS cluster's outlets, made, started and stopped in the one order that loses nothing.
// `volcast serve` and `volcast replay` parse their flags into SiteServerOptions and run one.
//
// Made in this order, stopped in the reverse, each outliving what uses it: the NATS connection
// outlives the capture nodes' subscriptions, which outlive the site (their cameras are its
// sources); the hub outlives the case watch and the server; the recorder, the publisher, the
// session bridge and the state mirror outlive the server, whose tier taps feed them; the server
// goes first, so that its viewers' threads stop before anything they reach. stop() writes the
// sessions' last state before the server ends their participants, and tells every participant
// that the recording stopped before their connections close.
#include <functional>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "volcast/cluster/nats.hpp"
#include "volcast/codec/tier.hpp"
#include "volcast/filter/chain.hpp"
#include "volcast/net/stream/server.hpp"
#include "volcast/pipeline/replay.hpp"
#include "volcast/session/hub.hpp"

namespace volcast {
namespace detail {
struct SiteParts;
}

struct SiteServerOptions {
  // The cameras: a recording replayed (`replay_path`), or the site's: those of the site config
  // (`site_config`, io/site_config.hpp), then `sources`, then the capture nodes' on NATS.
  std::string replay_path;               ///< a .vcr replayed as recorded; "" for a live site
  ReplayOptions replay;                  ///< with replay_path: the part, and whether it loops
  std::string site_config;               ///< site config JSON; "" for none
  std::vector<std::string> sources;      ///< more camera sources (open_source)
  std::optional<Intrinsics> intrinsics;  ///< for sources that carry none
  /// Camera `i`'s filters (before a site config's own "filters" apply); null: none.
  std::function<FilterConfig(size_t camera)> filters;
  double fps = 0;              ///< 0: the recordings' own rate
  int max_read_failures = 30;  ///< failed reads in a row that mark a camera failed

  /// The NATS cluster (cluster/nats.hpp); none when unset. Needed by the three below.
  std::optional<cluster::NatsOptions> nats;
  std::string nats_site = "or";           ///< the site's subject token
  std::vector<std::string> nats_cameras;  ///< capture nodes whose cameras join this site
  Tier nats_camera_tier;                  ///< the tier those nodes publish
  std::vector<Tier> nats_tiers;           ///< tiers offered on NATS to relays
  int nats_state_replicas = 1;            ///< the sessions' state in JetStream (0: not kept)
  bool camera_only = false;  ///< a capture node: publish on NATS; no sessions' bridge or state

  /// The sessions' hub (its site_listener is the OR's voice's, set here).
  SessionHubConfig hub;
  std::vector<std::string> sessions{"OR"};  ///< made at start
  std::string mic, speaker;       ///< the OR's own voice: a .wav or a sound device; "": none
  bool echo_cancellation = true;  ///< the loudspeaker's echo taken out of the microphone
  std::string case_folder;        ///< the patient case (assets/case_watch.hpp); "": none
  size_t case_max_triangles = 60000;

  ServerConfig server;      ///< its `session` is set to the hub here
  std::string record_path;  ///< record `record_tier` here (.vcr); "": no recording
  Tier record_tier;
};

class SiteServer {
 public:
  /// Opens everything and listens (ServerConfig's port), the cameras not yet started. Throws
  /// Error naming what could not be opened (a source, the NATS cluster, the recording's file),
  /// having closed what it had opened.
  explicit SiteServer(SiteServerOptions options);
  /// stop(), if it has not run.
  ~SiteServer();
  SiteServer(const SiteServer&) = delete;
  SiteServer& operator=(const SiteServer&) = delete;

  /// Starts the cameras (or the replay, whose recorded voices speak in the sessions).
  void start();
  /// Stops everything in the order that loses nothing and logs the sessions', the OR's voice's,
  /// the recording's and each viewer's figures. Once.
  void stop();

  Server& server();
  SessionHub& hub();
  /// The cameras as viewers see them (names, never file paths).
  const std::vector<protocol::CameraInfo>& cameras() const;
  /// Frame sets a second the site (or replay) publishes.
  double fps() const;
  bool replaying() const;
  /// A replay that does not loop has played to its end.
  bool finished() const;
  /// One line of figures: frame sets published, viewers connected, failed cameras, what was
  /// recorded and published on NATS.
  std::string progress() const;

 private:
  std::unique_ptr<detail::SiteParts> parts_;
};

}  // namespace volcast
