// Pointers and annotations (annotations.hpp): their messages, the hub's rules (late joiners,
// authors who leave, erasing, limits, hostile input) on a hub without a server, and pointing and
// drawing between participants over the real stream of a real site.
#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <mutex>

#include "support/hub_outlet.hpp"
#include "support/session_site.hpp"
#include "volcast/core/error.hpp"
#include "volcast/pipeline/live_surfaces.hpp"
#include "volcast/session/annotations.hpp"
#include "volcast/session/erase_last.hpp"
#include "volcast/session/message_table.hpp"
#include "volcast/session/pose_script.hpp"

namespace volcast {
namespace {

using namespace std::chrono_literals;
using session::Annotation;
using session::AnnotationAnchor;
using session::AnnotationKind;
using session::Type;
using test::eventually;
using test::join;
using test::Outlet;

// Synthetic (labelled): a stroke of `n` points 1 cm apart along x, 1 m up.
Annotation stroke(size_t n) {
  Annotation a;
  a.kind = AnnotationKind::kStroke;
  for (size_t i = 0; i < n; ++i) a.points.push_back({0.01f * float(i), 1.0f, -0.25f});
  return a;
}

Annotation label(const std::string& text) {
  Annotation a;
  a.kind = AnnotationKind::kLabel;
  a.points = {{0.1f, 1.2f, 0.3f}};
  a.text = text;
  return a;
}

void send(SessionHub& hub, uint64_t viewer, Type type, const std::vector<uint8_t>& payload) {
  hub.on_message(viewer, static_cast<uint8_t>(type), payload);
}

std::vector<Annotation> annotations_sent(Outlet& out, uint64_t viewer) {
  std::vector<Annotation> v;
  for (const auto& p : out.of(viewer, Type::kAnnotation)) v.push_back(session::parse_annotation(p));
  return v;
}

std::string last_error(Outlet& out, uint64_t viewer) {
  const auto e = out.of(viewer, Type::kSessionError);
  return e.empty() ? "" : session::parse_error(e.back());
}

TEST(Annotations, MessagesRoundTripAndRefuseBadFields) {
  session::PointerMessage p{7, 123, true, {1, 1.5f, 2}, true, {0.1f, 1.0f, -0.2f}};
  const session::PointerMessage q = session::parse_pointer(session::serialize(p));
  EXPECT_EQ(q.sequence, 7u);
  EXPECT_EQ(q.time_us, 123);
  EXPECT_TRUE(q.on && q.has_hit);
  EXPECT_EQ(q.origin, p.origin);
  EXPECT_EQ(q.hit, p.hit);
  auto nan = session::serialize(p);
  const float bad = std::nanf("");
  std::memcpy(nan.data() + 13, &bad, 4);  // origin x
  EXPECT_NE(test::error_of([&] { session::parse_pointer(nan); }).find("not finite"),
            std::string::npos);

  Annotation a = stroke(5);
  a.tag = 3;
  a.id = 9;
  a.author = 4;
  a.time_us = 55;
  const Annotation b = session::parse_annotation(session::serialize(a));
  EXPECT_EQ(b.id, 9u);
  EXPECT_EQ(b.author, 4u);
  EXPECT_EQ(b.tag, 3u);
  EXPECT_EQ(b.points, a.points);
  EXPECT_EQ(session::parse_annotate(session::serialize_annotate(a)).points, a.points);
  // Each kind's shape.
  const auto refused = [](const Annotation& x) {
    return test::error_of([&] { session::parse_annotate(session::serialize_annotate(x)); });
  };
  EXPECT_NE(refused(stroke(1)).find("at least 2"), std::string::npos);
  Annotation arrow = stroke(3);
  arrow.kind = AnnotationKind::kArrow;
  EXPECT_NE(refused(arrow).find("2 points"), std::string::npos);
  Annotation texted = stroke(2);
  texted.text = "x";
  EXPECT_NE(refused(texted).find("no text"), std::string::npos);
  Annotation empty = label("x");
  empty.text.clear();
  EXPECT_NE(refused(empty).find("has text"), std::string::npos);
  EXPECT_TRUE(refused(label("cut here")).empty());
  // A count the bytes do not hold is refused before anything is allocated.
  auto lying = session::serialize_annotate(stroke(2));
  const uint16_t many = 200;
  std::memcpy(lying.data() + 4 + 1 + 1 + 4 + 2, &many, 2);
  EXPECT_NE(test::error_of([&] { session::parse_annotate(lying); }).find("more points declared"),
            std::string::npos);
  EXPECT_THROW(session::serialize_annotate(stroke(session::kMaxStrokePoints + 1)), Error);
  // Labels: NFC, no bidi controls or invisible characters, at most 64 bytes.
  EXPECT_EQ(session::check_label_text("Cafe\xcc\x81"), "Caf\xc3\xa9");
  EXPECT_THROW(session::check_label_text("cut \u202ehere"), Error);
  EXPECT_THROW(session::check_label_text(std::string(65, 'x')), Error);
  // The table knows them.
  EXPECT_EQ(session::limit_of(static_cast<uint8_t>(Type::kPointer)).per_second, 150);
  EXPECT_NE(session::find_message(static_cast<uint8_t>(Type::kErased)), nullptr);
}

// On a hub without a server: a stroke reaches everyone (its author too, numbered), a later
// joiner gets it and the pointers held, it stays when its author leaves, anyone erases it.
TEST(Annotations, TheHubKeepsThemForLateJoinersAfterTheirAuthorAndErasesThemForEveryone) {
  SessionHub hub;
  Outlet out;
  hub.attach(&out);
  hub.create_session("OR");
  join(hub, 10, "OR", "A");
  join(hub, 11, "OR", "B");
  Annotation a = stroke(12);
  a.tag = 77;
  send(hub, 10, Type::kAnnotate, session::serialize_annotate(a));
  send(hub, 10, Type::kPointer,
       session::serialize(session::PointerMessage{1, 5, true, {0, 1.6f, 1}, true, {0, 1, 0}}));
  for (uint64_t v : {10, 11}) {
    const auto got = annotations_sent(out, v);
    ASSERT_EQ(got.size(), 1u) << v;
    EXPECT_EQ(got[0].id, 1u);
    EXPECT_EQ(got[0].tag, 77u);
    EXPECT_EQ(got[0].points, a.points);
  }
  EXPECT_EQ(out.of(11, Type::kPointerFrom).size(), 1u);
  EXPECT_EQ(out.of(10, Type::kPointerFrom).size(), 0u);  // not back to its owner
  const uint32_t author = annotations_sent(out, 11)[0].author;
  join(hub, 12, "OR", "C");  // later: gets the stroke and A's pointer
  ASSERT_EQ(annotations_sent(out, 12).size(), 1u);
  EXPECT_EQ(annotations_sent(out, 12)[0].points, a.points);
  ASSERT_EQ(out.of(12, Type::kPointerFrom).size(), 1u);
  EXPECT_EQ(session::split_forwarded(out.of(12, Type::kPointerFrom)[0]).first, author);
  hub.on_viewer_left(10, "closed");  // A goes; its stroke stays
  ASSERT_EQ(hub.annotations("OR").size(), 1u);
  join(hub, 13, "OR", "D");
  EXPECT_EQ(annotations_sent(out, 13).size(), 1u);
  EXPECT_EQ(out.of(13, Type::kPointerFrom).size(), 0u);  // A's pointer went with A
  send(hub, 11, Type::kErase, session::serialize_erase(1));
  for (uint64_t v : {11, 12, 13}) {
    const auto erased = out.of(v, Type::kErased);
    ASSERT_EQ(erased.size(), 1u) << v;
    EXPECT_EQ(session::parse_erased(erased[0]).first, 1u);
  }
  EXPECT_TRUE(hub.annotations("OR").empty());
  send(hub, 11, Type::kErase, session::serialize_erase(1));  // again: told, nothing else
  EXPECT_NE(last_error(out, 11).find("no annotation 1"), std::string::npos);
  EXPECT_EQ(hub.stats().erases, 1u);
}

// "Erase my last" (erase_last.hpp), the window's Backspace and the headset's erase button, on
// snapshots made by hand: a press waits for what this participant sent before it to come back
// numbered, so a quick press after drawing erases what was just drawn, not the one before it.
TEST(Annotations, EraseMyLastWaitsForWhatWasJustDrawnAndErasesOnlyTheOwnNewest) {
  using session::EraseLast;
  SessionSnapshot s;
  s.id = 7;
  auto drawn = [&](uint32_t id, uint32_t author, uint32_t tag) {
    Annotation a;
    a.id = id;
    a.author = author;
    a.tag = tag;
    s.annotations.push_back(a);
  };
  drawn(1, 7, 1);  // mine
  drawn(2, 9, 1);  // someone else's, newer
  EraseLast erase;
  EXPECT_EQ(erase.due(s, 0), std::nullopt) << "no press";
  erase.pressed(10);
  EXPECT_EQ(erase.due(s, 10), 1u) << "the newest of mine, not the other's newer one";
  EXPECT_FALSE(erase.waiting());
  EXPECT_EQ(erase.due(s, 20), std::nullopt) << "one press, one erase";

  // A stroke sent (tag 2), the key pressed before the server numbered it: it waits for it.
  erase.sent(2, 100);
  erase.pressed(150);
  erase.pressed(160);  // the same press
  EXPECT_EQ(erase.due(s, 170), std::nullopt);
  EXPECT_TRUE(erase.waiting());
  drawn(3, 7, 2);
  EXPECT_EQ(erase.due(s, 200), 3u) << "what was just drawn, not annotation 1";
  EXPECT_EQ(erase.due(s, 210), std::nullopt);

  // Something sent after the press does not hold it up.
  erase.pressed(300);
  erase.sent(3, 310);
  EXPECT_EQ(erase.due(s, 320), 3u);

  // One the server refused never comes back: the press waits kWaitUs for it, then erases the
  // newest of mine standing.
  erase.sent(4, 1000);
  erase.pressed(1001);
  EXPECT_EQ(erase.due(s, 1000 + EraseLast::kWaitUs), std::nullopt);
  EXPECT_EQ(erase.due(s, 1001 + EraseLast::kWaitUs), 3u);

  // Nothing of mine standing: the press is done with nothing to erase, and a later drawing is
  // not erased by it.
  s.annotations.erase(s.annotations.begin());  // 1
  s.annotations.pop_back();                    // 3
  erase.pressed(5'000'000);
  EXPECT_EQ(erase.due(s, 5'000'000), std::nullopt);
  EXPECT_FALSE(erase.waiting());
  drawn(5, 7, 5);
  EXPECT_EQ(erase.due(s, 5'000'010), std::nullopt);
  // A tag of 0 (annotate before joining: nothing sent) is not waited for.
  erase.sent(0, 6'000'000);
  erase.pressed(6'000'001);
  EXPECT_EQ(erase.due(s, 6'000'001), 5u);
}

TEST(Annotations, OnlyTheAuthorErasesWhereTheServerSaysSo) {
  SessionHubConfig config;
  config.anyone_erases = false;
  SessionHub hub(config);
  Outlet out;
  hub.attach(&out);
  hub.create_session("OR");
  join(hub, 10, "OR", "A");
  join(hub, 11, "OR", "B");
  send(hub, 10, Type::kAnnotate, session::serialize_annotate(label("here")));
  send(hub, 11, Type::kErase, session::serialize_erase(1));
  EXPECT_NE(last_error(out, 11).find("only its author"), std::string::npos);
  EXPECT_EQ(hub.annotations("OR").size(), 1u);
  send(hub, 10, Type::kErase, session::serialize_erase(1));
  EXPECT_TRUE(hub.annotations("OR").empty());
}

// A flood from 14 participants at once (the most a session has beside the OR site and one more):
// the session keeps at most its limits, each annotation over them refused with a message naming the
// limit; a bad label and a monitor annotation without a monitor are refused the same way; a
// malformed one drops its sender.
TEST(Annotations, FloodsBadLabelsAndStaleAnchorsAreRefusedWithAMessage) {
  SessionHub hub;
  Outlet out;
  hub.attach(&out);
  hub.create_session("OR");
  for (uint64_t v = 10; v < 24; ++v) join(hub, v, "OR", "P" + std::to_string(v));
  const Annotation big = stroke(session::kMaxStrokePoints);
  for (int round = 0; round < 20; ++round)  // each participant's burst (rate_limit: 20 at once)
    for (uint64_t v = 10; v < 24; ++v)
      send(hub, v, Type::kAnnotate, session::serialize_annotate(big));
  const auto kept = hub.annotations("OR");
  size_t points = 0;
  for (const Annotation& a : kept) points += a.points.size();
  EXPECT_EQ(points, session::kMaxSessionAnnotationPoints);
  EXPECT_EQ(kept.size(), session::kMaxSessionAnnotationPoints / session::kMaxStrokePoints);
  EXPECT_EQ(hub.stats().annotations_refused, 280 - kept.size());
  EXPECT_NE(last_error(out, 23).find("limit of 16384"), std::string::npos);
  // Erasing makes room again.
  send(hub, 10, Type::kErase, session::serialize_erase(kept[0].id));
  // (P10's bucket is empty after its burst: a participant who joins now draws.)
  join(hub, 30, "OR", "Q");
  send(hub, 30, Type::kAnnotate, session::serialize_annotate(big));
  EXPECT_EQ(hub.annotations("OR").size(), kept.size());
  EXPECT_EQ(hub.annotations("OR").back().author, annotations_sent(out, 30).back().author);

  send(hub, 30, Type::kAnnotate, session::serialize_annotate(label("Dr. \u202eA")));
  EXPECT_NE(last_error(out, 30).find("annotation refused"), std::string::npos);
  Annotation on_monitor = stroke(2);
  on_monitor.anchor = AnnotationAnchor::kMonitor;
  on_monitor.generation = 1;
  send(hub, 30, Type::kAnnotate, session::serialize_annotate(on_monitor));
  EXPECT_NE(last_error(out, 30).find("no longer shown"), std::string::npos);
  // Malformed (a stroke of one point, written by hand): dropped.
  auto one = session::serialize_annotate(stroke(2));
  one[4 + 1 + 1 + 4 + 2] = 1;
  one.resize(one.size() - 12);
  EXPECT_THROW(send(hub, 30, Type::kAnnotate, one), Error);
}

// Over the real stream of a real site: A draws, B and C (who joins later) receive it exactly, A
// leaves and it stays, B erases it and it is gone for everyone.
TEST(Annotations, ParticipantsDrawForEveryoneAndTheDrawingOutlivesItsAuthor) {
  test::SessionSite s;
  auto a = std::make_unique<test::TestParticipant>(s, test::hand_driven("Mentor"));
  auto b = std::make_unique<test::TestParticipant>(s, test::hand_driven("Surgeon"));
  ASSERT_TRUE(eventually([&] { return b->other("Mentor") && a->now().joined; }, 30s));
  // What B's drawing handler is given (`volcast record --session` records it): each 0x51 and 0x52
  // as the server sent it.
  std::mutex handed_mutex;
  std::vector<std::pair<uint8_t, std::vector<uint8_t>>> handed;
  b->p().set_drawing_handler([&](uint8_t type, std::span<const uint8_t> payload) {
    std::lock_guard lock(handed_mutex);
    handed.emplace_back(type, std::vector<uint8_t>(payload.begin(), payload.end()));
  });
  Annotation drawn = stroke(40);
  drawn.points[7] = {0.123456f, 1.2345678f, -0.3456789f};
  const uint32_t tag = a->p().annotate(drawn);
  EXPECT_GT(tag, 0u);
  EXPECT_THROW(a->p().annotate(label(std::string(65, 'x'))), Error);  // refused before sending
  const auto received = [](test::TestParticipant& p) {
    const auto all = p.now().annotations;
    return all.size() == 1 ? std::optional(all[0]) : std::nullopt;
  };
  ASSERT_TRUE(eventually([&] { return received(*b) && received(*a); }, 30s));
  EXPECT_EQ(received(*b)->points, drawn.points);  // exactly: f32 on the wire
  EXPECT_EQ(received(*a)->tag, tag);
  EXPECT_EQ(received(*b)->author, a->now().id);
  auto c = std::make_unique<test::TestParticipant>(s, test::hand_driven("Anaesthetist"));
  ASSERT_TRUE(eventually([&] { return received(*c).has_value(); }, 30s));
  EXPECT_EQ(received(*c)->points, drawn.points);
  const uint32_t id = received(*c)->id;
  a.reset();  // the author leaves
  ASSERT_TRUE(eventually([&] { return !b->other("Mentor"); }, 30s));
  EXPECT_TRUE(received(*b) && received(*c));
  b->p().erase(id);
  ASSERT_TRUE(eventually([&] { return !received(*b) && !received(*c); }, 30s));
  EXPECT_TRUE(s.hub.annotations("OR").empty());
  b->p().set_drawing_handler(nullptr);
  std::lock_guard lock(handed_mutex);
  ASSERT_EQ(handed.size(), 2u);
  EXPECT_EQ(handed[0].first, 0x51);
  const Annotation got = session::parse_annotation(handed[0].second);
  EXPECT_EQ(got.id, id);
  EXPECT_EQ(got.points, drawn.points);
  EXPECT_EQ(handed[0].second, session::serialize(got));  // the payload itself
  EXPECT_EQ(handed[1].first, 0x52);
  EXPECT_EQ(session::parse_erased(handed[1].second), std::make_pair(id, b->now().id));
}

TEST(Annotations, APoseScriptsDrawingParsesAndItsMistakesAreNamed) {
  const std::string keys = R"("keys": [{"t": 0, "head": [0, 1.6, 0]}])";
  const PoseScript s = parse_pose_script("{" + keys + R"(, "drawing": [
      {"t": 1, "kind": "point", "for_s": 0.5, "at": [0, 1, -1]},
      {"t": 2, "kind": "stroke", "for_s": 1, "path": [[0, 1, -1], [0.1, 1, -1], [0.1, 1.1, -1]]},
      {"t": 3, "kind": "arrow", "from": [0.3, 1, -1], "to": [0.1, 1, -1]},
      {"t": 3, "kind": "label", "at": [0, 1.2, -1], "text": "Cafe\u0301"}]})");
  ASSERT_EQ(s.drawing.size(), 4u);
  EXPECT_EQ(s.drawing[0].kind, ScriptedDrawing::Kind::kPoint);
  EXPECT_EQ(s.drawing[0].for_s, 0.5);
  EXPECT_EQ(s.drawing[1].points.size(), 3u);
  EXPECT_EQ(s.drawing[2].points[1], Eigen::Vector3f(0.1f, 1, -1));
  EXPECT_EQ(s.drawing[3].text, "Caf\xc3\xa9");  // NFC, as the server keeps it
  const auto error = [&](const std::string& drawing) {
    return test::error_of(
        [&] { parse_pose_script("{" + keys + R"(, "drawing": [)" + drawing + "]}"); });
  };
  EXPECT_NE(error(R"({"t": 1, "kind": "circle"})").find("none of point"), std::string::npos);
  EXPECT_NE(error(R"({"t": 1, "kind": "stroke", "path": [[0, 1, 0]]})").find("2 to 256"),
            std::string::npos);
  EXPECT_NE(
      error(R"({"t": 1, "kind": "label", "at": [0, 1, 0], "text": "a\u202eb"})").find("label"),
      std::string::npos);
  EXPECT_NE(
      error(
          R"({"t": 2, "kind": "point", "at": [0, 1, 0]}, {"t": 1, "kind": "point", "at": [0, 1, 0]})")
          .find("time order"),
      std::string::npos);
}

