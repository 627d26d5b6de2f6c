#pragma once
// The session service of the OR server (Fischer et al. 2024, §3.4: the OR server hosts the virtual
// room and relays its traffic): the lobby, sessions of participants, presence with a timeout,
// poses (only the newest per participant is sent on to each receiver), pose echoes for the round
// trip, server-checked teleports, and camera avatars whose frames, encoded once by their sender,
// are forwarded to every other participant unchanged. Messages: messages.hpp.
//
// The OR site is a participant of every session (id 1, role OR site): its cameras are the
// stream every participant receives, placed in the room by room_from_site. Roles come from the
// server, never from a Join: every viewer, the server's own and relays', is a remote participant;
// a Join claiming the OR site's role is refused with a SessionError saying so.
//
// Sessions made by the server (create_session: serve's --session) stay while it runs. A session a
// Join created is removed, with its objects' and monitor's state, when its last participant goes;
// one put back by restore() that nobody joins, after SessionHubConfig::unjoined_session_ms. One
// participant (one connection) creates at most rate_limit.hpp's kSessionCreation sessions.
//
// Every participant's messages are rate limited per type where they enter (rate_limit.hpp): over
// its limit a message is dropped, the sender told once per burst (a SessionError naming the
// limit), the server's log given the count.
//
// Names (display and session) are normalised to NFC and checked for bidi controls, invisible
// characters and mixed-script look-alikes (names.hpp); a display name that looks like another's
// in the session (the same UTS #39 skeleton) is refused. The Join is refused naming the problem.
#include <array>
#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <span>
#include <string>
#include <thread>
#include <vector>

#include "volcast/net/stream/session_port.hpp"
#include "volcast/room/room.hpp"
#include "volcast/session/annotations.hpp"
#include "volcast/session/message_table.hpp"
#include "volcast/session/messages.hpp"
#include "volcast/session/objects.hpp"
#include "volcast/session/rate_limit.hpp"
#include "volcast/session/voice_messages.hpp"

namespace volcast::session {
template <typename Route>
struct FeatureRoutes;  // src/session/routes.hpp
}  // namespace volcast::session

namespace volcast {

struct SessionHubConfig {
  RoomLayout room = default_operating_room();
  /// room_from_site: where the site's world frame (its cameras' world_from_camera) sits in the
  /// room: a shift (metres) and a turn about +y (radians).
  Eigen::Vector3f site_translation = Eigen::Vector3f::Zero();
  float site_yaw = 0;
  std::string site_name = "OR site";  ///< the OR site participant's display name
  /// A participant from whom no session message came for this long is removed ("timed out") and
  /// disconnected. Participants send poses at the display rate, or heartbeats.
  int presence_timeout_ms = 3000;
  int max_sessions = 16;
  int max_participants = 16;  ///< per session, the OR site included
  /// A session put back by restore() (saved state) that nobody joins is removed after this long.
  int unjoined_session_ms = 10 * 60 * 1000;
  /// The OR site's loudspeaker (voice_messages.hpp): called with every voice packet a participant
  /// of any session sends, and its sender's participant id, after the hub checked it. Called with
  /// the hub's lock held, on the sender's thread: it must only queue the packet. Null: the site
  /// does not listen.
  std::function<void(uint32_t participant, const session::VoicePacketView& packet)> site_listener;
  /// Who may erase an annotation (annotations.hpp 0x12): anyone in its session (true: a mentor's
  /// stroke stays erasable after the mentor left), or only its author.
  bool anyone_erases = true;
};

/// What the hub has handled, since it started.
struct SessionHubStats {
  uint64_t messages_in = 0, poses_in = 0, pose_messages_out = 0;
  uint64_t avatar_frames_in = 0, avatar_frames_out = 0, avatar_bytes_out = 0;
  uint64_t joins = 0, leaves = 0, timeouts = 0, dropped = 0;
  uint64_t grabs = 0, grabs_refused = 0, object_moves = 0, moves_ignored = 0, releases = 0;
  uint64_t monitor_changes = 0, case_swaps = 0;
  uint64_t rate_limited = 0;   ///< messages dropped over their type's limit (rate_limit.hpp)
  uint64_t joins_refused = 0;  ///< Joins answered with a SessionError
  uint64_t rejoins = 0;        ///< Joins that took their own member over (messages.hpp rejoin key)
  /// Joins of a participant timed out before, with its rejoin key: it got its id back.
  uint64_t returns = 0;
  uint64_t sessions_removed = 0;  ///< sessions removed (empty)
  /// Pose echoes not forwarded: not an answer to one of its receiver's recent poses that asked
  /// for one, or that participant's second answer to it (hub.cpp on_pose_echo).
  uint64_t echoes_refused = 0;
  /// Voice packets received (the site's own included), sent on to receivers, and refused as
  /// malformed (voice_messages.hpp: each loses only itself until kMaxMalformedVoice).
  uint64_t voice_in = 0, voice_out = 0, voice_malformed = 0;
  /// Pointer messages received; annotations taken, refused (0x43: annotations.hpp) and erased.
  uint64_t pointers_in = 0, annotations = 0, annotations_refused = 0, erases = 0;
  /// Bytes of pointer, annotation and erase messages sent to receivers (headers included).
  uint64_t drawing_bytes_out = 0;
};

/// One participant as the hub sees it.
struct SessionMember {
  uint32_t id = 0;
  uint64_t viewer = 0;  ///< the server's viewer id (0: the OR site itself)
  std::string name;
  session::Role role = session::Role::kRemote;
  bool has_camera = false;
  session::Spot spot;
  uint64_t poses = 0, avatar_frames = 0;
  uint64_t voice_packets = 0;
  bool muted = false;  ///< its last VoiceState (voice_messages.hpp)
  /// A recorded speaker (SessionHub::add_recorded_speaker): a replay's voice, no connection.
  bool recorded = false;
};

class SessionHub final : public SessionPort {
 public:
  /// Starts the presence thread. Throws Error on a config out of range.
  explicit SessionHub(SessionHubConfig config = {});
  ~SessionHub() override;
  SessionHub(const SessionHub&) = delete;
  SessionHub& operator=(const SessionHub&) = delete;

  /// The server whose viewers are the participants (its ServerConfig::session must be this hub);
  /// null detaches (before the server is destroyed).
  void attach(SessionOutlet* server);
  /// Viewer ids with bit 63 set (kRemoteViewer) are viewers of relays: their messages come in
  /// through on_message like the server's own viewers', and what the hub sends them goes to
  /// `remote` (cluster/session_link.hpp's SessionBridge); null detaches (before it is destroyed).
  void attach_remote(SessionOutlet* remote);
  static constexpr uint64_t kRemoteViewer = uint64_t{1} << 63;
  /// Makes a session with no one but the OR site in it (a session a demo starts), kept while the
  /// hub runs, empty or not; if it exists, it is kept from now on. Throws Error on a bad name
  /// (names.hpp) or too many sessions.
  void create_session(const std::string& name);
  std::vector<session::SessionSummary> sessions() const;
  /// The members of session `name` (empty if there is none), the OR site first.
  std::vector<SessionMember> members(const std::string& name) const;
  SessionHubStats stats() const;
  /// Shares `c` with every session (objects at their rest poses, nobody holding them; the monitor
  /// at its middle slice, the abdomen window, the overlay on) and sends it to every participant,
  /// now and on joining. Its generation is set here (one more than the last). Throws Error if it
  /// does not serialise (over kMaxCaseBytes). One caller at a time (serve's case watcher).
  void set_case(SharedCase c);
  /// Tells every member of every session, now and whenever one joins, that the room is being
  /// recorded and by whom (0x53 RecordingState, messages.hpp): every viewer shows it. `by` names
  /// who or what records as people read it ("the OR server (serve --record)"); it is cut to
  /// kMaxRecorderBytes at a character boundary and its control characters become spaces.
  void start_recording(const std::string& by);
  /// Tells everyone the recording stopped (0x53 with recording 0); nothing if none runs.
  void stop_recording();
  /// What every member is shown of the recording (recording false: none runs).
  session::RecordingState recording() const;
  /// The case's generation (0: none yet).
  uint32_t case_generation() const;
  /// The objects' states in session `name` (empty if there is none or no case).
  std::vector<session::ObjectState> objects(const std::string& name) const;
  std::optional<MonitorState> monitor(const std::string& name) const;
  /// The annotations of session `name` (annotations.hpp), by id: what a participant joining now
  /// receives. Empty if there is no such session.
  std::vector<session::Annotation> annotations(const std::string& name) const;
  /// The case's name (empty: none yet).
  std::string case_name() const;
  /// Puts session `name` back as it was saved (cluster/session_state.hpp): each object's pose
  /// (nobody holds anything after a restart; indices past the case's objects are ignored) and
  /// the monitor's slice (clamped to the series), window and overlay. A missing session is made,
  /// and removed like a participant's (when its last participant goes, or after
  /// unjoined_session_ms if nobody joins) unless create_session made it. Applied only when the
  /// current case is named `case_name`: false (nothing changed) for another case or none. For a
  /// hub starting up, before participants join (they get it on joining). Throws Error on a bad
  /// session name or too many sessions.
  bool restore(const std::string& name, const std::string& case_name,
               const std::vector<session::ObjectState>& objects,
               const std::optional<MonitorState>& monitor);

  /// The OR site's microphone (participant 1): forwards `packet` (voice_messages.hpp; the site's
  /// own sequence, frame and capture time on the server's clock) to every participant of every
  /// session. Thread-safe; never blocks on the network.
  void site_voice(const session::VoicePacketView& packet);
  /// The OR site's microphone muted or not (0x4f to everyone, and to those who join later).
  void site_voice_state(bool muted);

  /// Adds a recorded speaker: a voice of the recording being replayed (pipeline/replay.hpp). It is
  /// a participant of every session, those there now (announced to their members by 0x44) and
  /// those made later, with no connection: it never leaves or times out and does not count
  /// against max_participants. Its display name is `name` + " (recorded)", checked as a Join's
  /// (names.hpp; `name` shortened to fit kMaxNameBytes, "recorded speaker" if it is refused, " 2",
  /// " 3"... added if it looks like the OR site's or another recorded speaker's). Its role is
  /// remote (0x44 has no other role for it: a recorded OR site too, whose role would claim the
  /// site's cameras). It stands on the last free spawn spot of each session (live participants
  /// take the first), or for `or_site` at the table's centre, so that its voice comes from above
  /// the table as the live site's does. Returns its participant id. Thread-safe.
  uint32_t add_recorded_speaker(const std::string& name, bool or_site);
  /// Forwards `packet` (voice_messages.hpp; sequence, frame and capture time as the replay
  /// renumbered and stamped them, server clock) from recorded speaker `speaker` as 0x4e to every
  /// participant of every session, and to the OR site's loudspeaker (site_listener). False, and
  /// nothing sent, if `speaker` is not an id add_recorded_speaker returned. Thread-safe; never
  /// blocks on the network.
  bool recorded_voice(uint32_t speaker, const session::VoicePacketView& packet);
  /// A replay's drawing (pipeline/replay.hpp): one recorded annotation message, `type` 0x51 or
  /// 0x52 with its `payload` as the recording holds it (annotations.hpp), applied to every
  /// session now. 0x51 adds the annotation to each session as if `as` had drawn it now: numbered
  /// as that session numbers its own (the recorded id is kept only to find it again), author
  /// `as` (the recorded speaker add_recorded_speaker made for its recorded author; 0, as for the
  /// server, where the recording does not name its author), time this server's clock now; its
  /// label text checked as a live one's; a monitor annotation is put on the current case's
  /// monitor if that has its slice (else refused: the recorded case's generation means nothing
  /// here). A session at its limits (kMaxSessionAnnotations, kMaxSessionAnnotationPoints) does not
  /// take it. The same recorded id added again (a looping replay) replaces the one still shown.
  /// 0x52 erases, in every session, the annotation its recorded id added there, as erased by
  /// `as` (0x52's by). Everyone in a session is sent what changed in it (0x51, 0x52), as for live
  /// drawing; those who join later get the annotations standing. Sessions made later do not get
  /// what was added before them. Returns whether any session changed: false for a malformed or
  /// refused message (never throws), or nothing to erase. Thread-safe; never blocks on the network.
  bool recorded_drawing(uint8_t type, std::span<const uint8_t> payload, uint32_t as);

  /// Each participant message type this hub handles, with the feature whose routes handle it
  /// (message_table.hpp), in the features' order: for checks against the message table.
  static std::vector<std::pair<session::Type, session::Feature>> handled_types();

  // SessionPort (called by the server on viewers' threads).
  uint32_t max_payload(uint8_t type) const override;
  void on_message(uint64_t viewer, uint8_t type, std::span<const uint8_t> payload) override;
  void on_viewer_left(uint64_t viewer, const std::string& why) override;

 private:
  struct Member;
  struct Session;
  void handle(uint64_t viewer, uint8_t type, std::span<const uint8_t> payload);

  // What participants send: one handler per message type, in the file of its feature
  // (message_table.hpp's Feature): presence in hub.cpp, avatars in hub_avatars.cpp, voice in
  // hub_voice.cpp, drawing in hub_annotations.cpp, objects in hub_case.cpp. Each feature lists
  // its routes; handle() dispatches through them (route()), and a type without one is refused.
  using Payload = std::span<const uint8_t>;
  struct Route {
    session::Type type;
    /// For what anyone connected may send: `m` is the sender's membership, null outside a session.
    void (SessionHub::*anyone)(uint64_t viewer, Member* m, Payload payload) = nullptr;
    /// For what only a member sends: not called outside a session (the sender is told so).
    void (SessionHub::*member)(Member& m, Payload payload) = nullptr;
  };
  static const Route* route(uint8_t type);
  static std::span<const session::FeatureRoutes<Route>> features();  // every feature's routes
  static std::span<const Route> presence_routes();
  static std::span<const Route> avatar_routes();
  static std::span<const Route> voice_routes();
  static std::span<const Route> drawing_routes();
  static std::span<const Route> object_routes();
  bool in_session(uint64_t viewer, const Member* m, const char* what);
  // presence (hub.cpp)
  void on_list_sessions(uint64_t viewer, Member* m, Payload p);
  void on_join(uint64_t viewer, Member* m, Payload p);
  void on_leave(uint64_t viewer, Member* m, Payload p);
  void on_heartbeat(uint64_t viewer, Member* m, Payload p);
  void on_pose(uint64_t viewer, Member* m, Payload p);
  void on_pose_echo(uint64_t viewer, Member* m, Payload p);
  void on_teleport(uint64_t viewer, Member* m, Payload p);
  // avatars (hub_avatars.cpp)
  void on_avatar_camera(uint64_t viewer, Member* m, Payload p);
  void on_avatar_frame(Member& m, Payload p);
  // voice (hub_voice.cpp)
  void on_voice(Member& m, Payload p);
  void on_voice_state(Member& m, Payload p);
  // drawing (hub_annotations.cpp)
  void on_pointer(Member& m, Payload p);
  void on_annotate(Member& m, Payload p);
  void on_erase(Member& m, Payload p);
  // objects (hub_case.cpp)
  void on_object_request(Member& m, session::Type type, Payload p);
  void on_grab(Member& m, Payload p) { on_object_request(m, session::Type::kGrab, p); }
  void on_object_move(Member& m, Payload p) { on_object_request(m, session::Type::kObjectMove, p); }
  void on_release(Member& m, Payload p) { on_object_request(m, session::Type::kRelease, p); }
  void on_set_monitor(Member& m, Payload p);

  void join(uint64_t viewer, const session::Join& join);
  void welcome_member(uint64_t viewer, const Member& m);
  void take_over(uint64_t viewer, Member& m);
  uint32_t returning_id(const Session& s, const session::Join& j);
  static constexpr size_t kMaxTimedOutKept = 64;
  static constexpr int kTimedOutKeptMs = 60000;
  void remove(uint64_t viewer, session::LeftReason reason);
  Session& make_session(const std::string& name, bool standing);
  void prune(Session* s);  // removes `s` if it is a participant's session with nobody in it
  void send(uint64_t viewer, std::vector<uint8_t> message, uint64_t coalesce_key = 0);
  void send_shared(uint64_t viewer, const std::shared_ptr<const std::vector<uint8_t>>& message,
                   uint64_t coalesce_key = 0);
  void error(uint64_t viewer, const std::string& reason);
  void watch_presence();
  void reset_case_state(Session& s);
  void send_case_state(const Session& s, uint64_t viewer);
  void broadcast_object(const Session& s, uint16_t object, const Member* except);
  void send_drawing_state(const Session& s, uint64_t viewer);
  void erase_stale_annotations(Session& s);  // monitor annotations of a case swapped out
  void broadcast_recording();                // recording_ to every member
  void broadcast_voice(uint32_t from, const std::shared_ptr<const std::vector<uint8_t>>& message,
                       const Session& s);
  struct Recorded {
    uint32_t id;
    std::string name;
    bool or_site;
  };
  session::Spot free_spot(const Session& s, bool from_last) const;
  static int connected(const Session& s);  // members with a connection (not the site, recorded)
  Member& add_recorded_member(Session& s, const Recorded& r);

  SessionHubConfig config_;
  mutable std::mutex mutex_;
  SessionOutlet* outlet(uint64_t viewer) const {
    return viewer & kRemoteViewer ? remote_ : server_;
  }
  SessionOutlet* server_ = nullptr;
  SessionOutlet* remote_ = nullptr;
  std::map<uint32_t, std::unique_ptr<Session>> sessions_;  // by session id
  std::map<uint64_t, Member*> by_viewer_;                  // participants in a session
  // Participants timed out with a rejoin key, newest last (at most kMaxTimedOutKept, for
  // kTimedOutKeptMs): one that comes back with its key gets its participant id back (join).
  struct TimedOut {
    std::string session, name;
    std::array<uint64_t, 2> rejoin_key{};
    uint32_t id = 0;
    std::chrono::steady_clock::time_point at;
  };
  std::vector<TimedOut> timed_out_;
  uint32_t next_session_ = 1, next_participant_ = 2;  // participant 1: the OR site
  SessionHubStats stats_;
  session::RateLimiter limiter_;
  std::shared_ptr<const SharedCase> case_;
  std::shared_ptr<const std::vector<uint8_t>> case_message_;
  uint32_t case_generation_ = 0;
  bool site_muted_ = false;
  session::RecordingState recording_;  // start_recording's, sent to each member on joining
  std::vector<Recorded> recorded_;     // add_recorded_speaker's, members of every session
  std::atomic<bool> stopping_{false};
  std::thread presence_;
};

}  // namespace volcast
