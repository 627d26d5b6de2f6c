// Voices in recordings (volcast/record): Speaker and Voice records round trip through the index
// and through a scan, a file cut anywhere in its last records or a killed recorder keeps every
// complete voice, and the background recorder queues them (damaged files:
// voice_record_damage_test.cpp). The "Opus packets" are synthetic byte patterns (1..1275 bytes,
// each telling its speaker and sequence apart): records are not decoded here.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <fstream>
#include <thread>

#include "voice_record_support.hpp"
#include "volcast/record/recorder.hpp"

namespace volcast {
namespace {

using namespace voice_test;

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
  EXPECT_EQ(info.version, 3);
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

// A replay's voices (voice_plan): each packet plays as long after the last frame set captured at
// or before it as it was captured after it; the packets before the first frame set or a frame
// interval after the last have no place; a selection of frame sets plays only its own packets;
// looping moves a speaker's sequence by its packets in the pass, its frame clock by the pass.
TEST(VoiceRecording, AReplayPlaysEachVoiceWhereItFallsAmongTheFrameSets) {
  const fs::path dir = temp_dir("plan");
  const fs::path path = dir / "plan.vcr";
  {
    RecordingWriter w(path, tiny_stream());
    w.append_speaker(7, "Dr. Aiko Tanaka", 0);
    w.append_speaker(1, "OR 3", 1);
    for (uint32_t k = 0; k < 10; ++k) w.append(tiny_body(k));  // 1 s + k x 33,333 us
    for (uint32_t n = 0; n < 30; ++n) w.append_voice(packet(7, n));
    const std::vector<uint8_t> opus{0xf8, 0xff, 0xfe};
    w.append_voice(1, 5, 5, 999'000, opus);    // before the first frame set
    w.append_voice(1, 6, 7, 1'050'000, opus);  // 16,667 us after frame set 1
    w.append_voice(1, 7, 8, 1'340'000, opus);  // 40 ms after the last: past its frame interval
  }
  RecordingReader r(path);
  const RecordingInfo& info = r.info();
  const PlaybackTimeline t = playback_timeline(info.frame_sets);
  ASSERT_EQ(t.frame_interval_us, 33'333);
  // Every frame set: the pass lasts until a frame interval after the last one.
  const VoicePlan all = voice_plan(info, t, 0, 9);
  EXPECT_EQ(all.pass_us, 9 * 33'333 + 33'333);
  // Speaker 7's packet n was captured (n + n / 5) x 20 ms + 7 us after frame set 0: n <= 14 fall
  // before 1.3333 s.
  EXPECT_EQ(all.outside, 15u + 2u);
  ASSERT_EQ(all.speakers.size(), 2u);
  EXPECT_EQ(all.speakers[0].speaker.name, "Dr. Aiko Tanaka");
  EXPECT_EQ(all.speakers[0].packets, 15u);
  EXPECT_EQ(all.speakers[0].sequences_per_pass, 15u);
  EXPECT_EQ(all.speakers[0].frames_per_pass, 17u);  // frames 0..16, the pass 16.7 frames
  EXPECT_EQ(all.speakers[1].speaker.role, 1);
  EXPECT_EQ(all.speakers[1].packets, 1u);
  EXPECT_EQ(all.speakers[1].sequences_per_pass, 1u);
  EXPECT_EQ(all.speakers[1].frames_per_pass, 17u);  // the pass's length
  ASSERT_EQ(all.cues.size(), 16u);
  for (size_t c = 0; c < all.cues.size(); ++c) {
    const VoiceCue& cue = all.cues[c];
    const RecordedVoice& v = info.voices[cue.voice];
    EXPECT_EQ(cue.at_us, v.capture_us - 1'000'000) << c;
    EXPECT_EQ(cue.frame_set, static_cast<size_t>((v.capture_us - 1'000'000) / 33'333)) << c;
    EXPECT_EQ(all.speakers[cue.speaker].speaker.participant, v.participant) << c;
    if (c > 0) {
      EXPECT_GE(cue.at_us, all.cues[c - 1].at_us) << c;
    }
  }
  // Frame sets 3..6: the packets from frame set 3's capture to a frame interval after 6's, on the
  // selection's time line; speaker 1 has none there.
  const VoicePlan part = voice_plan(info, t, 3, 6);
  EXPECT_EQ(part.pass_us, 3 * 33'333 + 33'333);
  EXPECT_EQ(part.outside, all.outside);
  ASSERT_EQ(part.speakers.size(), 1u);
  ASSERT_EQ(part.cues.size(), 5u);  // packets 5..9: frames 6..10, 120..200 ms
  for (size_t c = 0; c < part.cues.size(); ++c) {
    const RecordedVoice& v = info.voices[part.cues[c].voice];
    EXPECT_EQ(v.sequence, 5 + c);
    EXPECT_EQ(part.cues[c].at_us, v.capture_us - 1'000'000 - 3 * 33'333);
  }
  EXPECT_EQ(part.speakers[0].sequences_per_pass, 5u);
  EXPECT_EQ(part.speakers[0].frames_per_pass, 7u);  // 133.3 ms: longer than frames 6..10
  // An empty selection: no plan.
  EXPECT_TRUE(voice_plan(info, t, 5, 4).cues.empty());
}

}  // namespace
}  // namespace volcast