// A stroke at 0.3 s for 0.6 s across the camera's view of its middle, 40 cm ahead of it, and a
// label at 1.0 s below it (room frame = site frame here).
std::vector<ScriptedDrawing> stroke_and_label(const RigidTransform& site_from_camera) {
  const auto ahead = [&](double x, double y) -> Eigen::Vector3f {
    return (site_from_camera * Eigen::Vector3d(x, y, 0.4)).cast<float>();
  };
  ScriptedDrawing stroke{ScriptedDrawing::Kind::kStroke, 0.3, 0.6, {}, ""};
  for (int i = 0; i <= 8; ++i) stroke.points.push_back(ahead(-0.08 + 0.02 * i, 0.02));
  return {stroke, {ScriptedDrawing::Kind::kLabel, 1.0, 0, {ahead(0, -0.03)}, "here"}};
}

// `drawn` is that stroke (4 points at least) and label, in order, each point where the camera
// measured the live cloud (within 2 cm along its ray).
void expect_stroke_and_label_on(const std::vector<Annotation>& drawn,
                                const CameraCalibration& camera, const CameraFrame& frame) {
  ASSERT_EQ(drawn.size(), 2u);
  EXPECT_EQ(drawn[0].kind, AnnotationKind::kStroke);
  EXPECT_GE(drawn[0].points.size(), 4u);
  EXPECT_EQ(drawn[1].text, "here");
  const RigidTransform camera_from_site = camera.world_from_camera.inverse();
  for (const Annotation& a : drawn)
    for (const Eigen::Vector3f& p : a.points) {
      const Eigen::Vector3d q = camera_from_site * p.cast<double>();
      const auto uv = project_normalized(camera.depth, {q.x() / q.z(), q.y() / q.z()});
      ASSERT_TRUE(uv.has_value());
      const uint16_t mm = frame.depth.at(int(std::lround(uv->x())), int(std::lround(uv->y())));
      ASSERT_NE(mm, 0);
      EXPECT_NEAR(q.z() * 1000, mm, 20) << "a point of the " << to_string(a.kind);
    }
}

