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
#include "volcast/demo/participants.hpp"
#include "volcast/io/site_config.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/pipeline/session_client.hpp"
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

// The liver's rest pose as the hub shares it (to_shared_case places it).
Pose hub_rest_pose(const Case& c) {
  const SharedCase shared = to_shared_case(c);
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
std::string not_settled(SessionHub& hub, const std::vector<std::unique_ptr<demo::Person>>& people) {
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
void end_when_settled(SessionHub& hub, const std::vector<std::unique_ptr<demo::Person>>& people,
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
                        const std::vector<std::unique_ptr<demo::Person>>& people) {
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
  const demo::DrawingSpot spot = demo::find_drawing_spot(read_site_config(config), config,
                                                         room_from_site, demo::drawing_hand());
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
  std::vector<std::unique_ptr<demo::Person>> people =
      demo::participants(a, data, out, link, talk ? &*talk : nullptr, spot);
  people.push_back(demo::or_display(a, out, link, people.front()->opt.seconds));
  // At least the script's time (the spoken exchange's, too); then until the session settled, a
  // minute more at most.
  const double min_s = people.front()->opt.seconds, max_s = min_s + 60;
  std::atomic<bool> end{false};
  for (auto& p : people) {
    p->opt.seconds = max_s + 5;  // the controller ends them first
    p->opt.stop = &end;
  }
  std::vector<std::thread> threads = demo::start(people);
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
