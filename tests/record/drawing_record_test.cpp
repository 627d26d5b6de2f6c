// Drawing in recordings (recording.hpp type 7, format version 3): annotations drawn and erased in
// a session, written through the BackgroundRecorder as `volcast record --session` writes them,
// read back byte-identical, replayed into a SessionHub at their times on the replay's timeline,
// exported as JSON with exact positions; truncated and corrupted files; version-2 files.
#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cstring>
#include <fstream>
#include <mutex>
#include <nlohmann/json.hpp>
#include <thread>
#include <tuple>

#include "record/voice_record_support.hpp"
#include "support/hub_outlet.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/pipeline/annotation_export.hpp"
#include "volcast/pipeline/replay.hpp"
#include "volcast/record/recorder.hpp"
#include "volcast/session/annotations.hpp"
#include "volcast/session/hub.hpp"
#include "volcast/session/messages.hpp"

namespace volcast {
namespace {

using namespace voice_test;
using session::Annotation;
using session::AnnotationKind;
using session::Type;

constexpr int64_t kStart = 1'000'000;  // the first frame set's capture time (server clock, us)
constexpr int64_t kFrameUs = 33'333;   // the frame interval
constexpr size_t kFrameSets = 30;

// One recorded drawing message, as the session carried it to the recorder.
struct Drawn {
  uint8_t type;
  int64_t received_us;
  std::vector<uint8_t> payload;
};

// Synthetic (exact values, labelled): the drawing of a short mentoring session. Dr. Aiko Tanaka
// (participant 7) had pinned a label before the recorder joined; she draws a stroke on frame set 5
// (+10 ms), Dr. Mesh (participant 9, whom the recording names nowhere) an arrow on frame set 10,
// and she erases her stroke on frame set 20 (+5 ms).
std::vector<Drawn> session_drawing() {
  Annotation label;
  label.id = 1, label.author = 7, label.time_us = kStart - 400'000, label.tag = 11;
  label.kind = AnnotationKind::kLabel;
  label.points = {{0.125f, 1.0625f, -0.3125f}};
  label.text = "incision here";
  Annotation stroke;
  stroke.id = 2, stroke.author = 7, stroke.time_us = kStart + 5 * kFrameUs + 9'000, stroke.tag = 12;
  stroke.points = {
      {0.1234567f, 0.9876543f, -0.4f}, {0.13f, 0.99f, -0.41f}, {0.1f / 3, 1.f, -1.f / 7}};
  Annotation arrow;
  arrow.id = 3, arrow.author = 9, arrow.time_us = kStart + 10 * kFrameUs - 1'000;
  arrow.kind = AnnotationKind::kArrow;
  arrow.points = {{-0.5f, 1.2f, 0.25f}, {-0.45f, 1.1f, 0.2f}};
  return {{0x51, kStart - 5'000, session::serialize(label)},
          {0x51, kStart + 5 * kFrameUs + 10'000, session::serialize(stroke)},
          {0x51, kStart + 10 * kFrameUs, session::serialize(arrow)},
          {0x52, kStart + 20 * kFrameUs + 5'000, session::serialize_erased(2, 7)}};
}

// Synthetic: frame set k of the 8x4 site as tiny_body times it, its depth a raw-coded image (so
// that a replay decodes it).
std::vector<uint8_t> decodable_body(uint64_t k) {
  static const auto encoder = make_depth_encoder("raw");
  DepthImage d(8, 4);
  for (size_t i = 0; i < d.pixels.size(); ++i) d.pixels[i] = static_cast<uint16_t>(1000 + k + i);
  protocol::EncodedCamera cam;
  encoder->encode(d, true, cam.depth);
  protocol::SenderTimes t;
  t.capture_us = kStart + static_cast<int64_t>(k) * kFrameUs;
  std::vector<uint8_t> body;
  protocol::serialize_frame_set_body(k + 1, true, t, std::span(&cam, 1), body);
  return body;
}

// Writes the session through a BackgroundRecorder (the recorder's path): 30 frame sets, the
// speaker, and the drawing pushed as received (the label, received on joining, first).
void record_session(const fs::path& path) {
  BackgroundRecorder rec(path, tiny_stream());
  const std::vector<Drawn> drawing = session_drawing();
  size_t next = 0;
  rec.push_speaker(7, "Dr. Aiko Tanaka", 0);
  for (uint64_t k = 0; k < kFrameSets; ++k) {
    for (; next < drawing.size() && drawing[next].received_us < kStart + int64_t(k) * kFrameUs;
         ++next)
      rec.push_drawing(drawing[next].type, drawing[next].received_us, drawing[next].payload);
    auto body = std::make_shared<std::vector<uint8_t>>(decodable_body(k));
    TierFrameSet f;
    f.sequence = k + 1;
    f.key = true;
    f.capture_us = kStart + int64_t(k) * kFrameUs;
    f.body = *body;
    f.keep = body;
    f.index = k + 1;
    rec.push(f);
  }
  for (; next < drawing.size(); ++next)
    rec.push_drawing(drawing[next].type, drawing[next].received_us, drawing[next].payload);
  rec.push_drawing(0x53, kStart, drawing[0].payload);  // not a drawing message: dropped
  rec.stop();
  EXPECT_EQ(rec.stats().drawings, 4u);
  EXPECT_EQ(rec.stats().drawing_dropped, 1u);
  EXPECT_EQ(rec.stats().error, "");
}

struct Recorded {
  fs::path dir, path;
};

// One recording shared by the tests (written once: ~50 ms).
const Recorded& recorded() {
  static const Recorded r = [] {
    Recorded out{temp_dir("drawing"), {}};
    out.path = out.dir / "session.vcr";
    record_session(out.path);
    return out;
  }();
  return r;
}

void expect_drawing(RecordingReader& r, size_t count) {
  const std::vector<Drawn> want = session_drawing();
  ASSERT_EQ(r.info().drawings.size(), count);
  std::vector<uint8_t> payload;
  for (size_t k = 0; k < count; ++k) {
    const RecordedDrawing& d = r.info().drawings[k];
    r.read_drawing(d, payload);
    EXPECT_EQ(d.type, want[k].type) << k;
    EXPECT_EQ(d.received_us, want[k].received_us) << k;
    EXPECT_EQ(payload, want[k].payload) << k;
  }
}

TEST(DrawingRecording, TheRecorderWritesEachMessageByteIdenticalAndTheIndexAndAScanAgree) {
  RecordingReader closed(recorded().path);
  EXPECT_EQ(closed.info().version, 3);
  EXPECT_TRUE(closed.info().closed);
  EXPECT_EQ(closed.info().frame_sets.size(), kFrameSets);
  expect_drawing(closed, 4);
  EXPECT_NO_THROW(closed.verify());
  // Without its Index and End (a recorder killed), scanning finds the same.
  std::vector<uint8_t> bytes = file_bytes(recorded().path);
  bytes.resize(bytes.size() - 16 - 8);  // the End record
  const uint64_t index_at = wire::load<uint64_t>(file_bytes(recorded().path).data() +
                                                 file_bytes(recorded().path).size() - 8);
  bytes.resize(index_at);
  put_file(recorded().dir / "scanned.vcr", bytes);
  RecordingReader scanned(recorded().dir / "scanned.vcr");
  EXPECT_FALSE(scanned.info().closed);
  EXPECT_FALSE(scanned.info().incomplete_tail_at);
  expect_drawing(scanned, 4);
  for (size_t k = 0; k < 4; ++k)
    EXPECT_EQ(scanned.info().drawings[k].offset, closed.info().drawings[k].offset);
}

// When each drawing plays (drawing_plan): as long after the last frame set received before it as
// it was received after it; before the first frame set at 0; a selection from frame set 8 on has
// the label and the stroke at its start.
TEST(DrawingRecording, EachDrawingPlaysWhereItFallsAmongTheFrameSets) {
  RecordingReader r(recorded().path);
  const PlaybackTimeline t = playback_timeline(r.info().frame_sets);
  const std::vector<DrawingCue> all = drawing_plan(r.info(), t, 0, kFrameSets - 1);
  ASSERT_EQ(all.size(), 4u);
  const int64_t want[] = {0, 5 * kFrameUs + 10'000, 10 * kFrameUs, 20 * kFrameUs + 5'000};
  for (size_t k = 0; k < 4; ++k) {
    EXPECT_EQ(all[k].drawing, k);
    EXPECT_EQ(all[k].at_us, want[k]) << k;
  }
  const std::vector<DrawingCue> late = drawing_plan(r.info(), t, 8, 15);
  ASSERT_EQ(late.size(), 3u);  // the erasure (frame set 20) is after the selection
  EXPECT_EQ(late[0].at_us, 0);
  EXPECT_EQ(late[1].at_us, 0);
  EXPECT_EQ(late[2].at_us, 2 * kFrameUs);
}

// A hub's outlet that notes when each message was sent.
struct TimedOutlet final : SessionOutlet {
  std::mutex mutex;
  std::vector<std::tuple<uint64_t, std::chrono::steady_clock::time_point, std::vector<uint8_t>>>
      sent;
  bool send_session(uint64_t viewer, std::shared_ptr<const std::vector<uint8_t>> m,
                    uint64_t) override {
    std::lock_guard lock(mutex);
    sent.emplace_back(viewer, std::chrono::steady_clock::now(), *m);
    return true;
  }
  void disconnect(uint64_t, const std::string&) override {}
};

TEST(DrawingRecording, AReplayDrawsAndErasesInEverySessionAtTheirTimes) {
  SessionHub hub;
  TimedOutlet outlet;
  hub.attach(&outlet);
  for (const auto& [viewer, name] :
       {std::pair<uint64_t, std::string>{100, "Dr. Live"}, {200, "Dr. Other"}}) {
    session::Join j;
    j.session = viewer == 100 ? "mentoring" : "teaching";
    j.name = name;
    hub.on_message(viewer, static_cast<uint8_t>(Type::kJoin), session::serialize(j));
  }
  ReplayOptions o;
  o.loop = false;
  ReplayPlayer player(recorded().path, o);
  ASSERT_EQ(player.drawing().size(), 4u);
  std::atomic<size_t> published{0};
  const auto start = std::chrono::steady_clock::now();
  player.start([&](std::shared_ptr<const CapturedFrameSet>) { ++published; }, &hub);
  for (int i = 0; i < 1000 && !player.finished(); ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  ASSERT_TRUE(player.finished());
  player.stop();
  EXPECT_EQ(player.drawings_sent(), 4u);
  // Dr. Aiko Tanaka has a Speaker record: a recorded speaker of the hub draws in her place; Dr.
  // Mesh has none: the server (0) does.
  uint32_t tanaka = 0;
  for (const SessionMember& m : hub.members("mentoring"))
    if (m.name == "Dr. Aiko Tanaka (recorded)") tanaka = m.id;
  ASSERT_NE(tanaka, 0u);
  const std::vector<Drawn> want = session_drawing();
  for (const auto& [viewer, name] :
       {std::pair<uint64_t, std::string>{100, "mentoring"}, {200, "teaching"}}) {
    // What the session holds at the end: the label and the arrow, numbered by the session.
    const std::vector<Annotation> standing = hub.annotations(name);
    ASSERT_EQ(standing.size(), 2u) << name;
    const Annotation label = session::parse_annotation(want[0].payload);
    const Annotation arrow = session::parse_annotation(want[2].payload);
    EXPECT_EQ(standing[0].points, label.points);
    EXPECT_EQ(standing[0].text, label.text);
    EXPECT_EQ(standing[0].author, tanaka);
    EXPECT_EQ(standing[1].points, arrow.points);
    EXPECT_EQ(standing[1].kind, AnnotationKind::kArrow);
    EXPECT_EQ(standing[1].author, 0u);
    // What its member was sent, in order, and never before its time on the replay's timeline.
    std::vector<std::pair<uint8_t, int64_t>> got;  // (type, us after start)
    std::vector<uint8_t> erased;
    {
      std::lock_guard lock(outlet.mutex);
      for (const auto& [v, at, m] : outlet.sent)
        if (v == viewer && (m[7] == 0x51 || m[7] == 0x52)) {
          got.emplace_back(
              m[7], std::chrono::duration_cast<std::chrono::microseconds>(at - start).count());
          if (m[7] == 0x52) erased.assign(m.begin() + 12, m.end());
        }
    }
    ASSERT_EQ(got.size(), 4u) << name;
    const int64_t due[] = {0, 5 * kFrameUs + 10'000, 10 * kFrameUs, 20 * kFrameUs + 5'000};
    for (size_t k = 0; k < 4; ++k) {
      EXPECT_EQ(got[k].first, want[k].type) << name << " " << k;
      EXPECT_GE(got[k].second, due[k]) << name << " " << k;
    }
    // The stroke (the session's number 2: the second added there) erased by her recorded speaker.
    EXPECT_EQ(session::parse_erased(erased), std::make_pair(uint32_t{2}, tanaka));
  }
  // The frame sets played alongside.
  EXPECT_EQ(player.frame_sets_published(), kFrameSets);
  EXPECT_EQ(published.load(), kFrameSets);
}

// A looping replay of frame sets 9..12 (a 133 ms pass): the label and the stroke, drawn before
// it, stand from its start, the arrow comes 33 ms in; when the pass ends all three are erased (by
// the server), and the next pass draws them again: never two of one.
TEST(DrawingRecording, ALoopingReplayBeginsEachPassAsTheRecordingDid) {
  SessionHub hub;
  test::Outlet outlet;
  hub.attach(&outlet);
  session::Join j;
  j.session = "mentoring";
  j.name = "Dr. Live";
  hub.on_message(100, static_cast<uint8_t>(Type::kJoin), session::serialize(j));
  ReplayOptions o;
  o.from_s = 9 * kFrameUs / 1e6;
  o.to_s = 12 * kFrameUs / 1e6;
  ReplayPlayer player(recorded().path, o);
  ASSERT_EQ(player.first_frame_set(), 9u);
  ASSERT_EQ(player.last_frame_set(), 12u);
  ASSERT_EQ(player.drawing().size(), 3u);
  player.start([](std::shared_ptr<const CapturedFrameSet>) {}, &hub);
  for (int i = 0; i < 1000 && player.drawings_sent() < 6; ++i)
    std::this_thread::sleep_for(std::chrono::milliseconds(5));
  player.stop();
  ASSERT_GE(player.drawings_sent(), 6u);
  std::vector<std::pair<uint8_t, uint32_t>> got;  // (type, the session's id)
  {
    std::lock_guard lock(outlet.mutex);
    for (const auto& [v, m] : outlet.sent)
      if (v == 100 && (m[7] == 0x51 || m[7] == 0x52)) {
        const std::span<const uint8_t> p(m.data() + 12, m.size() - 12);
        got.emplace_back(
            m[7], m[7] == 0x51 ? session::parse_annotation(p).id : session::parse_erased(p).first);
        if (m[7] == 0x52) {
          EXPECT_EQ(session::parse_erased(p).second, 0u);
        }
      }
  }
  ASSERT_GE(got.size(), 9u);
  const std::vector<std::pair<uint8_t, uint32_t>> want = {{0x51, 1}, {0x51, 2}, {0x51, 3},
                                                          {0x52, 1}, {0x52, 2}, {0x52, 3},
                                                          {0x51, 4}, {0x51, 5}, {0x51, 6}};
  EXPECT_EQ(std::vector(got.begin(), got.begin() + 9), want);
  EXPECT_LE(hub.annotations("mentoring").size(), 3u);
}

TEST(DrawingRecording, ExportWritesEveryAnnotationWithExactPositionsAndItsTimes) {
  const fs::path json = recorded().dir / "annotations.json";
  EXPECT_EQ(export_annotations(recorded().path, json), 3u);
  EXPECT_EQ(fs::status(json).permissions() & fs::perms::all,
            fs::perms::owner_read | fs::perms::owner_write);
  const nlohmann::json j = nlohmann::json::parse(std::ifstream(json));
  EXPECT_EQ(j["frame"], "room");
  EXPECT_EQ(j["units"], "metres");
  EXPECT_EQ(j["time_zero_us"], kStart);
  const nlohmann::json& list = j["annotations"];
  ASSERT_EQ(list.size(), 3u);
  const std::vector<Drawn> want = session_drawing();
  for (size_t k = 0; k < 3; ++k) {
    const Annotation a = session::parse_annotation(want[k].payload);
    const nlohmann::json& e = list[k];
    EXPECT_EQ(e["id"], a.id);
    EXPECT_EQ(e["author"]["id"], a.author);
    EXPECT_EQ(e["kind"], session::to_string(a.kind));
    EXPECT_EQ(e["anchor"], "room");
    EXPECT_EQ(e["text"], a.text);
    EXPECT_EQ(e["drawn_us"], a.time_us);
    EXPECT_DOUBLE_EQ(e["drawn_s"].get<double>(), double(a.time_us - kStart) / 1e6);
    EXPECT_EQ(e["received_us"], want[k].received_us);
    ASSERT_EQ(e["points"].size(), a.points.size());
    for (size_t i = 0; i < a.points.size(); ++i)
      for (int c = 0; c < 3; ++c)  // each float exactly (the JSON number reads back as it)
        EXPECT_EQ(static_cast<float>(e["points"][i][c].get<double>()), a.points[i][c])
            << k << " " << i;
  }
  EXPECT_EQ(list[1]["points"][0][0].get<double>(), 0.1234567);  // as written, not 0.1234567016...
  EXPECT_EQ(list[0]["author"]["name"], "Dr. Aiko Tanaka");
  EXPECT_TRUE(list[2]["author"]["name"].is_null());  // Dr. Mesh: no Speaker record
  EXPECT_TRUE(list[0]["erased_us"].is_null());
  EXPECT_TRUE(list[0]["erased_by"].is_null());
  EXPECT_EQ(list[1]["erased_us"], want[3].received_us);
  EXPECT_EQ(list[1]["erased_by"]["id"], 7);
  EXPECT_EQ(list[1]["erased_by"]["name"], "Dr. Aiko Tanaka");
}

// The offset of drawing record `k` and the file without its Index and End (a killed recorder).
std::pair<uint64_t, std::vector<uint8_t>> unclosed(size_t k) {
  RecordingReader r(recorded().path);
  const uint64_t at = r.info().drawings.at(k).offset;
  std::vector<uint8_t> bytes = file_bytes(recorded().path);
  bytes.resize(wire::load<uint64_t>(bytes.data() + bytes.size() - 8));
  return {at, bytes};
}

TEST(DrawingRecording, AFileCutInsideADrawingRecordKeepsTheDrawingBeforeTheCut) {
  const auto [at, bytes] = unclosed(3);
  // The erasure is the last drawing record; cut at each byte of it (the frame sets after it too).
  RecordingReader whole(recorded().path);
  const uint64_t end = at + 16 + 13 + whole.info().drawings[3].bytes;
  for (uint64_t cut = at + 1; cut < end; cut += 3) {
    std::vector<uint8_t> part(bytes.begin(), bytes.begin() + static_cast<ptrdiff_t>(cut));
    put_file(recorded().dir / "cut.vcr", part);
    RecordingReader r(recorded().dir / "cut.vcr");
    ASSERT_TRUE(r.info().incomplete_tail_at) << cut;
    EXPECT_EQ(*r.info().incomplete_tail_at, at) << cut;
    expect_drawing(r, 3);
  }
}

// A Drawing record whose CRCs hold but whose content is wrong is corruption naming its offset:
// by the scanning reader, by read_drawing and verify() of a closed file; a length over the limit
// is refused before anything is read for it.
TEST(DrawingRecording, ACorruptDrawingRecordIsAnErrorNamingItsOffset) {
  const auto [at, bytes] = unclosed(1);
  RecordingReader whole(recorded().path);
  const size_t n = 16 + 13 + whole.info().drawings[1].bytes;  // the stroke's record
  const std::vector<uint8_t> good(bytes.begin() + static_cast<ptrdiff_t>(at + 16),
                                  bytes.begin() + static_cast<ptrdiff_t>(at + n));
  const auto with = [&, at = at, bytes = bytes](const std::vector<uint8_t>& record) {
    std::vector<uint8_t> b(bytes.begin(), bytes.begin() + static_cast<ptrdiff_t>(at));
    b.insert(b.end(), record.begin(), record.end());
    b.insert(b.end(), bytes.begin() + static_cast<ptrdiff_t>(at + n), bytes.end());
    put_file(recorded().dir / "bad.vcr", b);
    return error_of([&] { RecordingReader r(recorded().dir / "bad.vcr"); });
  };
  const std::string offset = "drawing at offset " + std::to_string(at);
  EXPECT_EQ(with(framed(RecordType::kDrawing, good)), "");
  std::vector<uint8_t> p = good;
  p[0] = 0x53;  // another session message
  EXPECT_NE(with(framed(RecordType::kDrawing, p))
                .find(offset + ": malformed drawing: session "
                               "message type 83"),
            std::string::npos);
  p = good;
  p[13 + 4 + 4 + 8 + 4] = 7;  // the stroke's kind: none such
  const std::string kind = with(framed(RecordType::kDrawing, p));
  EXPECT_NE(kind.find(offset + ": malformed drawing: malformed annotation"), std::string::npos)
      << kind;
  p = good;
  p.push_back(0);  // a byte the length does not cover
  EXPECT_NE(with(framed(RecordType::kDrawing, p))
                .find(offset + ": malformed drawing: payload "
                               "length"),
            std::string::npos);
  // A header claiming more than the limit: refused before its payload is read.
  std::vector<uint8_t> huge = framed(RecordType::kDrawing, good);
  wire::store<uint32_t>(huge.data() + 4, 1u << 30);
  wire::store<uint32_t>(huge.data() + 12, crc32_of(std::span(huge).first(12)));
  EXPECT_NE(with(huge).find("drawing record of 1073741824 bytes (over the limit of 4109) at "
                            "offset " +
                            std::to_string(at)),
            std::string::npos);
  // In a closed file the index is trusted until the record is read: read_drawing and verify()
  // name it.
  std::vector<uint8_t> closed = file_bytes(recorded().path);
  closed[at + 16 + 13 + 4 + 4 + 8 + 4] = 7;
  const std::vector<uint8_t> record(closed.begin() + static_cast<ptrdiff_t>(at + 16),
                                    closed.begin() + static_cast<ptrdiff_t>(at + n));
  const std::vector<uint8_t> refr = framed(RecordType::kDrawing, record);
  std::copy(refr.begin(), refr.begin() + 16, closed.begin() + static_cast<ptrdiff_t>(at));
  put_file(recorded().dir / "bad_closed.vcr", closed);
  RecordingReader r(recorded().dir / "bad_closed.vcr");
  ASSERT_TRUE(r.info().closed);
  std::vector<uint8_t> payload;
  EXPECT_NE(error_of([&] { r.read_drawing(r.info().drawings[1], payload); }).find(offset),
            std::string::npos);
  EXPECT_NE(error_of([&] { r.verify(); }).find(offset), std::string::npos);
  // The writer refuses what the reader would (nothing written, it goes on).
  RecordingWriter w(recorded().dir / "refused.vcr", tiny_stream(), {.overwrite = true});
  EXPECT_NE(error_of([&] { w.append_drawing(0x51, 0, p); }).find("drawing refused"),
            std::string::npos);
  EXPECT_NE(error_of([&] { w.append_drawing(0x50, 0, good); }).find("drawing refused"),
            std::string::npos);
  EXPECT_EQ(w.drawings(), 0u);
  w.append_drawing(0x52, 0, session::serialize_erased(1, 0));
  EXPECT_EQ(w.drawings(), 1u);
}

// A version-2 file (voices, no drawing) as this build's writer wrote it before version 3: the
// same records, its Index without the drawing count.
std::vector<uint8_t> version2_file(bool closed) {
  const fs::path path = temp_dir("v2") / "v2.vcr";
  {
    RecordingWriter w(path, tiny_stream());
    write_mixed(w);
  }
  std::vector<uint8_t> b = file_bytes(path);
  b[8] = 2;
  wire::store<uint32_t>(b.data() + 12, crc32_of(std::span(b).first(12)));
  const uint64_t index_at = wire::load<uint64_t>(b.data() + b.size() - 8);
  const uint32_t index_bytes = wire::load<uint32_t>(b.data() + index_at + 4);
  std::vector<uint8_t> index(b.begin() + static_cast<ptrdiff_t>(index_at + 16),
                             b.begin() + static_cast<ptrdiff_t>(index_at + 16 + index_bytes - 4));
  b.resize(index_at);
  if (!closed) return b;
  const std::vector<uint8_t> ir = framed(RecordType::kIndex, index);
  b.insert(b.end(), ir.begin(), ir.end());
  std::vector<uint8_t> end(8);
  wire::store<uint64_t>(end.data(), index_at);
  const std::vector<uint8_t> er = framed(RecordType::kEnd, end);
  b.insert(b.end(), er.begin(), er.end());
  return b;
}

TEST(DrawingRecording, AVersion2FileStillReadsAndADrawingRecordInItIsAnUnknownType) {
  const fs::path dir = temp_dir("v2read");
  for (const bool closed : {true, false}) {
    put_file(dir / "v2.vcr", version2_file(closed));
    RecordingReader r(dir / "v2.vcr");
    EXPECT_EQ(r.info().version, 2);
    EXPECT_EQ(r.info().closed, closed);
    EXPECT_FALSE(r.info().incomplete_tail_at);
    EXPECT_EQ(r.info().frame_sets.size(), 10u);
    EXPECT_EQ(r.info().voices.size(), 60u);
    EXPECT_TRUE(r.info().drawings.empty());
    EXPECT_NO_THROW(r.verify());
  }
  std::vector<uint8_t> b = version2_file(false);
  // A Drawing record (valid in version 3) at the end of a version-2 file.
  std::vector<uint8_t> payload(13, 0);
  payload[0] = 0x52;
  const std::vector<uint8_t> erase = session::serialize_erased(1, 0);
  wire::store<uint32_t>(payload.data() + 9, static_cast<uint32_t>(erase.size()));
  payload.insert(payload.end(), erase.begin(), erase.end());
  const uint64_t at = b.size();
  const std::vector<uint8_t> rec = framed(RecordType::kDrawing, payload);
  b.insert(b.end(), rec.begin(), rec.end());
  put_file(dir / "v2.vcr", b);
  EXPECT_NE(error_of([&] {
              RecordingReader r(dir / "v2.vcr");
            }).find("unknown type 7 at offset " + std::to_string(at)),
            std::string::npos);
  b[8] = 3;  // the same file as version 3 reads, the erasure with it
  wire::store<uint32_t>(b.data() + 12, crc32_of(std::span(b).first(12)));
  put_file(dir / "v2.vcr", b);
  RecordingReader r(dir / "v2.vcr");
  ASSERT_EQ(r.info().drawings.size(), 1u);
  EXPECT_EQ(r.info().drawings[0].offset, at);
}

}  // namespace
}  // namespace volcast