// A pose script's stroke over the real hands site: the pointer sweeps its path, and the stroke
// the others receive lies on the live surface (each point where the site camera measured it,
// within 2 cm along the camera's ray), as does the label's pin; the pointer is shown meanwhile.
// The site's first frame comes only after the script's drawing times have passed (a loaded
// machine): the drawing waits for it, then happens whole.
TEST(Annotations, AScriptedStrokeLiesWhereItsRaysMetTheLiveCloud) {
  test::SessionSite s;
  const CameraCalibration camera = s.site.player.cameras()[0].calibration;
  CameraFrame frame;
  test::HandsSite::sources()[0]->next(frame);
  auto surfaces = std::make_shared<LiveSurfaces>();
  const RigidTransform& site_from_camera = camera.world_from_camera;
  SessionClientOptions drawer = test::named("Mentor");
  drawer.surfaces = surfaces;
  drawer.script.loop = false;
  PoseKey k;  // the right hand where the camera is in the play area (placed at its spawn spot)
  k.hands = true;
  k.right = site_from_camera.translation.cast<float>();
  drawer.script.keys = {k};
  drawer.script.drawing = stroke_and_label(site_from_camera);
  auto watcher = std::make_unique<test::TestParticipant>(s, test::hand_driven("Surgeon"));
  auto mentor = std::make_unique<test::TestParticipant>(s, drawer);
  // 90 poses published (at most 60 a second): past the drawing's times, with no frame yet.
  ASSERT_TRUE(eventually([&] { return mentor->p().stats().poses_sent >= 90; }, 30s));
  EXPECT_TRUE(watcher->now().pointers.empty()) << "nothing to point at yet";
  EXPECT_TRUE(watcher->now().annotations.empty()) << "nothing drawn without the live clouds";
  EXPECT_FALSE(mentor->session->script_done());
  surfaces->update(std::span(&camera, 1), std::vector{std::make_shared<const CameraFrame>(frame)},
                   RigidTransform{});
  bool pointer_seen = false;
  ASSERT_TRUE(eventually(
      [&] {
        pointer_seen = pointer_seen || !watcher->now().pointers.empty();
        return watcher->now().annotations.size() == 2;
      },
      30s));
  EXPECT_TRUE(pointer_seen);
  EXPECT_TRUE(eventually([&] { return mentor->session->script_done(); })) << "drawn, pointer away";
  EXPECT_TRUE(eventually([&] { return watcher->now().pointers.empty(); })) << "put away";
  expect_stroke_and_label_on(watcher->now().annotations, camera, frame);
}

