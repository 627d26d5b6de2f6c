// volcast demo: the session's scripted people -- Dr. Hands (a camera avatar), Dr. Mesh (a mesh
// avatar who teleports, points and draws on the live site) and the OR's wall display -- and where
// Dr. Mesh draws (volcast/demo/participants.hpp).
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <optional>

#include "demo_voice.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/demo/participants.hpp"
#include "volcast/io/site_config.hpp"
#include "volcast/pipeline/live_surfaces.hpp"
#include "volcast/pipeline/or_display.hpp"
#include "volcast/pipeline/session_scene.hpp"

namespace volcast::demo {
namespace fs = std::filesystem;
namespace {

// The right hand of the one who points and draws, held still there (play area frame, metres).
constexpr float kDrawingHand[3] = {0.25f, 1.1f, -0.35f};

// A remote participant's script (play area frame): standing at its spot, looking ahead and a
// little down, with its head and hands moving; `turn_deg` turns its gaze over the run.
PoseScript demo_script(float turn_deg, bool teleport) {
  PoseScript s;
  for (int i = 0; i <= 4; ++i) {
    PoseKey k;
    k.t_s = i * 1.0;
    const float w = (i % 2 ? 1.0f : -1.0f);
    k.head = {0.05f * w, 1.65f, 0.03f * w};
    k.yaw_deg = turn_deg * float(i) / 4.0f;
    k.pitch_deg = -15;
    k.hands = true;
    k.left = {-0.25f, 1.1f + 0.05f * w, -0.35f};
    // The right hand held still by the one who points and draws (its rays start there).
    k.right = {kDrawingHand[0], kDrawingHand[1] - (teleport ? 0 : 0.05f * w), kDrawingHand[2]};
    s.keys.push_back(k);
  }
  s.loop = false;
  // Across the table, between the liver over it and the wall monitor (both in view).
  if (teleport) s.teleports.push_back({2.0, kMeshSpot});
  return s;
}

}  // namespace

Eigen::Vector3f drawing_hand() {
  const Eigen::Vector3f hand(kDrawingHand[0], kDrawingHand[1], kDrawingHand[2]);
  return (session::room_from_playarea(kMeshSpot) * hand.cast<double>()).cast<float>();
}

DrawingSpot find_drawing_spot(const std::vector<SiteCamera>& site, const fs::path& config,
                              const RigidTransform& room_from_site, const Eigen::Vector3f& hand) {
  std::vector<CameraCalibration> calibrations;
  std::vector<std::shared_ptr<const CameraFrame>> frames;
  for (const SiteCamera& cam : site) {
    SourceOptions o;
    if (cam.intrinsics) o.intrinsics = *cam.intrinsics;
    o.world_from_camera = cam.world_from_camera;
    auto source = open_source(resolve_site_source(cam.source, config), o);
    calibrations.push_back(source->calibration());
    frames.push_back(std::make_shared<const CameraFrame>(source->next()));
  }
  LiveSurfaces surfaces;
  surfaces.update(calibrations, frames, room_from_site);
  const CameraCalibration& c = calibrations.at(0);
  const DepthImage& d = frames.at(0)->depth;
  const RigidTransform room_from_camera = room_from_site * c.world_from_camera;
  // Camera 0's measured point at pixel (u, v), room frame; none where it measured nothing.
  const auto point_at = [&](int u, int v) -> std::optional<Eigen::Vector3f> {
    if (u < 0 || v < 0 || u >= d.width || v >= d.height || d.at(u, v) == 0) return std::nullopt;
    const auto xy = unproject_pixel(c.depth, Eigen::Vector2d(u, v));
    if (!xy) return std::nullopt;
    const double z = d.at(u, v) / 1000.0;
    return (room_from_camera * Eigen::Vector3d(xy->x() * z, xy->y() * z, z)).cast<float>();
  };
  const Eigen::Vector3f eye = room_from_camera.translation.cast<float>();
  const Eigen::Vector3f image_right =
      (room_from_camera.rotation * Eigen::Vector3d::UnitX()).cast<float>();
  const Eigen::Vector3f image_up =
      (room_from_camera.rotation * -Eigen::Vector3d::UnitY()).cast<float>();
  // Candidates every 8 pixels, nearest the image's centre first; those within 3 m of the camera
  // (where a team would look: the table, not the far wall) before the rest.
  std::vector<std::pair<double, Eigen::Vector2i>> candidates;
  for (int v = 0; v < d.height; v += 8)
    for (int u = 0; u < d.width; u += 8)
      if (d.at(u, v) != 0)
        candidates.push_back(
            {std::hypot(u - d.width / 2.0, v - d.height / 2.0) + (d.at(u, v) > 3000 ? 1e6 : 0),
             {u, v}});
  std::sort(candidates.begin(), candidates.end(),
            [](const auto& x, const auto& y) { return x.first < y.first; });
  for (const auto& [distance, uv] : candidates) {
    const auto p = point_at(uv.x(), uv.y());
    // The surface's normal from its neighbours 6 pixels away (a plane of 4 cm or more).
    const auto l = point_at(uv.x() - 6, uv.y()), r = point_at(uv.x() + 6, uv.y());
    const auto t = point_at(uv.x(), uv.y() - 6), b = point_at(uv.x(), uv.y() + 6);
    if (!p || !l || !r || !t || !b) continue;
    Eigen::Vector3f n = (*r - *l).cross(*b - *t);
    if (n.norm() < 1e-6f) continue;
    n.normalize();
    if (n.dot(eye - *p) < 0) n = -n;  // towards camera 0
    const auto facing = [&](const Eigen::Vector3f& from) {
      return n.dot((from - *p).normalized()) > 0.5f;  // within 60 degrees
    };
    if (!facing(eye) || !facing(hand)) continue;
    const auto met = surfaces.hit(hand, *p - hand);
    if (met && (*met - *p).norm() < 0.03f) {
      DrawingSpot s;
      s.at = *p;
      s.right = (image_right - n * n.dot(image_right)).normalized();
      s.up = n.cross(s.right).normalized();
      if (s.up.dot(image_up) < 0) s.up = -s.up;  // up the picture
      // Every point of the drawing is on that surface as the hand sees it, and the middle
      // between a stroke's points too: a circle over an edge, or a ray grazing another camera's
      // surface, would meet something else and streak across the picture.
      bool whole = true;
      for (const ScriptedDrawing& step : drawing_at(s)) {
        std::vector<Eigen::Vector3f> on = step.points;
        for (size_t i = 1; i < step.points.size(); ++i)
          on.push_back((step.points[i - 1] + step.points[i]) / 2);
        for (const Eigen::Vector3f& q : on) {
          const auto at = surfaces.hit(hand, q - hand);
          whole = whole && at && (*at - q).norm() < 0.03f;
        }
      }
      if (!whole) continue;
      spdlog::info(
          "demo: Dr. Mesh draws at camera 0's pixel ({}, {}), {:.2f} m from its hand, on a surface "
          "facing both",
          uv.x(), uv.y(), (*p - hand).norm());
      return s;
    }
  }
  throw Error("demo: no surface near camera 0's image centre is in view of Dr. Mesh's hand");
}

std::vector<ScriptedDrawing> drawing_at(const DrawingSpot& spot) {
  using Kind = ScriptedDrawing::Kind;
  std::vector<ScriptedDrawing> d;
  d.push_back({Kind::kPoint, 2.6, 1.0, {spot.at}, ""});
  ScriptedDrawing circle{Kind::kStroke, 3.7, 1.6, {}, ""};
  for (int i = 0; i <= 16; ++i) {
    const float a = float(i) / 16 * 2 * float(M_PI);
    circle.points.push_back(spot.at + 0.12f * (std::cos(a) * spot.right + std::sin(a) * spot.up));
  }
  d.push_back(circle);
  d.push_back(
      {Kind::kArrow, 5.5, 0, {spot.at + 0.4f * spot.right, spot.at + 0.16f * spot.right}, ""});
  d.push_back({Kind::kLabel, 5.7, 0, {spot.at + 0.22f * spot.up}, "cut here"});
  return d;
}

std::vector<std::unique_ptr<Person>> participants(const DemoArgs& a, const fs::path& data,
                                                  const fs::path& out, const std::string& link,
                                                  const Exchange* talk, const DrawingSpot& spot) {
  std::vector<std::unique_ptr<Person>> people;
  for (int i = 0; i < 2; ++i) {
    auto p = std::make_unique<Person>();
    p->name = i == 0 ? "Dr. Hands (camera)" : "Dr. Mesh";
    p->file = i == 0 ? "session_camera_avatar" : "session_mesh_avatar";
    SessionClientOptions o;
    o.participant.session = "OR";
    o.participant.name = p->name;
    o.script = demo_script(i == 0 ? -35 : 10, i == 1);
    if (i == 0)  // takes the liver and turns it 150 degrees
      o.script.grabs.push_back({1.0, 2.5, "liver", 60});
    else  // the next slice in the liver window, the overlay on; then points and draws
      o.script.monitor.push_back(
          {0.8, 2, window_preset("liver").center, window_preset("liver").width, true});
    if (i == 1) o.script.drawing = drawing_at(spot);
    auto surfaces = std::make_shared<LiveSurfaces>();
    o.surfaces = surfaces;
    if (i == 0) {
      o.camera_source = data / kHandsSet;
      o.camera_options.intrinsics = Intrinsics{0, 0, 460, 460, 320, 180};
    }
    p->session = std::make_unique<SessionClient>(std::move(o));
    SessionClient* client = p->session.get();
    ViewerOptions& v = p->opt;
    v.client = client_config_from_link(link);
    // Long enough for the spoken exchange's last line.
    v.seconds = talk ? std::max(a.session_seconds, 12.0) : a.session_seconds;
    v.width = 1280;
    v.height = 720;
    v.screenshot = out / (p->file + ".png");
    v.stats_json = out / (p->file + ".json");
    v.stop = a.stop;
    Person* raw = p.get();
    std::optional<voice::VoiceConfig> talking;
    if (talk) talking = participant_voice(*talk, p->file);
    v.reconnect = true;  // after a cut it rejoins as itself (live_in_viewer)
    ParticipantLife life;
    life.session_name = "OR";
    life.joined = [raw, talking](SessionClient& c) {
      if (talking) raw->voice = std::make_unique<voice::VoiceLink>(*c.participant(), *talking);
    };
    life.leaving = [raw](SessionClient&, ViewerResult&) {
      if (!raw->voice) return;
      raw->voice->stop();
      raw->heard = raw->voice->stats();
      raw->voice.reset();
    };
    live_in_viewer(*client, v, std::move(life));
    v.presenter = session_presenter(
        v, [client] { return client->participant(); }, {}, 2, surfaces);
    people.push_back(std::move(p));
  }
  return people;
}

std::unique_ptr<Person> or_display(const DemoArgs& a, const fs::path& out, const std::string& link,
                                   double seconds) {
  auto p = std::make_unique<Person>();
  p->name = "OR wall display";
  p->file = "or_display";
  SessionClientOptions o;
  o.participant.session = "OR";
  o.participant.name = p->name;
  o.drive_poses = false;
  p->session = std::make_unique<SessionClient>(std::move(o));
  SessionClient* client = p->session.get();
  ViewerOptions& v = p->opt;
  v.client = client_config_from_link(link);
  v.seconds = seconds;
  v.screenshot = out / "or_display.png";
  v.stats_json = out / "or_display.json";
  v.stop = a.stop;
  v.reconnect = true;
  live_in_viewer(*client, v, {"OR", {}, {}});
  v.presenter = or_display_presenter(
      v, 0, [client] { return client->participant(); }, 2);
  return p;
}

std::vector<std::thread> start(const std::vector<std::unique_ptr<Person>>& people) {
  std::vector<std::thread> threads;
  for (const auto& p : people)
    threads.emplace_back([person = p.get()] {
      try {
        person->result = run_viewer(person->opt);
      } catch (const std::exception& e) {
        person->error = e.what();
      }
    });
  return threads;
}

}  // namespace volcast::demo
