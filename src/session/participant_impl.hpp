#pragma once
// Private to src/session: the state behind a Participant (participant.hpp), shared by what it
// sends (participant.cpp) and what it receives from the server (participant_receive.cpp and
// participant_<feature>.cpp).
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <deque>
#include <map>
#include <mutex>
#include <random>
#include <span>

#include "routes.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/net/stream/session_port.hpp"
#include "volcast/session/participant.hpp"
#include "volcast/session/rate_limit.hpp"

namespace volcast {
namespace participant_detail {

using session::Type;

inline constexpr size_t kPoseHistory = 32;
inline constexpr size_t kMaxSamples = 1 << 16;

inline uint64_t pose_key() {
  return 1;
}
inline uint64_t avatar_key() {
  return 2;
}
inline uint64_t pointer_key() {
  return 4;
}
inline uint64_t voice_key() {  // packets queue up (session_port.hpp), none replaces another
  return kQueuedStreamKey | 5;
}

inline int64_t steady_us() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

inline double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * double(v.size() - 1) + 0.5));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

inline void add_sample(std::vector<double>& v, double x) {
  if (v.size() < kMaxSamples) v.push_back(x);
}

inline BodyPose to_room(const RigidTransform& room_from_playarea, const BodyPose& b) {
  const Eigen::Matrix3f r = room_from_playarea.rotation.cast<float>();
  const Eigen::Vector3f t = room_from_playarea.translation.cast<float>();
  const Eigen::Quaternionf q(r);
  const auto one = [&](const Pose& p) {
    return Pose{r * p.position + t, (q * p.orientation).normalized()};
  };
  return {one(b.head), one(b.left_hand), one(b.right_hand), b.hands_tracked};
}

// The pose at `at` (server clock) from time-stamped poses, oldest first: interpolated between
// the two around it; before the first or after the newest, that one (no guessing).
template <typename T>
T pose_at(const std::deque<std::pair<int64_t, T>>& q, int64_t at) {
  T p = q.back().second;
  if (at <= q.front().first) p = q.front().second;
  for (size_t i = 1; i < q.size(); ++i)
    if (q[i - 1].first <= at && at < q[i].first) {
      const float t = float(at - q[i - 1].first) / float(q[i].first - q[i - 1].first);
      return interpolate(q[i - 1].second, q[i].second, t);
    }
  return p;
}

}  // namespace participant_detail

using namespace participant_detail;

struct Participant::Impl {
  std::mutex client_mutex;  // the client pointer, swapped by reattach()
  Client* client;
  ParticipantConfig config;
  std::atomic<int64_t> offset_us{0};
  std::array<uint64_t, 2> rejoin_key{};  // drawn once (messages.hpp Join); sent on every Join
  std::unique_ptr<DepthEncoder> depth_encoder;
  std::unique_ptr<ColorEncoder> color_encoder;
  std::vector<uint8_t> depth_bytes, color_bytes;
  std::mutex upload_mutex;  // the encoders and their buffers

  mutable std::mutex mutex;  // everything below
  SessionSnapshot state;
  uint32_t pose_sequence = 0;
  session::RateLimiter pose_pace;  // the server's pose limit, kept here (a faster display)
  uint64_t avatar_sequence = 0;
  std::map<uint32_t, int64_t> pose_sent_us;  // sequence -> local steady time, echoes pending
  std::vector<double> round_trips_ms;
  uint64_t poses_sent = 0, avatar_frames_sent = 0;
  std::atomic<uint64_t> voice_sent{0};
  std::shared_ptr<const CameraFrame> own;
  std::mutex voice_mutex;  // the handlers (taken on the receiving thread without `mutex`)
  VoiceHandler voice_handler;
  DrawingHandler drawing_handler;

  struct Remote {
    RemoteParticipant info;
    std::deque<std::pair<int64_t, BodyPose>> poses;  // (server time, room pose), oldest first
    int64_t first_pose_rx_us = 0, last_pose_rx_us = 0;
    uint64_t poses_received = 0;
    std::vector<double> pose_ages_ms, avatar_latencies_ms;
    std::vector<double> pointer_ages_ms;  // server clock: sent -> received
    uint64_t pointers_received = 0;
    std::optional<session::AvatarCamera> camera;
    std::shared_ptr<const std::vector<uint8_t>> avatar_payload;  // newest AvatarFrame payload
    int64_t first_avatar_rx_us = 0, last_avatar_rx_us = 0;
    uint64_t avatars_received = 0;
    // Decoding, on whoever asks (guarded by decode_mutex).
    std::unique_ptr<DepthDecoder> depth_decoder;
    std::unique_ptr<ColorDecoder> color_decoder;
    uint64_t decoded_sequence = 0;
    std::shared_ptr<const CameraFrame> decoded;
  };
  std::shared_ptr<const SharedCase> shared_case;
  struct Track {
    session::ObjectState newest;
    std::deque<std::pair<int64_t, Pose>> poses;  // (server time, room_from_object), oldest first
    Pose own;                                    // where this participant last moved it
  };
  std::vector<Track> objects;
  std::optional<MonitorState> monitor;  // the server's newest
  // What set_monitor sent and when (steady_us), until the server's state matches it or it sends
  // an error: snapshot() shows it meanwhile (kMonitorWaitUs at most), so that changes faster than
  // the round trip build on each other instead of on the server's older state.
  std::optional<std::pair<MonitorState, int64_t>> monitor_sent;
  static constexpr int64_t kMonitorWaitUs = 3'000'000;
  std::map<uint32_t, PointerView> pointers;                // held now, by owner (own included)
  uint32_t pointer_sequence = 0;                           // own pointer messages sent
  std::map<uint32_t, session::PointerMessage> pointer_in;  // the newest received, by owner
  std::map<uint32_t, session::Annotation> annotations;     // by id
  uint32_t annotation_tag = 0;
  std::map<uint32_t, std::shared_ptr<Remote>> remotes;
  std::map<uint32_t, std::shared_ptr<Remote>> gone;  // those who left, for stats()
  std::mutex decode_mutex;

