#pragma once
// A virtual-OR session for tests: the real hands site (hands_site.hpp) served with a SessionHub,
// and participants, each with its own connection, a thread receiving on it (session messages
// arrive there) and a SessionClient publishing its pose script (and camera).
#include <gtest/gtest.h>

#include <atomic>
#include <cmath>
#include <memory>
#include <optional>
#include <string>
#include <thread>

#include "support/hands_site.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/session_client.hpp"
#include "volcast/session/hub.hpp"

namespace volcast::test {

/// `c` for a test that is not about presence: the hub holds a participant however long a loaded
/// machine keeps its heartbeats from arriving (a window or headset drawing a blended frame under
/// llvmpipe takes seconds there; the presence timeout has tests of its own).
inline SessionHubConfig patient_hub(SessionHubConfig c = {}) {
  c.presence_timeout_ms = 120000;
  return c;
}

struct SessionSite {
  SessionHub hub;
  HandsSite site;
  /// `server`: further server settings (e.g. web_root); its session is set here.
  explicit SessionSite(SessionHubConfig config = {}, double fps = 15, ServerConfig server = {})
      : hub(std::move(config)), site(fps, with_hub(hub, std::move(server))) {
    hub.attach(&site.server);
    hub.create_session("OR");
  }
  ~SessionSite() { hub.attach(nullptr); }
  static ServerConfig with_hub(SessionHub& hub, ServerConfig c = {}) {
    c.session = &hub;
    return c;
  }
  std::string link() const { return site.server.join_link("127.0.0.1"); }
  /// A receive-only client: the site's frames are read and acknowledged, the session is tested.
  ClientConfig client_config() const {
    ClientConfig c = client_config_from_link(link());
    c.decode = false;
    c.receive_timeout_ms = 20000;
    return c;
  }
};

struct TestParticipant {
  std::unique_ptr<Client> client;
  std::unique_ptr<SessionClient> session;
  std::thread receiver;
  std::atomic<bool> ended{false};
  std::atomic<uint64_t> frame_sets{0};         ///< received from the stream
  std::atomic<int64_t> first_frame_set_us{0};  ///< when the first arrived (local wall clock)
  std::atomic<int64_t> first_capture_us{0};    ///< the first one's capture time (server clock)
  std::atomic<uint64_t> first_sequence{0};     ///< the first one's site sequence
  std::string error;

  TestParticipant(const SessionSite& s, SessionClientOptions options)
      : TestParticipant(s.client_config(), std::move(options)) {}
  TestParticipant(const ClientConfig& config, SessionClientOptions options) {
    client = std::make_unique<Client>(config);
    session = std::make_unique<SessionClient>(std::move(options));
    session->start(*client);
    receiver = std::thread([this] {
      ReceivedFrameSet rx;
      try {
        while (client->receive(rx))
          if (frame_sets++ == 0) {
            first_frame_set_us = wall_clock_us();
            first_capture_us = rx.times.capture_us;
            first_sequence = rx.frames.sequence;
          }
      } catch (const std::exception& e) {
        error = e.what();
      }
      ended = true;
    });
  }
  ~TestParticipant() { end(); }
  /// Leaves as a closed application does: threads stopped, connection closed.
  void end() {
    if (!client) return;
    session->stop();
    client->close();
    receiver.join();
    client.reset();
  }
  Participant& p() { return *session->participant(); }
  SessionSnapshot now() const { return session->participant()->snapshot(wall_clock_us()); }
  /// The participant named `name` as this one sees it now, if it does.
  std::optional<RemoteParticipant> other(const std::string& name) const {
    for (const auto& o : now().others)
      if (o.name == name) return o;
    return std::nullopt;
  }
};

/// Watches, from `observer`, participant `name`'s voice while it is there: whether its packets
/// arrived, and whether it was then seen muted. Polls every 5 ms on a thread of its own until
/// stop() (or destruction).
struct VoiceWatch {
  std::atomic<bool> heard{false}, saw_muted{false};
  VoiceWatch(const TestParticipant& observer, std::string name)
      : thread_([this, &observer, name = std::move(name)] {
          while (!done_) {
            if (const auto o = observer.other(name)) {
              heard = heard || o->voice_packets > 0;
              saw_muted = saw_muted || (heard && o->muted);
            }
            std::this_thread::sleep_for(std::chrono::milliseconds(5));
          }
        }) {}
  ~VoiceWatch() { stop(); }
  void stop() {
    done_ = true;
    if (thread_.joinable()) thread_.join();
  }

