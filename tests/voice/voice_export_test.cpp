// `export --wav` on the recording's time line (voice_export.hpp): a speaker who began before the
// first frame set (a recorder whose first frame set came late) is cut at sample 0, and the speech
// after a pause (DTX: no packets) still lies where it was said. Real speech (shared data speech/)
// encoded with Opus as the voice link does; the frame sets are SYNTHETIC (exact times only).
#include <gtest/gtest.h>

#include "../record/voice_record_support.hpp"
#include "support/speech.hpp"
#include "volcast/audio/opus_voice.hpp"
#include "volcast/voice/voice_export.hpp"

namespace volcast {
namespace {

namespace fs = std::filesystem;
using audio::kFrameSamples;
using audio::kFrameUs;
using audio::kSampleRate;

TEST(VoiceExport, SpeechBeforeTheFirstFrameSetIsCutAndWhatFollowsAPauseStaysInSync) {
  const fs::path dir = voice_test::temp_dir("export_sync");
  // 300 ms of silence, "Front_Center", 300 ms, "Side_Left": the first phrase begins 200 ms before
  // the first frame set (captured at 1 s: tiny_body).
  std::vector<size_t> starts;
  const std::vector<float> said = test::phrases({"Front_Center", "Side_Left"}, 0.3, &starts);
  const int64_t t0_us = 1'000'000;
  const int64_t said_from_us =
      t0_us - 200'000 - int64_t(starts[0]) * 1'000'000 / int64_t(kSampleRate);
  uint32_t sequence = 0, before = 0;
  size_t dtx = 0;
  {
    RecordingWriter w(dir / "talk.vcr", voice_test::tiny_stream());
    w.append_speaker(5, "Dr. A", 0);
    audio::VoiceEncoder encoder;
    const size_t frames = said.size() / kFrameSamples;
    uint64_t frame_set = 0;
    for (uint32_t f = 0; f < frames; ++f) {
      const int64_t capture_us = said_from_us + int64_t{f} * kFrameUs;
      // Frame sets at their capture times, among the voices (as a recorder writes them).
      while (t0_us + int64_t(frame_set) * 33'333 <= capture_us && frame_set < 100)
        w.append(voice_test::tiny_body(frame_set++));
      const auto bytes = encoder.encode(std::span<const float, kFrameSamples>(
          said.data() + size_t(f) * kFrameSamples, kFrameSamples));
      if (encoder.last_was_dtx()) {  // silence: not sent, and no sequence number
        ++dtx;
        continue;
      }
      before += capture_us < t0_us;
      w.append_voice({5, sequence++, f, capture_us, {bytes.begin(), bytes.end()}});
    }
    w.close();
  }
  ASSERT_GE(before, 10u) << "at least the phrase's 200 ms before the first frame set";
  ASSERT_GT(dtx, 5u) << "the pause between the phrases is DTX";
  const std::vector<voice::ExportedVoice> exported = voice::export_voices(dir / "talk.vcr", dir);
  ASSERT_EQ(exported.size(), 1u);
  EXPECT_EQ(exported[0].packets, sequence);
  EXPECT_EQ(exported[0].before_start, before);
  EXPECT_EQ(exported[0].concealed, 0u);
  const audio::Pcm out = audio::read_wav(exported[0].path);
  // The first phrase after its first 200 ms at sample 0, the second where it was said on the time
  // line, within Opus's look-ahead (10 ms). The old export wrote the packets said before sample 0
  // from 0 on: it put the first phrase's rest at least 200 ms late, and (where the pause between
  // the words let it catch up) the rest of it in pieces.
  const std::vector<float> first = test::speech("Front_Center"), second = test::speech("Side_Left");
  const std::span<const float> rest = std::span<const float>(first).subspan(kSampleRate / 5);
  const std::ptrdiff_t second_at =
      std::ptrdiff_t(starts[1] - starts[0]) - std::ptrdiff_t(kSampleRate / 5);
  for (const auto& [name, phrase, at] :
       {std::tuple{"the first phrase's rest", rest, std::ptrdiff_t{0}},
        std::tuple{"the second phrase", std::span<const float>(second), second_at}}) {
    const test::Alignment found =
        test::align(phrase, out.samples, std::max<std::ptrdiff_t>(0, at - kSampleRate / 2),
                    at + kSampleRate / 2);
    std::printf("%s: %+.1f ms from where it was said, correlation %.3f\n", name,
                double(found.offset - at) * 1000.0 / kSampleRate, found.correlation);
    EXPECT_GE(found.correlation, 0.85) << name;
    EXPECT_LE(std::abs(found.offset - at), std::ptrdiff_t(kSampleRate / 100)) << name;
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace volcast
