#pragma once
// A participant's side of the session channel (messages.hpp), on the connection of its Client:
// joins a session through the lobby, publishes its body pose at the display rate (only the newest
// unsent one goes out), receives the others' poses and interpolates them, answers pose echoes,
// teleports, uploads its own RGB-D camera as an avatar stream (encoded once, in a lossless codec)
// and receives the others' avatar frames, decoding them only when someone asks for them. Measures
// the session round trip (own pose -> seen by another -> echoed back), pose rates and ages, and
// avatar latency, all on the server's clock (Client::clock_offset_us).
#include <cstdint>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <vector>

#include "volcast/core/calibration.hpp"
#include "volcast/core/frame.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/room/room.hpp"
#include "volcast/session/annotations.hpp"
#include "volcast/session/message_table.hpp"
#include "volcast/session/messages.hpp"
#include "volcast/session/objects.hpp"
#include "volcast/session/voice_messages.hpp"

namespace volcast {

/// A participant's own RGB-D camera: calibration with world_from_camera = playarea_from_camera
/// (metres; the camera registered to the participant's play area) and its upload codecs (depth
/// lossless and not temporal: volcast, rvl, zstd, lz4, raw; color not temporal: jpeg, raw, none).
struct AvatarCameraSetup {
  CameraCalibration calibration;
  std::string depth_codec = "volcast";
  std::string color_codec = "jpeg";
};

struct ParticipantConfig {
  /// The session to join (1..64 bytes of UTF-8, checked as names.hpp says).
  std::string session = "OR";
  bool create = true;  ///< make it if there is none of that name
  /// Display name, unique in the session and not like another's (1..64 bytes of UTF-8, checked as
  /// names.hpp says). A participant is always remote: roles come from the server (hub.hpp).
  std::string name;
  std::optional<AvatarCameraSetup> camera;
  /// Others' poses are shown this far in the past, interpolated between the two received poses
  /// around that time (two pose intervals at 60 Hz plus jitter; 0 shows the newest).
  int64_t interpolation_delay_us = 40'000;
  int echo_every = 6;  ///< every Nth pose asks its receivers for an echo (round trip samples)
};

/// Another participant as this one sees it now.
struct RemoteParticipant {
  uint32_t id = 0;
  std::string name;
  session::Role role = session::Role::kRemote;
  bool has_camera = false;
  session::Spot spot;               ///< where its play area stands
  bool has_pose = false;            ///< a pose has arrived
  BodyPose pose;                    ///< room frame, interpolated (see interpolation_delay_us)
  BodyPose newest_pose;             ///< room frame, the newest received
  int64_t newest_pose_time_us = 0;  ///< its time stamp, server clock
  uint32_t newest_pose_sequence = 0;
  /// Its avatar camera in the room: world_from_camera = room_from_playarea(spot) *
  /// playarea_from_camera; absent without a camera.
  std::optional<CameraCalibration> avatar_camera;
  uint64_t avatar_sequence = 0;  ///< newest avatar frame received (0: none)
  bool muted = false;            ///< its microphone is muted (voice_messages.hpp 0x4f)
  uint64_t voice_packets = 0;    ///< voice packets received from it
  int64_t last_voice_us = 0;     ///< local wall clock of the newest (0: none)
};

/// A teleport seen in the session (anyone's, one's own included).
struct TeleportSeen {
  uint32_t participant = 0;
  session::Spot from, to;
  int64_t time_us = 0;  ///< server clock
};

/// One of the case's objects as this participant sees it now.
struct ObjectView {
  uint16_t object = 0;
  uint32_t owner = 0;  ///< participant id holding it, 0: nobody
  /// room_from_object: held by another, interpolated like their poses; held by this participant,
  /// where it last moved it; else where it was let go.
  Pose pose;
  uint32_t sequence = 0;
};

/// A participant's laser pointer while it is held (annotations.hpp; room frame, metres).
struct PointerView {
  uint32_t participant = 0;  ///< its owner (this participant's own id for its own)
  Eigen::Vector3f origin = Eigen::Vector3f::Zero();
  bool has_hit = false;
  Eigen::Vector3f hit = Eigen::Vector3f::Zero();  ///< where it meets a surface (has_hit)
  int64_t time_us = 0;                            ///< server clock
};

struct SessionSnapshot {
  bool joined = false;
  uint32_t id = 0;  ///< this participant's id once joined
  std::string session_name;
  session::Spot spot;                     ///< this participant's play area
  bool has_own_body = false;              ///< publish() was called since joining
  BodyPose own_body;                      ///< room frame, the last published (the eye is its head)
  RigidTransform room_from_site;          ///< where the OR site's cameras sit in the room
  std::vector<RemoteParticipant> others;  ///< by id; the OR site included
  std::vector<TeleportSeen> teleports;    ///< the last 16
  std::vector<session::SessionSummary> lobby;  ///< the last SessionList
  std::string last_error;                      ///< the server's last SessionError, if any
  /// Whether the room is being recorded and by whom (0x53): every viewer shows it while joined.
  session::RecordingState recording;
  /// (id, name, reason) of the participants that left, oldest first (the last 64).
  std::vector<std::tuple<uint32_t, std::string, session::LeftReason>> departed;
  uint32_t case_generation = 0;         ///< 0: no case received
  std::vector<ObjectView> objects;      ///< by object index of shared_case()
  std::optional<MonitorState> monitor;  ///< when the case has a series
  /// The pointers held now, by owner id: the others' (the newest received) and this
  /// participant's own (as last sent), none of those who left.
  std::vector<PointerView> pointers;
  /// The session's annotations, by id (the order drawn): every one since joining, with those
  /// drawn before it, but those erased.
  std::vector<session::Annotation> annotations;
};

/// Where everyone's head is, as a voice mixer needs it every 20 ms: the part of a
/// SessionSnapshot that places voices (room frame, metres), kept in storage the caller reuses.
struct VoiceScene {
  /// One other participant (the OR site included).
  struct Speaker {
    uint32_t id = 0;
    std::string name;
    session::Spot spot;     ///< where its play area stands
    bool has_pose = false;  ///< a pose has arrived
    Pose head;              ///< interpolated as SessionSnapshot::others' pose
  };
  session::Spot spot;           ///< this participant's play area
  bool has_own_body = false;    ///< publish() was called since joining
  Pose own_head;                ///< the last published head
  std::vector<Speaker> others;  ///< by id
};

/// Figures about the others (the session's receivers' side) and the round trip.
struct RemoteStats {
  uint32_t id = 0;
  std::string name;
  uint64_t poses_received = 0;
  double pose_rate_hz = 0;  ///< over the time between its first and newest pose received
  double pose_age_ms_p50 = 0, pose_age_ms_p99 = 0;  ///< server-clock age when received
  uint64_t avatar_frames_received = 0;
  double avatar_fps = 0;
  double avatar_latency_ms_p50 = 0, avatar_latency_ms_p99 = 0;  ///< capture -> received
  uint64_t pointers_received = 0;
  /// Its pointer's moves, sent -> received here (server clock; annotations.hpp 0x50).
  double pointer_age_ms_p50 = 0, pointer_age_ms_p99 = 0;
};

struct ParticipantStats {
  uint64_t poses_sent = 0, avatar_frames_sent = 0, voice_sent = 0;
  size_t round_trip_samples = 0;
  double round_trip_ms_p50 = 0, round_trip_ms_p99 = 0;
  std::vector<RemoteStats> others;  ///< by id: everyone seen in the session (those who left too),
                                    ///< but the OR site
};

class Participant {
 public:
  /// Installs the session handler on `client` (not in receive() yet; it must outlive this object
  /// or detach() be called first) and sends ListSessions and Join. Throws Error on a bad name
  /// (names.hpp: the server would refuse it) or camera setup.
  Participant(Client& client, ParticipantConfig config);
  ~Participant();
  /// Lets go of the client (removes the handler); later sends are ignored, the state stays
  /// readable. Call before the Client goes (leave() first to leave gracefully; else the server
  /// notices the closed connection or the silence).
  void detach();
  /// Moves to `client`, a new connection to the same server (not in receive() yet; the old one
  /// is closed or about to be: its path was cut) and joins the session it was in again, with the
  /// rejoin key it drew at construction (messages.hpp Join): if the server still holds its place
  /// it gets it back (the same participant id), else it joins anew. Until the server answers,
  /// joined() is false and sends are ignored; the others, the case and the drawing arrive again.
  /// Call from the thread that calls receive() on either client, between receives.
  void reattach(Client& client);
  Participant(const Participant&) = delete;
  Participant& operator=(const Participant&) = delete;