// The same drawing stepped as a starved pose thread steps it: once when the clouds are there and
// once 2 s later, both items due and the stroke's 0.6 s over (a loaded CI run's mentor drew no
// stroke: its thread did not run while the stroke lasted, and the stroke met the clouds 0 times).
// Its rays are cast along its whole path all the same: both are drawn, in script order, on the
// live surface.
TEST(Annotations, AStrokeSteppedOnlyAfterItEndedIsDrawnWhole) {
  test::SessionSite s;
  const CameraCalibration camera = s.site.player.cameras()[0].calibration;
  CameraFrame frame;
  test::HandsSite::sources()[0]->next(frame);
  auto surfaces = std::make_shared<LiveSurfaces>();
  surfaces->update(std::span(&camera, 1), std::vector{std::make_shared<const CameraFrame>(frame)},
                   RigidTransform{});
  auto watcher = std::make_unique<test::TestParticipant>(s, test::hand_driven("Surgeon"));
  auto mentor = std::make_unique<test::TestParticipant>(s, test::hand_driven("Mentor"));
  ASSERT_TRUE(eventually([&] { return watcher->other("Mentor") && mentor->now().joined; }, 30s));
  PoseScript script;
  script.drawing = stroke_and_label(camera.world_from_camera);
  ScriptedPointing pointing(script, surfaces);
  const Eigen::Vector3f hand = camera.world_from_camera.translation.cast<float>();  // room frame
  pointing.step(mentor->p(), hand, 5.0);  // the clouds are there: the drawing's times start
  EXPECT_FALSE(pointing.done());
  pointing.step(mentor->p(), hand, 7.0);
  EXPECT_TRUE(pointing.done()) << "both drawn, the pointer put away";
  ASSERT_TRUE(eventually([&] { return watcher->now().annotations.size() == 2; }, 30s));
  expect_stroke_and_label_on(watcher->now().annotations, camera, frame);
}

}  // namespace
}  // namespace volcast
