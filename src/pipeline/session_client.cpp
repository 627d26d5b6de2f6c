#include "volcast/pipeline/session_client.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <cmath>

#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/session/rate_limit.hpp"

namespace volcast {

RigidTransform auto_playarea_from_camera(const DepthImage& first) {
  std::vector<uint16_t> valid;
  for (uint16_t d : first.pixels)
    if (d) valid.push_back(d);
  double median_m = 0.8;
  if (!valid.empty()) {
    std::nth_element(valid.begin(), valid.begin() + valid.size() / 2, valid.end());
    median_m = valid[valid.size() / 2] / 1000.0;
  }
  RigidTransform t;
  // Camera axes (x right, y down, z ahead) in the play area (x right, y up, z back): looking
  // along +z at someone who faces -z.
  t.rotation << -1, 0, 0, 0, -1, 0, 0, 0, 1;
  t.translation = {0, 1.3, -0.3 - median_m};
  return t;
}

std::vector<ScriptAction> ScriptedObjects::due(const SharedCase* c, const SessionSnapshot& s,
                                               double t_s, bool move_queued) {
  std::vector<ScriptAction> out;
  if (!c) return out;  // every event waits for the case
  using Kind = ScriptAction::Kind;
  const auto action = [](Kind kind, uint16_t object = 0, const Pose& pose = {}) {
    ScriptAction a;
    a.kind = kind, a.object = object, a.pose = pose;
    return a;
  };
  while (next_monitor_ < script_.monitor.size() && script_.monitor[next_monitor_].t_s <= t_s) {
    if (!c->monitor) {  // no CT series in this case: nothing to set
      next_monitor_ = script_.monitor.size();
      break;
    }
    if (!s.monitor) break;  // its state follows the case: wait for it, then set
    const ScriptedMonitor& m = script_.monitor[next_monitor_++];
    ScriptAction a = action(Kind::kMonitor);
    a.monitor = *s.monitor;
    if (m.slice >= 0)
      a.monitor.slice = static_cast<uint16_t>(std::min(m.slice, c->monitor->slices - 1));
    if (m.center) a.monitor.center = *m.center;
    if (m.width) a.monitor.width = *m.width;
    if (m.overlay) a.monitor.overlay = *m.overlay;
    out.push_back(a);
  }
  if (!holding_ && next_grab_ < script_.grabs.size() && script_.grabs[next_grab_].t_s <= t_s) {
    const ScriptedGrab& g = script_.grabs[next_grab_];
    const auto it = std::find_if(c->objects.begin(), c->objects.end(),
                                 [&](const auto& o) { return o.name == g.object; });
    if (it == c->objects.end()) {
      spdlog::warn("pose script: no object '{}' in the case to grab", g.object);
      ++next_grab_;
      return out;
    }
    const auto i = static_cast<size_t>(it - c->objects.begin());
    if (i >= s.objects.size()) return out;  // the objects' state follows the case: wait
    ++next_grab_;
    object_ = static_cast<uint16_t>(i);
    start_pose_ = s.objects[i].pose;
    grab_ = g;
    grab_.t_s = t_s;  // asked for now, however late that is
    granted_s_.reset();
    steps_ = std::max(1, static_cast<int>(std::lround(grab_.for_s * kMovesPerSecond)));
    moved_ = -1;
    holding_ = true;
    out.push_back(action(Kind::kGrab, object_));
    return out;
  }
  if (!holding_) return out;
  const bool mine = object_ < s.objects.size() && s.objects[object_].owner == s.id;
  // Held from when the server made it ours (on a loaded machine that may be a while after
  // asking); given up if it never does within kGrantWait_s.
  if (mine && !granted_s_) granted_s_ = t_s;
  if (!granted_s_) {
    if (t_s - grab_.t_s >= grab_.for_s + kGrantWait_s) {
      spdlog::warn("pose script: the server did not hand over object {} within {:.0f} s", object_,
                   grab_.for_s + kGrantWait_s);
      holding_ = false;
    }
    return out;
  }
  if (!mine) {  // taken from us (the server ended the hold): nothing more to send
    holding_ = false;
    return out;
  }
  if (move_queued) return out;  // the step before has not left yet: never coalesce two
  const int next = moved_ + 1;  // 0..steps_: a move; steps_ + 1: the release
  // Not yet due (a microsecond's slack for the sum's rounding: 6.1 - 6.0 < 0.1 in doubles).
  if (next <= steps_ && (t_s - *granted_s_) * kMovesPerSecond + 1e-6 < next) return out;
  const auto turned = static_cast<float>(grab_.turn_deg_per_s * grab_.for_s *
                                         std::min(next, steps_) / steps_ * M_PI / 180);
  Pose pose = start_pose_;
  pose.orientation = (Eigen::Quaternionf(Eigen::AngleAxisf(turned, Eigen::Vector3f::UnitY())) *
                      start_pose_.orientation)
                         .normalized();
  if (next > steps_) {
    out.push_back(action(Kind::kRelease, object_, pose));
    holding_ = false;
    return out;
  }
  moved_ = next;
  out.push_back(action(Kind::kMove, object_, pose));
  return out;
}

void ScriptedObjects::step(Participant& p, double t_s) {
  const auto c = p.shared_case();
  const bool queued = holding_ && p.object_request_queued(object_);
  for (const ScriptAction& a : due(c.get(), p.snapshot(wall_clock_us()), t_s, queued)) {
    switch (a.kind) {
      case ScriptAction::Kind::kGrab:
        p.grab(a.object);
        break;
      case ScriptAction::Kind::kMove:
        p.move_object(a.object, a.pose);
        break;
      case ScriptAction::Kind::kRelease:
        p.release(a.object, a.pose);
        break;
      case ScriptAction::Kind::kMonitor:
        p.set_monitor(a.monitor);
        break;
    }
  }
}

SessionClient::SessionClient(SessionClientOptions options) : options_(std::move(options)) {
  const double max_rate = session::limit_of(static_cast<uint8_t>(session::Type::kPose)).per_second;
  if (!(options_.pose_rate_hz > 0 && options_.pose_rate_hz <= max_rate))
    throw Error("session: the pose rate must be in (0, " + std::to_string(std::lround(max_rate)) +
                "] Hz (the server's limit, session/rate_limit.hpp)");
  if (options_.camera_source.empty()) return;
  camera_ = open_source(options_.camera_source, options_.camera_options);
  AvatarCameraSetup setup;
  setup.calibration = camera_->calibration();
  setup.depth_codec = options_.upload_depth_codec;
  setup.color_codec = options_.upload_color_codec;
  if (options_.playarea_from_camera) {
    setup.calibration.world_from_camera = *options_.playarea_from_camera;
  } else {
    CameraFrame first;
    camera_->next(first);
    setup.calibration.world_from_camera = auto_playarea_from_camera(first.depth);
    const auto& t = setup.calibration.world_from_camera.translation;
    spdlog::info(
        "avatar camera {}: not registered to the play area; placed facing you at "
        "({:.2f}, {:.2f}, {:.2f}) m",
        camera_->description(), t.x(), t.y(), t.z());
  }
  options_.participant.camera = setup;
}

SessionClient::~SessionClient() {
  stop();
}

void SessionClient::start(Client& client) {
  participant_ = std::make_unique<Participant>(client, options_.participant);
  poses_ = std::thread([this] { run_poses(); });
  if (camera_) frames_ = std::thread([this] { run_camera(); });
}

void SessionClient::reattach(Client& client) {
  if (participant_) participant_->reattach(client);
}

void SessionClient::stop() {
  if (stopping_.exchange(true)) return;
  if (poses_.joinable()) poses_.join();
  if (frames_.joinable()) frames_.join();
  if (participant_) participant_->detach();
}

void live_in_viewer(SessionClient& client, ViewerOptions& viewer, ParticipantLife life) {
  auto shared = std::make_shared<ParticipantLife>(std::move(life));
  SessionClient* c = &client;
  viewer.on_connected = [c, shared](Client& connection) {
    c->start(connection);
    if (shared->joined && c->participant()) shared->joined(*c);
  };
  viewer.on_reconnected = [c](Client& connection) { c->reattach(connection); };
  viewer.on_finished = [c, shared](ViewerResult& result) {
    if (shared->leaving) shared->leaving(*c, result);
    c->stop();
    if (Participant* p = c->participant()) {
      result.session = p->stats();
      result.session_name = shared->session_name;
    }
  };
}

void SessionClient::run_poses() {
  using clock = std::chrono::steady_clock;
  const auto period = std::chrono::duration_cast<clock::duration>(
      std::chrono::duration<double>(1.0 / options_.pose_rate_hz));
  // The script's clock starts when the session is joined.
  while (!stopping_ && !participant_->joined())
    std::this_thread::sleep_for(std::chrono::milliseconds(2));
  const auto start = clock::now();
  auto next = start;
  size_t teleports = 0;
  if (!options_.drive_poses) script_done_ = true;
  while (!stopping_ && !options_.drive_poses) {  // someone else publishes: presence only
    participant_->heartbeat();
    for (int i = 0; i < 50 && !stopping_; ++i)
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  ScriptedObjects objects(options_.script);
  ScriptedPointing pointing(options_.script, options_.surfaces);
  while (!stopping_) {
    const double t = std::chrono::duration<double>(clock::now() - start).count();
    while (teleports < options_.script.teleports.size() &&
           options_.script.teleports[teleports].t_s <= t)
      participant_->teleport(options_.script.teleports[teleports++].to);
    objects.step(*participant_, t);
    participant_->publish(options_.script.at(t));
    if (!options_.script.drawing.empty())
      pointing.step(*participant_,
                    participant_->snapshot(wall_clock_us()).own_body.right_hand.position, t);
    script_done_ =
        teleports == options_.script.teleports.size() && objects.done() && pointing.done();
    next += period;
    const auto now = clock::now();
    if (next < now) next = now;  // fell behind (a loaded machine): no burst to catch up
    std::this_thread::sleep_until(next);
  }
}

void SessionClient::run_camera() {
  using clock = std::chrono::steady_clock;
  const double fps = std::clamp(camera_->fps(), 1.0, 120.0);
  const auto period =
      std::chrono::duration_cast<clock::duration>(std::chrono::duration<double>(1.0 / fps));
  auto next = clock::now();
  uint64_t failures = 0;
  while (!stopping_) {
    auto frame = std::make_shared<CameraFrame>();
    try {
      camera_->next(*frame);
      const int64_t captured = wall_clock_us();
      participant_->upload(std::move(frame), captured);
    } catch (const Error& e) {
      if (failures++ % 30 == 0) spdlog::warn("avatar camera: frame skipped: {}", e.what());
    }
    next += period;
    const auto now = clock::now();
    if (next < now) next = now;
    std::this_thread::sleep_until(next);
  }
}

}  // namespace volcast