  /// Publishes this participant's body in its play area frame (playarea_from_head etc.); sent in
  /// the room frame, time-stamped now on the server clock. Ignored until joined, and beyond the
  /// server's pose rate limit (rate_limit.hpp: 150 a second, 75 at once; a faster display's
  /// extra poses). Thread-safe.
  void publish(const BodyPose& playarea_pose);
  /// Asks to move the play area's origin to `to` (the server checks it; the others see an
  /// effect). Thread-safe.
  void teleport(const session::Spot& to);
  /// Encodes and uploads one frame of the own camera, captured at `capture_us` (local wall
  /// clock); kept as own_frame(). Sizes as its calibration, else Error; without a camera in the
  /// config, Error. Ignored until joined. Thread-safe.
  void upload(std::shared_ptr<const CameraFrame> frame, int64_t capture_us);
  /// Sends one voice packet of this participant's microphone (voice_messages.hpp; capture time on
  /// the server's clock: local wall clock + clock_offset_us()). They queue for the connection, none
  /// replacing another (session_port.hpp kQueuedStreamKey: up to kMaxQueuedPerStream while it is
  /// full, then the oldest is dropped; else up to kMaxHeldPerStream). Ignored until joined.
  /// Thread-safe.
  void send_voice(const session::VoicePacketView& packet);
  /// Tells the others whether this participant's microphone is muted (0x0f). Thread-safe.
  void set_muted(bool muted);
  /// Called with every voice packet received (0x4e: from `participant`, 1 = the OR site), on the
  /// client's receiving thread, the packet's bytes valid during the call: it must only queue
  /// them. Null: voices are ignored. Set it before receiving starts or from that thread.
  using VoiceHandler =
      std::function<void(uint32_t participant, const session::VoicePacketView& packet)>;
  void set_voice_handler(VoiceHandler handler);
  /// Called with every drawing message received -- `type` 0x51 Annotation or 0x52 Erased
  /// (annotations.hpp), its `payload` exactly as the server sent it (after the header), valid
  /// during the call -- on the client's receiving thread, after snapshot()'s annotations took it
  /// (a malformed one drops the connection first and is never passed on). The annotations the
  /// session holds when this participant joins arrive so too, as the server sends them on
  /// joining. It must only queue them (`volcast record --session` records them). Null: not
  /// called. Set it before receiving starts or from that thread.
  using DrawingHandler = std::function<void(uint8_t type, std::span<const uint8_t> payload)>;
  void set_drawing_handler(DrawingHandler handler);
  /// Sends a Heartbeat (presence while no pose is published).
  void heartbeat();
  void list_sessions();
  /// Leaves the session (stays connected, back in the lobby).
  void leave();
  /// Joins `session` (after leave(), or when the first join failed).
  void join(const std::string& session, bool create);