 private:
  std::atomic<bool> done_{false};
  std::thread thread_;
};

/// Options joining session `session` as `name`.
inline SessionClientOptions named(const std::string& name, const std::string& session = "OR") {
  SessionClientOptions o;
  o.participant.name = name;
  o.participant.session = session;
  return o;
}

/// Options joining as `name` with heartbeats only: the test moves the objects and the pose by hand.
inline SessionClientOptions hand_driven(const std::string& name) {
  SessionClientOptions o = named(name);
  o.drive_poses = false;
  return o;
}

/// Publishes `p`'s head at `room_position` (room frame, metres), turned `yaw_degrees` about +y
/// from facing -z, as the play-area pose it must publish; the hands with it. Waits first until
/// `p` knows it joined: the hub may tell the others before its own Joined reaches it (a loaded
/// run: C saw B, B's pose was published before B's Joined and skipped), and a participant
/// publishes nothing, and has no spot, before that.
inline void stand(TestParticipant& p, const Eigen::Vector3f& room_position, float yaw_degrees = 0) {
  if (!eventually([&] { return p.now().joined; })) ADD_FAILURE() << "stand: never joined";
  const RigidTransform room_from_playarea = session::room_from_playarea(p.now().spot);
  const RigidTransform playarea_from_room = room_from_playarea.inverse();
  BodyPose body;
  body.head.position = (playarea_from_room * room_position.cast<double>()).cast<float>();
  const Eigen::Matrix3d turn =
      Eigen::AngleAxisd(yaw_degrees * M_PI / 180, Eigen::Vector3d::UnitY()).toRotationMatrix();
  body.head.orientation = Eigen::Quaternionf((playarea_from_room.rotation * turn).cast<float>());
  body.left_hand = body.right_hand = body.head;
  p.p().publish(body);
}

/// A pose 1.35 m up near the table, turned `degrees` about +y (room frame).
inline Pose turned(float degrees) {
  Pose p;
  p.position = {0.1f, 1.35f, 0.05f};
  p.orientation =
      Eigen::Quaternionf(Eigen::AngleAxisf(degrees * float(M_PI) / 180, Eigen::Vector3f::UnitY()));
  return p;
}

/// The same pose as the wire carries it (float32): 1 µm, 1e-4 rad.
inline bool same_pose(const Pose& a, const Pose& b) {
  return a.position.isApprox(b.position, 1e-6f) &&
         a.orientation.angularDistance(b.orientation) < 1e-4f;
}

/// Synthetic (labelled): an object named `name` of one part "shell", a tetrahedron of 10 cm edges
/// (its corner at the object's origin), colour `rgba`, resting at `rest` (room frame, metres).
inline SharedObject tetrahedron(const std::string& name, const Eigen::Vector3f& rest,
                                const Eigen::Vector4f& rgba = {0.6f, 0.2f, 0.1f, 1}) {
  SharedObject o;
  o.name = name;
  o.rest.position = rest;
  SharedPart p;
  p.name = "shell";
  p.rgba = rgba;
  p.positions = {{0, 0, 0}, {0.1f, 0, 0}, {0, 0.1f, 0}, {0, 0, 0.1f}};
  p.normals = {{-1, -1, -1}, {1, 0, 0}, {0, 1, 0}, {0, 0, 1}};
  for (auto& n : p.normals) n.normalize();
  p.indices = {0, 2, 1, 0, 1, 3, 0, 3, 2, 1, 2, 3};
  o.parts.push_back(p);
  return o;
}

}  // namespace volcast::test
