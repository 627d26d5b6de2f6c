#pragma once
// What a SiteServer owns (site_server.hpp), private to src/site. The members are declared in the
// order they are made, so they are destroyed in the reverse order, each outliving what uses it.
#include <atomic>
#include <memory>
#include <optional>
#include <vector>

#include "volcast/assets/case_watch.hpp"
#include "volcast/cluster/remote_site.hpp"
#include "volcast/cluster/session_link.hpp"
#include "volcast/cluster/session_state.hpp"
#include "volcast/cluster/tier_publisher.hpp"
#include "volcast/pipeline/replay.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/record/recorder.hpp"
#include "volcast/site/site_server.hpp"
#include "volcast/voice/site_voice.hpp"

namespace volcast::detail {

struct SiteParts {
  SiteServerOptions options;
  std::optional<ReplayPlayer> replay;
  std::optional<cluster::NatsConnection> nats;
  std::vector<std::unique_ptr<cluster::RemoteSite>> nodes;
  std::optional<SitePlayer> site;
  std::vector<protocol::CameraInfo> cameras;  ///< as viewers see them: names, never file paths
  std::optional<SessionHub> hub;
  std::unique_ptr<voice::SiteVoice> voice;  ///< the OR speaks and listens
  std::atomic<voice::SiteVoice*> listening{nullptr};
  std::optional<CaseWatch> case_watch;
  std::optional<BackgroundRecorder> recorder;
  std::optional<cluster::TierPublisher> publisher;
  std::optional<cluster::SessionBridge> bridge;      ///< relays' participants, to the hub
  std::optional<cluster::SessionStateMirror> state;  ///< the hub's state, in a NATS bucket
  std::optional<Server> server;
  bool stopped = false;
};

/// The cameras: the recording replayed, or the site's sources and the capture nodes' cameras in
/// a SitePlayer; logs each (site_cameras.cpp).
void open_cameras(SiteParts& s);

}  // namespace volcast::detail
