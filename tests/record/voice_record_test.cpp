// Voices in recordings (volcast/record): Speaker and Voice records round trip through the index
// and through a scan, a killed recorder keeps every complete voice, corruption names its offset,
// and version-1 files (no voices) still read. The "Opus packets" here are synthetic byte patterns
// (1..1275 bytes, each telling its speaker and sequence apart): records are not decoded here.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <thread>

#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/net/protocol/frame_set.hpp"
#include "volcast/record/recorder.hpp"
#include "volcast/record/recording.hpp"

namespace volcast {
namespace {

namespace fs = std::filesystem;

fs::path temp_dir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("voice_record_test_" + std::to_string(getpid()) + "_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

std::vector<uint8_t> file_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

void put_file(const fs::path& p, std::span<const uint8_t> bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

// Synthetic (for exact behaviour only): a one-camera 8x4 site, as record_test has it.
RecordingStream tiny_stream() {
  RecordingStream s;
  s.depth_codec = "raw";
  s.color_codec = "none";
  s.started_us = 1;
  s.origin = "voice_record_test";
  protocol::CameraInfo c;
  c.calibration.depth = Intrinsics{8, 4, 10, 10, 4, 2};
  c.description = "synthetic";
  s.welcome.cameras.push_back(c);
  return s;
}

std::vector<uint8_t> tiny_body(uint64_t k) {
  protocol::EncodedCamera cam;
  cam.depth.assign(200, static_cast<uint8_t>(k));
  protocol::SenderTimes t;
  t.capture_us = 1'000'000 + static_cast<int64_t>(k) * 33'333;
  std::vector<uint8_t> body;
  protocol::serialize_frame_set_body(k + 1, k % 10 == 0, t, std::span(&cam, 1), body);
  return body;
}

// A synthetic voice packet: participant p's packet n (sequence n, frame n + n / 5: DTX skips).
RecordedVoicePacket packet(uint32_t p, uint32_t n) {
  RecordedVoicePacket v{p, n, n + n / 5, 1'000'000 + int64_t{n + n / 5} * 20'000 + p, {}};
  const size_t len = n == 0 ? 1 : n == 1 ? kMaxRecordedVoiceBytes : 40 + (n * 37 + p) % 120;
  v.bytes.resize(len);
  for (size_t i = 0; i < len; ++i) v.bytes[i] = static_cast<uint8_t>(p * 101 + n * 7 + i);
  return v;
}

bool same(const RecordedVoicePacket& a, const RecordedVoicePacket& b) {
  return a.participant == b.participant && a.sequence == b.sequence && a.frame == b.frame &&
         a.capture_us == b.capture_us && a.bytes == b.bytes;
}

// Writes frame sets and two speakers' voices interleaved (10 frame sets, 30 voices each): the
// order a recorder sees them. Returns the packets in the order written.
std::vector<RecordedVoicePacket> write_mixed(RecordingWriter& w) {
  std::vector<RecordedVoicePacket> written;
  w.append_speaker(7, "Dr. Aiko Tanaka", 0);
  w.append_speaker(1, "OR 3", 1);
  for (uint32_t n = 0; n < 30; ++n) {
    if (n % 3 == 0) w.append(tiny_body(n / 3));
    for (uint32_t p : {7u, 1u}) {
      written.push_back(packet(p, n));
      w.append_voice(written.back());
    }
  }
  return written;
}

void expect_voices(RecordingReader& r, const std::vector<RecordedVoicePacket>& written,
                   size_t count) {
  ASSERT_EQ(r.info().voices.size(), count);
  std::vector<uint8_t> bytes;
  for (size_t k = 0; k < count; ++k) {
    const RecordedVoice& v = r.info().voices[k];
    r.read_voice(v, bytes);
    RecordedVoicePacket got{v.participant, v.sequence, v.frame, v.capture_us, bytes};
    ASSERT_TRUE(same(got, written[k])) << "voice " << k;
  }
}

TEST(VoiceRecording, SpeakersAndVoicesRoundTripThroughTheIndexAndAScan) {
  const fs::path dir = temp_dir("roundtrip");
  const fs::path path = dir / "voices.vcr";
  std::vector<RecordedVoicePacket> written;
  {
    RecordingWriter w(path, tiny_stream());
    written = write_mixed(w);
    // Late and out of order: capture order is not file order. A name change writes a new record
    // (the last one holds); the same name again writes nothing. An unknown speaker gets a name.
    written.push_back(packet(7, 30));
    written.back().capture_us = 999'000;
    w.append_voice(written.back());
    w.append_speaker(7, "Dr. Tanaka", 0);
    w.append_speaker(7, "Dr. Tanaka", 0);
    written.push_back(packet(42, 0));
    w.append_voice(written.back());
    EXPECT_EQ(w.voices(), 62u);
    w.close();
  }
  RecordingReader r(path);
  const RecordingInfo& info = r.info();
  EXPECT_TRUE(info.closed);
  EXPECT_EQ(info.version, 2);
  EXPECT_EQ(info.frame_sets.size(), 10u);
  ASSERT_EQ(info.speakers.size(), 3u);
  EXPECT_EQ(info.speakers[0].participant, 7u);
  EXPECT_EQ(info.speakers[0].name, "Dr. Tanaka");
  EXPECT_EQ(info.speakers[1].name, "OR 3");
  EXPECT_EQ(info.speakers[1].role, 1);
  EXPECT_EQ(info.speakers[2].name, "participant 42");
  expect_voices(r, written, written.size());
  // Each speaker's packets in capture order, bytes included.
  const std::vector<RecordedVoicePacket> seven = r.voices(7);
  ASSERT_EQ(seven.size(), 31u);
  EXPECT_TRUE(same(seven[0], written[60]));
  for (uint32_t n = 0; n < 30; ++n) EXPECT_TRUE(same(seven[n + 1], packet(7, n))) << n;
  EXPECT_EQ(r.voices(1).size(), 30u);
  EXPECT_TRUE(r.voices(5).empty());
  std::vector<uint8_t> body;
  for (size_t k = 0; k < 10; ++k) {
    r.read(k, body);
    EXPECT_EQ(body, tiny_body(k));
  }
  EXPECT_NO_THROW(r.verify());
  // Summaries: participant 1 sent frames 0..35 (30 packets) from 1 s + 1 us on.
  const std::vector<SpeakerSummary> sum = speaker_summaries(info);
  ASSERT_EQ(sum.size(), 3u);
  EXPECT_EQ(sum[1].packets, 30u);
  EXPECT_EQ(sum[1].sent_us, 30 * kVoiceFrameUs);
  EXPECT_EQ(sum[1].spanned_us, 35 * kVoiceFrameUs);
  EXPECT_EQ(sum[1].first_us, 1);
  EXPECT_EQ(sum[1].last_us, 34 * kVoiceFrameUs + 1);
  // Without its Index and End (a recorder killed just before closing) a scan finds the same.
  const std::vector<uint8_t> whole = file_bytes(path);
  const uint64_t index_at = wire::load<uint64_t>(whole.data() + whole.size() - 8);
  put_file(dir / "scanned.vcr", std::span(whole).first(index_at));
  RecordingReader s(dir / "scanned.vcr");
  EXPECT_FALSE(s.info().closed);
  EXPECT_FALSE(s.info().incomplete_tail_at);
  ASSERT_EQ(s.info().speakers.size(), 3u);
  EXPECT_EQ(s.info().speakers[0].name, "Dr. Tanaka");
  ASSERT_EQ(s.info().voices.size(), info.voices.size());
  for (size_t k = 0; k < info.voices.size(); ++k) {
    EXPECT_EQ(s.info().voices[k].offset, info.voices[k].offset) << k;
    EXPECT_EQ(s.info().voices[k].bytes, info.voices[k].bytes) << k;
  }
  EXPECT_EQ(s.info().frame_sets.size(), 10u);
}

TEST(VoiceRecording, AFileCutAtEveryByteOfItsLastRecordsGivesBackEveryCompleteVoice) {
  const fs::path dir = temp_dir("cut");
  const fs::path path = dir / "open.vcr";
  std::vector<RecordedVoicePacket> written;
  std::vector<uint8_t> open_image;
  {
    RecordingWriter w(path, tiny_stream());
    written = write_mixed(w);
    open_image = file_bytes(path);  // as a killed recorder leaves it: no Index, no End
  }
  RecordingReader whole(path);
  ASSERT_TRUE(whole.info().closed);
  std::vector<uint64_t> voice_ends, set_ends;
  for (const RecordedVoice& v : whole.info().voices)
    voice_ends.push_back(v.offset + 16 + 24 + v.bytes);
  for (const RecordedFrameSet& f : whole.info().frame_sets)
    set_ends.push_back(f.offset + 16 + f.bytes);
  // The last 8 records: voices, and a frame set among them.
  const uint64_t from = whole.info().voices[whole.info().voices.size() - 7].offset - 1;
  ASSERT_GT(whole.info().frame_sets.back().offset, from);
  const fs::path cut = dir / "cut.vcr";
  for (uint64_t n = from; n <= open_image.size(); ++n) {
    put_file(cut, std::span(open_image).first(n));
    const std::string error = error_of([&] {
      RecordingReader r(cut);
      r.verify();
    });
    ASSERT_EQ(error, "") << n;
    RecordingReader r(cut);
    const size_t voices = static_cast<size_t>(
        std::upper_bound(voice_ends.begin(), voice_ends.end(), n) - voice_ends.begin());
    const size_t sets = static_cast<size_t>(std::upper_bound(set_ends.begin(), set_ends.end(), n) -
                                            set_ends.begin());
    expect_voices(r, written, voices);
    EXPECT_EQ(r.info().frame_sets.size(), sets) << n;
    const uint64_t last_end = std::max(voices ? voice_ends[voices - 1] : 0, set_ends[sets - 1]);
    EXPECT_EQ(r.info().incomplete_tail_at.has_value(), n != last_end) << n;
    if (n != last_end) {
      EXPECT_EQ(*r.info().incomplete_tail_at, last_end) << n;
    }
  }
}

TEST(VoiceRecording, ARecorderKilledWhileWritingVoicesKeepsThemUpToItsLastCompleteRecord) {
  const fs::path dir = temp_dir("killed");
  size_t kept = 0;
  for (int run = 0; run < 6; ++run) {
    const fs::path path = dir / ("killed-" + std::to_string(run) + ".vcr");
    int ready[2];
    ASSERT_EQ(pipe(ready), 0);
    const pid_t child = fork();
    ASSERT_GE(child, 0);
    if (child == 0) {
      RecordingWriter w(path, tiny_stream(), {.sync_interval_ms = 5});
      w.append_speaker(3, "speaker", 0);
      const char c = 1;
      [[maybe_unused]] auto n = write(ready[1], &c, 1);
      for (uint32_t k = 0;; ++k) {
        if (k % 3 == 0) w.append(tiny_body(k / 3));
        w.append_voice(packet(3, k));
      }
    }
    char c = 0;
    ASSERT_EQ(read(ready[0], &c, 1), 1);
    close(ready[0]);
    close(ready[1]);
    std::this_thread::sleep_for(std::chrono::milliseconds(5 + 13 * run));
    kill(child, SIGKILL);
    int status = 0;
    waitpid(child, &status, 0);
    ASSERT_TRUE(WIFSIGNALED(status));
    RecordingReader r(path);
    EXPECT_FALSE(r.info().closed);
    kept += r.info().voices.size();
    std::vector<uint8_t> bytes;
    for (uint32_t k = 0; k < r.info().voices.size(); ++k) {
      r.read_voice(r.info().voices[k], bytes);
      ASSERT_EQ(bytes, packet(3, k).bytes) << path << " voice " << k;
    }
  }
  EXPECT_GT(kept, 0u);
}

TEST(VoiceRecording, ACorruptVoiceInTheMiddleIsAnErrorNamingItsOffset) {
  const fs::path dir = temp_dir("corrupt");
  const fs::path path = dir / "v.vcr";
  std::vector<uint8_t> open_image;
  {
    RecordingWriter w(path, tiny_stream());
    write_mixed(w);
    open_image = file_bytes(path);
  }
  const std::vector<uint8_t> closed = file_bytes(path);
  RecordingReader ok(path);
  const RecordedVoice v = ok.info().voices[20];
  const std::string at = "at offset " + std::to_string(v.offset);
  const fs::path bad = dir / "bad.vcr";
  // A flipped Opus byte: a scan refuses the file; with the index, reading the voice does.
  for (const bool indexed : {false, true}) {
    std::vector<uint8_t> b = indexed ? closed : open_image;
    b[v.offset + 16 + 24 + 3] ^= 0x20;
    put_file(bad, b);
    const std::string error = error_of([&] {
      RecordingReader r(bad);
      r.verify();
    });
    EXPECT_NE(error.find("corrupt"), std::string::npos) << error;
    EXPECT_NE(error.find(at), std::string::npos) << error;
    EXPECT_NE(error.find("voice"), std::string::npos) << error;
  }
  // A flipped bit in its record header, or an index entry that moved it.
  std::vector<uint8_t> b = open_image;
  b[v.offset + 5] ^= 0x01;
  put_file(bad, b);
  EXPECT_NE(error_of([&] { RecordingReader r(bad); }).find("corrupt record header " + at),
            std::string::npos);
}

// A record with valid CRCs around `payload`, as a (hostile) writer would frame it.
std::vector<uint8_t> framed(RecordType type, const std::vector<uint8_t>& payload) {
  std::vector<uint8_t> h(16, 0);
  h[0] = static_cast<uint8_t>(type);
  wire::store<uint32_t>(h.data() + 4, static_cast<uint32_t>(payload.size()));
  wire::store<uint32_t>(h.data() + 8, crc32_of(payload));
  wire::store<uint32_t>(h.data() + 12, crc32_of(std::span(h).first(12)));
  h.insert(h.end(), payload.begin(), payload.end());
  return h;
}

std::vector<uint8_t> voice_payload(uint32_t length_field, size_t actual) {
  std::vector<uint8_t> p;
  wire::Writer w(p);
  w.put<uint32_t>(3);  // participant
  w.put<uint32_t>(1);
  w.put<uint32_t>(1);
  w.put<int64_t>(5);
  w.put<uint32_t>(length_field);
  p.resize(p.size() + actual, 0x55);
  return p;
}

TEST(VoiceRecording, AnOversizedVoicePacketIsRefusedByTheWriterAndTheReader) {
  const fs::path dir = temp_dir("oversized");
  const fs::path path = dir / "v.vcr";
  std::vector<uint8_t> open_image;
  {
    RecordingWriter w(path, tiny_stream());
    w.append_speaker(3, "three", 0);
    const std::vector<uint8_t> big(kMaxRecordedVoiceBytes + 1, 1);
    EXPECT_NE(error_of([&] { w.append_voice(3, 1, 1, 5, big); }).find("1276 bytes"),
              std::string::npos);
    EXPECT_NE(error_of([&] { w.append_voice(3, 1, 1, 5, {}); }).find("0 bytes"), std::string::npos);
    w.append_voice(packet(3, 1));  // the writer goes on
    open_image = file_bytes(path);
  }
  EXPECT_EQ(RecordingReader(path).info().voices.size(), 1u);
  const auto refused = [&](const std::vector<uint8_t>& record) {
    std::vector<uint8_t> b = open_image;
    b.insert(b.end(), record.begin(), record.end());
    const std::vector<uint8_t> after = framed(RecordType::kVoice, voice_payload(4, 4));
    b.insert(b.end(), after.begin(), after.end());
    put_file(dir / "bad.vcr", b);
    return error_of([&] { RecordingReader r(dir / "bad.vcr"); });
  };
  const std::string at = "at offset " + std::to_string(open_image.size());
  // A record longer than any voice, and a length field over 1275 inside a short record.
  std::string e = refused(framed(RecordType::kVoice, voice_payload(1276, 1276)));
  EXPECT_NE(e.find("voice record of 1300 bytes (over the limit of 1299) " + at), std::string::npos)
      << e;
  e = refused(framed(RecordType::kVoice, voice_payload(1276, 100)));
  EXPECT_NE(e.find("voice " + at + ": malformed voice: an Opus packet of 1276 bytes"),
            std::string::npos)
      << e;
  e = refused(framed(RecordType::kVoice, voice_payload(0, 0)));
  EXPECT_NE(e.find("an Opus packet of 0 bytes"), std::string::npos) << e;
  e = refused(framed(RecordType::kVoice, voice_payload(50, 40)));
  EXPECT_NE(e.find("does not fit"), std::string::npos) << e;
  // A voice whose speaker was never named.
  std::vector<uint8_t> stranger = voice_payload(4, 4);
  stranger[0] = 9;
  e = refused(framed(RecordType::kVoice, stranger));
  EXPECT_NE(e.find("participant 9, who has no speaker record"), std::string::npos) << e;
}

// A version-1 file as the format's comment describes it, byte by byte.
std::vector<uint8_t> version1_file(size_t frame_sets, bool closed, bool with_voice) {
  std::vector<uint8_t> f = {'V', 'C', 'R', 'E', 'C', 'O', 'R', 'D', 1, 0, 0, 0, 0, 0, 0, 0};
  wire::store<uint32_t>(f.data() + 12, crc32_of(std::span(f).first(12)));
  const RecordingStream s = tiny_stream();
  std::vector<uint8_t> stream;
  wire::Writer w(stream);
  w.put_string(s.depth_codec);
  w.put_string(s.color_codec);
  w.put<uint8_t>(0);
  w.put<int64_t>(s.started_us);
  w.put_string(s.origin);
  w.put_bytes(protocol::serialize(s.welcome));
  const auto add = [&](const std::vector<uint8_t>& r) { f.insert(f.end(), r.begin(), r.end()); };
  add(framed(RecordType::kStream, stream));
  std::vector<uint8_t> index;
  wire::Writer iw(index);
  iw.put<uint32_t>(static_cast<uint32_t>(frame_sets));
  for (size_t k = 0; k < frame_sets; ++k) {
    const std::vector<uint8_t> body = tiny_body(k);
    iw.put<uint64_t>(f.size());
    iw.put<uint64_t>(k + 1);
    iw.put<int64_t>(1'000'000 + static_cast<int64_t>(k) * 33'333);
    iw.put<uint8_t>(k % 10 == 0);
    add(framed(RecordType::kFrameSet, body));
  }
  if (with_voice) add(framed(RecordType::kVoice, voice_payload(4, 4)));
  if (closed) {
    const uint64_t index_at = f.size();
    add(framed(RecordType::kIndex, index));
    std::vector<uint8_t> end(8);
    wire::store<uint64_t>(end.data(), index_at);
    add(framed(RecordType::kEnd, end));
  }
  return f;
}

TEST(VoiceRecording, AVersion1FileWithoutVoicesStillReads) {
  const fs::path dir = temp_dir("v1");
  for (const bool closed : {true, false}) {
    put_file(dir / "v1.vcr", version1_file(12, closed, false));
    RecordingReader r(dir / "v1.vcr");
    EXPECT_EQ(r.info().version, 1);
    EXPECT_EQ(r.info().closed, closed);
    EXPECT_FALSE(r.info().incomplete_tail_at);
    EXPECT_TRUE(r.info().speakers.empty());
    EXPECT_TRUE(r.info().voices.empty());
    ASSERT_EQ(r.info().frame_sets.size(), 12u);
    std::vector<uint8_t> body;
    for (size_t k = 0; k < 12; ++k) {
      r.read(k, body);
      EXPECT_EQ(body, tiny_body(k));
    }
    EXPECT_NO_THROW(r.verify());
    EXPECT_TRUE(speaker_summaries(r.info()).empty());
  }
  // Voice records belong to version 2: in a version-1 file they are an unknown type.
  put_file(dir / "v1.vcr", version1_file(3, false, true));
  EXPECT_NE(error_of([&] { RecordingReader r(dir / "v1.vcr"); }).find("unknown type 6"),
            std::string::npos);
  // An unknown version is named.
  std::vector<uint8_t> v3 = version1_file(1, true, false);
  v3[8] = 3;
  wire::store<uint32_t>(v3.data() + 12, crc32_of(std::span(v3).first(12)));
  put_file(dir / "v1.vcr", v3);
  EXPECT_NE(error_of([&] { RecordingReader r(dir / "v1.vcr"); }).find("format version 3"),
            std::string::npos);
}

TEST(VoiceRecording, TheBackgroundRecorderQueuesVoicesAndCountsWhatItDrops) {
  const fs::path dir = temp_dir("background");
  const fs::path path = dir / "bg.vcr";
  {
    BackgroundRecorder rec(path, tiny_stream(), {}, 64, 8);
    rec.push_speaker(4, "four", 0);
    for (uint32_t n = 0; n < 40; ++n) {
      const RecordedVoicePacket p = packet(4, n);
      rec.push_voice(p.participant, p.sequence, p.frame, p.capture_us, p.bytes);
      if (n % 4 == 3) {  // let the queue drain now and then (it holds 8)
        for (int i = 0; i < 2000 && rec.stats().voice_packets + rec.stats().voice_dropped <= n; ++i)
          std::this_thread::sleep_for(std::chrono::milliseconds(1));
      }
    }
    const std::vector<uint8_t> big(kMaxRecordedVoiceBytes + 1, 0);
    rec.push_voice(4, 99, 99, 0, big);
    rec.stop();
    const RecorderStats s = rec.stats();
    EXPECT_EQ(s.voice_packets + s.voice_dropped, 41u);
    EXPECT_GE(s.voice_dropped, 1u);
    EXPECT_GE(s.voice_packets, 8u);
    EXPECT_EQ(s.error, "");
  }
  RecordingReader r(path);
  ASSERT_EQ(r.info().speakers.size(), 1u);
  EXPECT_EQ(r.info().speakers[0].name, "four");
  // What was kept is each packet as pushed, in order.
  uint32_t last = 0;
  for (const RecordedVoicePacket& p : r.voices(4)) {
    EXPECT_TRUE(same(p, packet(4, p.sequence)));
    EXPECT_TRUE(p.sequence == 0 || p.sequence > last);
    last = p.sequence;
  }
}

}  // namespace
}  // namespace volcast