  Impl(Client& c, ParticipantConfig cfg) : client(&c), config(std::move(cfg)) {
    std::random_device random;  // the kernel's getrandom(): unguessable by the others
    for (uint64_t& k : rejoin_key) k = (uint64_t{random()} << 32) | random();
    if (rejoin_key == std::array<uint64_t, 2>{}) rejoin_key[0] = 1;
  }

  int64_t server_now() const { return wall_clock_us() + offset_us; }

  std::atomic<bool> detached{false};

  void post(Type type, std::span<const uint8_t> payload, uint64_t key = 0) {
    std::lock_guard lock(client_mutex);
    if (!detached) client->post_session(session::message(type, payload), key);
  }

  // What the server sends: one handler per message type, in the file of its feature
  // (message_table.hpp's Feature): presence in participant_receive.cpp, the others in
  // participant_<feature>.cpp. handle() dispatches through the features' routes (route()); a
  // `locked` handler runs under `mutex`, the others take it themselves (a case is megabytes,
  // parsed before, so that snapshots, every frame, do not wait; voice and drawing go on to
  // their handlers outside it). `now_server`: the server's wall clock when it arrived (µs).
  using Payload = std::span<const uint8_t>;
  struct Route {
    Type type;
    void (Impl::*handle)(Payload p, int64_t now_server);
    bool locked = true;
  };
  static const Route* route(uint8_t type);
  static std::span<const session::FeatureRoutes<Route>> features();  // every feature's routes
  static std::span<const Route> presence_routes();
  static std::span<const Route> avatar_routes();
  static std::span<const Route> voice_routes();
  static std::span<const Route> drawing_routes();
  static std::span<const Route> object_routes();
  void handle(uint8_t type, Payload p);
  // presence (participant_receive.cpp)
  void on_session_list(Payload p, int64_t now_server);
  void on_joined(Payload p, int64_t now_server);
  void on_session_error(Payload p, int64_t now_server);
  void on_participant_joined(Payload p, int64_t now_server);
  void on_left(Payload p, int64_t now_server);
  void on_pose(Payload p, int64_t now_server);
  void on_pose_echo(Payload p, int64_t now_server);
  void on_teleported(Payload p, int64_t now_server);
  void on_recording_state(Payload p, int64_t now_server);
  // avatars (participant_avatars.cpp)
  void on_avatar_camera(Payload p, int64_t now_server);
  void on_avatar_frame(Payload p, int64_t now_server);
  // voice (participant_voice.cpp)
  void on_voice(Payload p, int64_t now_server);
  void on_voice_state(Payload p, int64_t now_server);
  // drawing (participant_drawing.cpp)
  void on_pointer(Payload p, int64_t now_server);
  void on_annotation(Payload p, int64_t now_server);
  void on_erased(Payload p, int64_t now_server);
  // objects (participant_objects.cpp)
  void on_case(Payload p, int64_t now_server);
  void on_object_state(Payload p, int64_t now_server);
  void on_monitor_state(Payload p, int64_t now_server);

  // The queue's key of `object`'s moves and release: the newest replaces one still queued.
  static uint64_t object_key(uint16_t object) { return (uint64_t{3} << 32) | object; }

  // A move or release of `object` at `pose` (shown here at once), coalesced per object.
  void post_object(Type type, uint16_t object, const Pose& pose) {
    session::ObjectRequest q{0, object, pose};
    {
      std::lock_guard lock(mutex);
      if (!shared_case || object >= objects.size()) return;
      q.generation = shared_case->generation;
      objects[object].own = pose;
    }
    post(type, session::serialize(q, true), object_key(object));
  }

  void send_join(const std::string& name, bool create) {
    session::Join j;
    j.session = name;
    j.create = create;
    j.name = config.name;
    j.role = session::Role::kRemote;  // the only role a Join may ask for (hub.hpp)
    j.has_camera = config.camera.has_value();
    j.rejoin_key = rejoin_key;
    post(Type::kJoin, session::serialize(j));
  }
};

}  // namespace volcast