  /// The case shared in the session (null before one arrived).
  std::shared_ptr<const SharedCase> shared_case() const;
  /// Asks to hold object `object` (the server decides; snapshot().objects shows the owner).
  void grab(uint16_t object);
  /// Moves the held object (ignored by the server unless this participant holds it); shown here
  /// at once. room_from_object, metres.
  void move_object(uint16_t object, const Pose& room_from_object);
  /// Lets go of the held object at `room_from_object`.
  void release(uint16_t object, const Pose& room_from_object);
  /// Whether a move or release of `object` still waits to be sent (a newer one replaces it).
  bool object_request_queued(uint16_t object) const;
  /// Sets the monitor for everyone (slice, window, overlay; the generation is filled in).
  /// snapshot().monitor shows this state until the server's matches it or it sends an error (3 s
  /// at most: another participant's came after it), so that changes faster than the round trip
  /// build on each other (a slider dragged, keys pressed in a row) instead of on the older state.
  void set_monitor(const MonitorState& state);

  /// Shows (`on`) or puts away this participant's laser pointer: a ray from `origin` that meets
  /// a surface at `hit` (when has_hit; else it points through `hit`), room frame, metres: the
  /// caller finds the hit against what it shows (reconstruct/ray_hit.hpp for the live clouds).
  /// Sent at most at the server's pointer rate (150 a second: a faster caller's extra ones are
  /// skipped; putting it away is always sent). Ignored until joined. Thread-safe.
  void point(bool on, const Eigen::Vector3f& origin, bool has_hit, const Eigen::Vector3f& hit);
  /// Draws `a` (annotations.hpp; kind, anchor, points in the room frame, text; its tag, id,
  /// author and time are filled in) for the whole session; returns its tag, which the server's
  /// copy in snapshot().annotations carries once it arrived. A monitor anchor's generation is
  /// filled in from the case. Throws Error, sending nothing, for what the server would drop the
  /// sender for (point counts, non-finite points) and a label text it would refuse; the session's
  /// limits (annotations.hpp kMaxSessionAnnotations, their points) and a monitor anchor's slice
  /// are the server's to refuse (SessionError 0x43). Ignored (returns 0) until joined.
  /// Thread-safe.
  uint32_t annotate(session::Annotation a);
  /// Asks to erase annotation `id` (the server decides: hub.hpp anyone_erases). Thread-safe.
  void erase(uint32_t id);

  bool joined() const;
  /// The state now; remote poses interpolated for `now_us` (local wall clock).
  SessionSnapshot snapshot(int64_t now_us) const;
  /// The heads now, as snapshot(now_us) has them, into `out`: its vector and names keep their
  /// storage, so that once it has held as many participants (and as long names) nothing is
  /// allocated (the voice loop calls it every 20 ms).
  void voice_scene(int64_t now_us, VoiceScene& out) const;
  /// Participant `id`'s newest avatar frame, decoded (once per frame); null when there is none.
  /// Throws Error if it does not decode.
  std::shared_ptr<const CameraFrame> avatar_frame(uint32_t id);
  /// The own camera's last uploaded frame (null before any).
  std::shared_ptr<const CameraFrame> own_frame() const;
  /// The own camera's calibration placed in the room (room_from_playarea(spot) *
  /// playarea_from_camera); absent without a camera.
  std::optional<CameraCalibration> own_camera() const;
  ParticipantStats stats() const;
  /// Each server message type a participant handles, with the feature whose routes handle it
  /// (message_table.hpp), in the features' order: for checks against the message table.
  static std::vector<std::pair<session::Type, session::Feature>> handled_types();
  /// Server clock minus local clock, microseconds.
  int64_t clock_offset_us() const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast
