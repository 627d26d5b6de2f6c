// volcast demo, second part: a virtual-OR session on loopback. The OR site is the four real Azure
// Kinects of one room, registered from depth alone (volcast calibrate, once; cached), placed in
// the virtual room; two scripted remote participants join it -- one with a camera avatar (the
// real hands sequence), one with a mesh avatar who teleports -- and each writes a screenshot from
// its own eye and its session figures. The patient case is over the table: the liver of
// 3D-IRCADb patient 1 with its tumours and vessels (meshes made from its label volume) and a CT
// with its liver SEG on the wall monitor; Dr. Hands grabs the liver and turns it, Dr. Mesh sets
// the monitor (slice, liver window), then points at the live site and draws on it (a circle, an
// arrow, a label) where its pointer's rays meet the live clouds; the OR's wall display shows
// camera 0's own image with them in it (or_display.png); session_case.json has what the hub and
// each saw, the annotations too.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <nlohmann/json.hpp>
#include <optional>
#include <thread>

#include "demo_voice.hpp"
#include "volcast/assets/case.hpp"
#include "volcast/assets/shared_case.hpp"
#include "volcast/calibrate/site_calibration.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/demo/demo.hpp"
#include "volcast/io/site_config.hpp"
#include "volcast/pipeline/live_surfaces.hpp"
#include "volcast/pipeline/or_display.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/pipeline/session_client.hpp"
#include "volcast/pipeline/session_scene.hpp"
#include "volcast/quality/quality_report.hpp"
#include "volcast/session/hub.hpp"
#include "volcast/voice/voice_report.hpp"

namespace volcast {
namespace fs = std::filesystem;
namespace {

// The registered four-camera site: out/site-4cam.json, made by `volcast calibrate` the first
// time (about a minute) and reused after.
fs::path registered_site(const fs::path& data, const fs::path& out) {
  const fs::path config = out / "site-4cam.json";
  if (fs::exists(config)) {
    spdlog::info("demo: the four cameras' registration from {} (delete it to register again)",
                 config.string());
    return config;
  }
  spdlog::info("demo: registering the four Azure Kinects from depth alone (once; about a minute)");
  CalibrationOptions c;
  c.sources = {(data / kFourKinectSet).string()};
  const int code =
      report_calibration(calibrate_site(c), config, (out / "site-4cam-registration.png").string());
  if (code != 0 || !fs::exists(config))
    throw Error("demo: the four cameras could not be registered (volcast calibrate exit " +
                std::to_string(code) + ")");
  return config;
}

// Where Dr. Mesh teleports: across the table, between the liver over it and the wall monitor.
constexpr session::Spot kMeshSpot{0.9f, -1.8f, 1.9f};

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
    // The right hand held still by the one who points and draws (drawing_spot's rays start there).
    k.right = {0.25f, teleport ? 1.1f : 1.1f - 0.05f * w, -0.35f};
    s.keys.push_back(k);
  }
  s.loop = false;
  // Across the table, between the liver over it and the wall monitor (both in view).
  if (teleport) s.teleports.push_back({2.0, kMeshSpot});
  return s;
}

// Where Dr. Mesh points and draws: a surface camera 0 sees near the middle of its image that Dr.
// Mesh's right hand (at `hand`, room frame) also sees -- the ray from the hand to it meets nothing
// of the four cameras' first frames before it -- and that faces both (its normal within 60 degrees
// of each), with two directions in that surface: `right` (camera 0's image right, laid into it) and
// `up` (across it), so that the drawing lies on the surface as a surgeon's on the patient would,
// and the OR display (camera 0) sees it whole. Room frame, metres.
struct DrawingSpot {
  Eigen::Vector3f at = Eigen::Vector3f::Zero(), right = Eigen::Vector3f::UnitX(),
                  up = Eigen::Vector3f::UnitY();
};

std::vector<ScriptedDrawing> demo_drawing(const DrawingSpot& spot);

DrawingSpot drawing_spot(const std::vector<SiteCamera>& site, const fs::path& config,
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
      for (const ScriptedDrawing& step : demo_drawing(s)) {
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

// Dr. Mesh's pointing and drawing at `spot`: the pointer on it, a circle drawn around it, an
// arrow towards the circle and a label above it.
std::vector<ScriptedDrawing> demo_drawing(const DrawingSpot& spot) {
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

// The liver's rest pose as the hub shares it (to_shared_case places it).
Pose hub_rest_pose(const Case& c) {
  const session::SharedCase shared = to_shared_case(c);
  return shared.objects.empty() ? Pose{} : shared.objects[0].rest;
}

// The demo's case folder: a case.json naming the shared data's files (never copied).
fs::path demo_case(const fs::path& data, const fs::path& out) {
  const fs::path folder = out / "case";
  fs::create_directories(folder);
  const fs::path labels = fs::absolute(data / "medical/ircad01-labelmap/3Dircadb0101Labeled.vti");
  const fs::path ct = fs::absolute(data / "medical/ct-liver-3slices");
  const auto part = [&](const char* name, int mask, bool components) {
    return fmt::format(
        R"(    {{"name": "{}", "labels": "{}", "mask": {}, "value": {}, "components": {}, "group": "liver"}})",
        name, labels.string(), mask, mask, components ? "true" : "false");
  };
  std::ofstream(folder / "case.json")
      << "{\"name\": \"3D-IRCADb patient 1 (liver) + dcmqi CT\",\n \"parts\": [\n"
      << part("liver", 448, false) << ",\n"
      << part("tumour", 2, true) << ",\n"
      << part("portal vein", 16, false) << ",\n"
      << part("hepatic veins", 32, false) << "],\n"
      << fmt::format(R"( "dicom": {{"series": "{}", "seg": "{}"}}}})", ct.string(),
                     (ct / "liver_seg.dcm").string())
      << "\n";
  return folder;
}

// A scripted remote participant of the demo's session: its client, viewer and how it ended.
struct Person {
  std::string name, file;
  std::unique_ptr<SessionClient> session;
  ViewerOptions opt;
  ViewerResult result;
  std::string error;
  std::unique_ptr<voice::VoiceLink> voice;  // with the spoken exchange
  voice::VoiceStats heard;
};

// The two participants joining session "OR" through `link`: Dr. Hands (a camera avatar from the
// hands sequence, who grabs and turns the liver) and Dr. Mesh (a mesh avatar who teleports and
// sets the monitor), each with a screenshot and figures in `out`.
std::vector<std::unique_ptr<Person>> demo_participants(const DemoArgs& a, const fs::path& data,
                                                       const fs::path& out, const std::string& link,
                                                       const std::optional<demo::Exchange>& talk,
                                                       const DrawingSpot& spot) {
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
      o.script.monitor.push_back({0.8, 2, session::window_preset("liver").center,
                                  session::window_preset("liver").width, true});
    if (i == 1) o.script.drawing = demo_drawing(spot);
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
    if (talk) talking = demo::participant_voice(*talk, p->file);
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

// The OR's wall display of camera 0: joins as "OR wall display" (no pose, no avatar) and writes
// or_display.png, the camera's image with the remote participants, pointers and drawing in it.
std::unique_ptr<Person> demo_or_display(const DemoArgs& a, const fs::path& out,
                                        const std::string& link, double seconds) {
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

// What one participant shows now against the hub's state: the liver's pose, the monitor, the
// pointers and the drawing.
struct Agreement {
  bool sees_the_hubs_liver_pose = false;
  int monitor_slice = -1;  // none
  size_t pointers_held = 0, annotations = 0;
};
Agreement agreement(const Participant& part, const std::vector<session::ObjectState>& objects) {
  const SessionSnapshot snap = part.snapshot(wall_clock_us());
  Agreement a;
  a.sees_the_hubs_liver_pose =
      !objects.empty() && !snap.objects.empty() &&
      snap.objects[0].pose.orientation.angularDistance(objects[0].pose.orientation) < 1e-4f &&
      snap.objects[0].pose.position.isApprox(objects[0].pose.position, 1e-5f);
  a.monitor_slice = snap.monitor ? int(snap.monitor->slice) : -1;
  a.pointers_held = snap.pointers.size();
  a.annotations = snap.annotations.size();
  return a;
}

// Why the session cannot end yet ("" once it can): a participant's script is not done, or one
// does not show yet what the hub has (the liver's pose, the monitor, no pointer, every annotation).
std::string not_settled(SessionHub& hub, const std::vector<std::unique_ptr<Person>>& people) {
  const auto objects = hub.objects("OR");
  const auto monitor = hub.monitor("OR");
  const size_t drawn = hub.annotations("OR").size();
  for (const auto& p : people) {
    const Participant* part = p->session->participant();
    if (!part) return p->name + " has not joined";
    if (!p->session->script_done()) return p->name + "'s script is not done";
    const Agreement a = agreement(*part, objects);
    if (!objects.empty() && !a.sees_the_hubs_liver_pose)
      return p->name + " does not show the liver where the hub has it";
    if (monitor && a.monitor_slice != int(monitor->slice))
      return p->name + " does not show the monitor's slice";
    if (a.pointers_held) return p->name + " still shows a pointer";
    if (a.annotations != drawn)
      return fmt::format("{} shows {} of the {} annotations", p->name, a.annotations, drawn);
  }
  // Every script is done, so nobody holds an object any more: one the hub still has held is a
  // release on its way (a loaded machine's queue), which everyone must see arrive.
  for (const auto& o : objects)
    if (o.owner != 0)
      return fmt::format("the hub still has object {} held (its release on its way)", o.object);
  return "";
}

// Ends the viewers (sets `end`) once `min_s` seconds passed and the session settled (not_settled),
// or `max_s` passed, or `stop` was set; run on its own thread beside them. On a loaded machine the
// site's clouds, and so the drawing, come seconds late: the session waits for them rather than end
// with a participant who never saw the drawing.
void end_when_settled(SessionHub& hub, const std::vector<std::unique_ptr<Person>>& people,
                      double min_s, double max_s, const std::atomic<bool>* stop,
                      std::atomic<bool>& end) {
  using clock = std::chrono::steady_clock;
  const auto start = clock::now();
  std::string why = "not started";
  bool said = false;
  while (!(stop && *stop)) {
    const double t = std::chrono::duration<double>(clock::now() - start).count();
    if (t >= min_s) {
      why = not_settled(hub, people);
      if (why.empty()) break;
      if (!said) spdlog::info("demo: the session goes on until it settles: {}", why);
      said = true;
    }
    if (t >= max_s) {
      spdlog::warn("demo: the session ends after {:.0f} s unsettled: {}", max_s, why);
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  end = true;
}

// session_case.json: what the hub and each participant ended with -- one pose for the liver, one
// monitor state.
void write_session_case(const fs::path& file, const Case& patient, SessionHub& hub,
                        const std::vector<std::unique_ptr<Person>>& people) {
  nlohmann::json r;
  r["case"] = patient.name;
  r["load_ms"] = patient.load_ms;
  for (const CasePart& p : patient.parts)
    r["parts"].push_back({{"name", p.name},
                          {"triangles", p.mesh.triangles()},
                          {"volume_ml", p.volume_ml},
                          {"voxel_volume_ml", p.voxel_volume_ml},
                          {"closed", p.closed}});
  const SessionHubStats hs = hub.stats();
  r["hub"] = {{"grabs", hs.grabs},
              {"releases", hs.releases},
              {"object_moves", hs.object_moves},
              {"monitor_changes", hs.monitor_changes}};
  const auto objects = hub.objects("OR");
  const Pose rest = hub_rest_pose(patient);
  if (!objects.empty())
    r["liver"] = {
        {"owner", objects[0].owner},
        {"turned_deg", objects[0].pose.orientation.angularDistance(rest.orientation) * 180 / M_PI}};
  for (const session::Annotation& an : hub.annotations("OR")) {
    nlohmann::json points = nlohmann::json::array();
    for (const Eigen::Vector3f& q : an.points) points.push_back({q.x(), q.y(), q.z()});
    r["annotations"].push_back({{"id", an.id},
                                {"author", an.author},
                                {"kind", session::to_string(an.kind)},
                                {"points_room_m", points},
                                {"text", an.text}});
  }
  r["hub"]["pointers_in"] = hs.pointers_in;
  r["hub"]["annotations"] = hs.annotations;
  if (const auto m = hub.monitor("OR"))
    r["monitor"] = {
        {"slice", m->slice}, {"center", m->center}, {"width", m->width}, {"overlay", m->overlay}};
  for (auto& p : people) {
    const Participant* part = p->session->participant();
    if (!part || objects.empty()) continue;
    const Agreement a = agreement(*part, objects);
    r["participants"].push_back({{"name", p->name},
                                 {"sees_the_hubs_liver_pose", a.sees_the_hubs_liver_pose},
                                 {"monitor_slice", a.monitor_slice},
                                 {"pointers_held", a.pointers_held},
                                 {"annotations", a.annotations}});
  }
  std::ofstream(file) << r.dump(2) << "\n";
}

// The picture, measured: each of the four cameras held out and drawn from the other three, with
// the renderer as it was before issue 38 and as it is now; quality/quality.png shows the worst
// camera (rendered | real | colour error | depth error), before above now.
void write_quality(const fs::path& config, const fs::path& data, const fs::path& out) {
  const QualitySite site = load_quality_site(config, nominal_kinect_color(data));
  std::vector<QualitySetting> settings;
  for (QualitySetting& s : quality_settings())
    if (s.name.find("(before)") != std::string::npos ||
        s.name.find("(default)") != std::string::npos)
      settings.push_back(std::move(s));
  const std::vector<QualityRow> rows = score_settings(site, settings, out / "quality");
  write_quality_json(rows, out / "quality" / "quality.json");
  std::printf(
      "\nThe picture, measured (each camera held out and drawn from the others; volcast "
      "bench --quality compares more settings):\n%s\n  picture: %s\n",
      quality_table(rows).c_str(), (out / "quality" / "quality.png").c_str());
}

}  // namespace

int run_demo_session(const DemoArgs& a, const fs::path& data, const fs::path& out) {
  const fs::path config = registered_site(data, out);
  write_quality(config, data, out);
  std::vector<std::unique_ptr<FrameSource>> sources;
  std::vector<protocol::CameraInfo> cameras;
  const ColorCalibration nominal_color = nominal_kinect_color(data);  // the set recorded none
  for (const SiteCamera& cam : read_site_config(config)) {
    SourceOptions o;
    if (cam.intrinsics) o.intrinsics = *cam.intrinsics;
    o.world_from_camera = cam.world_from_camera;
    o.nominal_color = nominal_color;
    sources.push_back(open_source(resolve_site_source(cam.source, config), o));
  }
  SitePlayer site(std::move(sources), a.session_fps);
  cameras = site.cameras();
  for (size_t i = 0; i < cameras.size(); ++i) cameras[i].description = fmt::format("OR {}", i);
  // The registered room (floor at y = 0, the cameras around its middle) beside the virtual
  // operating table, turned to face it.
  SessionHubConfig hub_config;
  hub_config.site_translation = {2.2f, 0, 0};
  hub_config.site_name = "OR site";
  std::atomic<voice::SiteVoice*> listening{nullptr};  // the OR's loudspeaker, while it plays
  hub_config.site_listener = [&listening](uint32_t id, const session::VoicePacketView& p) {
    if (voice::SiteVoice* v = listening.load()) v->put(id, p);
  };
  SessionHub hub(hub_config);
  hub.create_session("OR");
  spdlog::info("demo: loading the patient case (meshes from the liver's label volume, the CT)");
  const Case patient = load_case(demo_case(data, out));
  hub.set_case(to_shared_case(patient));
  ServerConfig server_config;
  server_config.port = 0;
  server_config.session = &hub;
  // Both participants come from 127.0.0.1, one address, whose own tiers may use half the budget;
  // the default (half the cores, at least 1) leaves the four cameras' volcast/jpeg tier, about
  // 0.5 cores at 30 fps, on the edge of that share on a 2-core machine.
  server_config.tier_cpu_budget = std::max(2.0, double(std::thread::hardware_concurrency()) / 2);
  // Where Dr. Mesh draws, found before the site streams: its ray marching would otherwise starve
  // the site's player, whose frames then come in bursts that make the tier look costlier.
  RigidTransform room_from_site;
  room_from_site.translation = hub_config.site_translation.cast<double>();
  // Dr. Mesh's right hand once it has teleported (demo_script's spot; its keys' right hand).
  const Eigen::Vector3f hand =
      (session::room_from_playarea(kMeshSpot) * Eigen::Vector3d(0.25, 1.1, -0.35)).cast<float>();
  const DrawingSpot spot = drawing_spot(read_site_config(config), config, room_from_site, hand);
  Server server(cameras, server_config);
  hub.attach(&server);
  site.start(server);
  const std::string link = server.join_link("127.0.0.1");
  spdlog::info("demo: session 'OR' with the OR site's {} cameras on 127.0.0.1:{} (TLS)",
               cameras.size(), server.port());

  // The spoken exchange begins 2.5 s after the participants start connecting.
  const std::optional<demo::Exchange> talk = demo::prepare_exchange(out, 2.5);
  std::unique_ptr<voice::SiteVoice> or_voice;
  if (talk) {
    or_voice = demo::site_voice(*talk, hub);
    listening = or_voice.get();
  }
  std::vector<std::unique_ptr<Person>> people = demo_participants(a, data, out, link, talk, spot);
  people.push_back(demo_or_display(a, out, link, people.front()->opt.seconds));
  // At least the script's time (the spoken exchange's, too); then until the session settled, a
  // minute more at most.
  const double min_s = people.front()->opt.seconds, max_s = min_s + 60;
  std::atomic<bool> end{false};
  for (auto& p : people) {
    p->opt.seconds = max_s + 5;  // the controller ends them first
    p->opt.stop = &end;
  }
  std::vector<std::thread> threads;
  for (auto& p : people)
    threads.emplace_back([&p] {
      try {
        p->result = run_viewer(p->opt);
      } catch (const std::exception& e) {
        p->error = e.what();
      }
    });
  std::thread controller([&] { end_when_settled(hub, people, min_s, max_s, a.stop, end); });
  for (auto& t : threads) t.join();
  end = true;  // a viewer that failed early
  controller.join();
  listening = nullptr;
  if (or_voice) or_voice->stop();
  write_session_case(out / "session_case.json", patient, hub, people);
  site.stop();
  hub.attach(nullptr);
  server.stop();
  std::printf(
      "\nvirtual OR session 'OR': the OR site's %zu registered cameras, 2 participants and the "
      "OR's wall display; Dr. Mesh pointed and drew %zu annotations on the live site\n",
      cameras.size(), hub.annotations("OR").size());
  std::printf(
      "case '%s': %zu parts, loaded in %.0f ms; the liver grabbed, turned and released; "
      "the monitor set (%s)\n",
      patient.name.c_str(), patient.parts.size(), patient.load_ms,
      (out / "session_case.json").c_str());
  for (auto& p : people) {
    if (!p->error.empty()) throw Error("demo participant '" + p->name + "': " + p->error);
    std::printf("\n%s:\n%s", p->name.c_str(), format_stats_table(p->result).c_str());
    const bool wall = p->file == "or_display";
    std::printf(
        "wrote %s (%s) and %s\n", p->opt.screenshot.c_str(),
        wall ? "camera 0's image with the remote participants and their drawing" : "its eye",
        p->opt.stats_json.c_str());
    if (talk && !wall) {
      const fs::path heard = talk->dir / ("heard_" + p->file);
      voice::report_voice(p->heard, heard.string() + ".json");
      std::printf("wrote %s.wav (what it heard, HRTF) and %s.json\n", heard.c_str(), heard.c_str());
    }
  }
  if (or_voice) {
    std::map<uint32_t, std::string> names;  // who the participants heard: every remote speaker
    for (const auto& p : people)
      for (const voice::HeardVoice& h : p->heard.heard)
        if (!h.name.empty()) names[h.id] = h.name;
    demo::report_site(*talk, or_voice->stats(), names);
  }
  return 0;
}

}  // namespace volcast
