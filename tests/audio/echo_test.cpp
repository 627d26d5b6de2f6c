// EchoCanceller in a simulated OR: the loudspeaker plays remote speech (real recordings from
// ../shared/data/speech, looped), the microphone hears it 40 ms later, 6 dB down, through a
// seeded decaying room response, plus a little noise. After ~2 s of convergence the echo must be
// at least 20 dB down, and a local talker speaking over it must come through.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <random>
#include <vector>

#include "test_speech.hpp"
#include "volcast/audio/echo_canceller.hpp"
#include "volcast/core/error.hpp"

namespace volcast::audio {
namespace {

using test::db;
using test::energy;
using test::read_speech;

constexpr size_t kEchoDelaySamples = 40 * kSampleRate / 1000;  // 40 ms loudspeaker -> mic
constexpr long kMaxLatency = 960;  // samples: the canceller's output may lag its input by <= 20 ms

// The room: a direct path at -6 dB, then an exponentially decaying noise tail (time constant
// 10 ms, ~50 ms long, one tap every 6 samples to keep the test quick), fixed seed.
std::vector<float> room_response() {
  std::mt19937 random(35);
  std::normal_distribution<float> noise(0.0f, 1.0f);
  std::vector<float> taps(2400, 0.0f);
  taps[0] = 0.5f;
  for (size_t i = 48; i < taps.size(); i += 6) {
    const float t_ms = static_cast<float>(i) / 48.0f;
    taps[i] = 0.08f * std::exp(-t_ms / 10.0f) * noise(random);
  }
  return taps;
}

// The far end's speech, `seconds` long: the recordings one after another, looped.
std::vector<float> looped_speech(const std::vector<std::string>& names, double seconds) {
  std::vector<float> all;
  for (const std::string& name : names) {
    const std::vector<float> s = read_speech(name);
    all.insert(all.end(), s.begin(), s.end());
  }
  std::vector<float> out(static_cast<size_t>(seconds * kSampleRate));
  for (size_t i = 0; i < out.size(); ++i) out[i] = 0.7f * all[i % all.size()];
  return out;
}

// What the microphone hears of the loudspeaker: delayed, through the room, plus noise (-66 dBFS).
std::vector<float> echo_at_mic(const std::vector<float>& speaker) {
  const std::vector<float> room = room_response();
  std::vector<size_t> taps;  // the non-zero ones
  for (size_t k = 0; k < room.size(); ++k) {
    if (room[k] != 0.0f) taps.push_back(k);
  }
  std::vector<float> mic(speaker.size(), 0.0f);
  std::mt19937 random(7);
  std::normal_distribution<float> noise(0.0f, 0.0005f);
  for (size_t n = 0; n < mic.size(); ++n) {
    double sum = 0;
    for (const size_t k : taps) {
      if (n < kEchoDelaySamples + k) break;
      sum += static_cast<double>(room[k]) * speaker[n - kEchoDelaySamples - k];
    }
    mic[n] = static_cast<float>(sum) + noise(random);
  }
  return mic;
}

// Runs the canceller over whole frames: far_end(speaker) then near_end(mic) for each.
std::vector<float> cancel(EchoCanceller& aec, const std::vector<float>& speaker,
                          const std::vector<float>& mic) {
  std::vector<float> out = mic;
  for (size_t at = 0; at + kFrameSamples <= out.size(); at += kFrameSamples) {
    aec.far_end(std::span<const float, kFrameSamples>(speaker.data() + at, kFrameSamples));
    aec.near_end(std::span<float, kFrameSamples>(out.data() + at, kFrameSamples));
  }
  return out;
}

// The simulated room, built once: 9 s of far-end speech on the loudspeaker, its echo at the
// microphone, and from 6 s on a local talker (another person's recording) as loud as the echo.
struct Room {
  static constexpr size_t kConverged = 2 * kSampleRate;    // measure the echo from 2 s on
  static constexpr size_t kTalkerStart = 6 * kSampleRate;  // the local surgeon speaks from 6 s
  std::vector<float> speaker, mic, talker;
  size_t talk_end = 0;

  Room() {
    speaker = looped_speech({"Front_Left.wav", "Front_Center.wav", "Front_Right.wav"}, 9.0);
    mic = echo_at_mic(speaker);
    talker.assign(mic.size(), 0.0f);
    const std::vector<float> local = read_speech("Side_Left.wav");
    talk_end = std::min(mic.size(), kTalkerStart + local.size());
    for (size_t n = kTalkerStart; n < talk_end; ++n) {
      talker[n] = 0.5f * local[n - kTalkerStart];
      mic[n] += talker[n];
    }
  }
};

const Room& room() {
  static const Room built;
  return built;
}

struct EchoResult {
  double reduction_db = 0;  // echo energy in the mic / in the output, far-end-only frames
  double talker_kept = 0;   // correlation of the output with the local talker during double talk
  double mic_talker = 0;    // the same for the microphone itself (the echo still in it)
  EchoStats stats;
};

EchoResult run_room(int stream_delay_ms) {
  const Room& r = room();
  EchoConfig config;
  config.stream_delay_ms = stream_delay_ms;
  EchoCanceller aec(config);
  const std::vector<float> out = cancel(aec, r.speaker, r.mic);
  EchoResult result;
  result.stats = aec.stats();
  // Echo only (far end talking, no local talker): 20 ms frames where the loudspeaker is active.
  double echo_in = 0, echo_out = 0;
  for (size_t at = Room::kConverged; at + kFrameSamples <= Room::kTalkerStart;
       at += kFrameSamples) {
    const std::span<const float> far(r.speaker.data() + at - kEchoDelaySamples, kFrameSamples);
    if (energy(far) / kFrameSamples < 1e-5) continue;  // far end silent here (below -50 dBFS)
    echo_in += energy(std::span<const float>(r.mic.data() + at, kFrameSamples));
    echo_out += energy(std::span<const float>(out.data() + at, kFrameSamples));
  }
  result.reduction_db = db(echo_in / std::max(echo_out, 1e-12));
  // Double talk, compared in the speech band (above 200 Hz: webrtc's high-pass filter removes the
  // recordings' rumble) at the canceller's own latency (~14 ms).
  const auto band = [&](const std::vector<float>& x) {
    return test::speech_band({x.data() + Room::kTalkerStart, r.talk_end - Room::kTalkerStart});
  };
  const std::vector<float> talker = band(r.talker);
  result.talker_kept = test::best_correlation(band(out), talker, 0, kMaxLatency).correlation;
  result.mic_talker = test::best_correlation(band(r.mic), talker, 0, 0).correlation;
  std::printf(
      "delay hint %d ms: echo reduction %.1f dB over far-end-only frames after 2 s; double talk:"
      " output vs local talker correlation %.2f (the microphone itself %.2f); webrtc reports ERLE"
      " %.1f dB, delay %d ms\n",
      stream_delay_ms, result.reduction_db, result.talker_kept, result.mic_talker,
      result.stats.erle_db, result.stats.delay_ms);
  return result;
}

TEST(EchoTest, TheLoudspeakersEchoIsCancelledAndTheLocalTalkerKept) {
  const EchoResult known = run_room(40);  // the true loudspeaker-to-microphone delay
  EXPECT_GE(known.reduction_db, 20.0);
  EXPECT_GE(known.talker_kept, 0.6);
  EXPECT_EQ(known.stats.frames, room().mic.size() / kFrameSamples);
}

TEST(EchoTest, AWrongDelayHintStillConverges) {
  const EchoResult unknown = run_room(0);  // the canceller finds the 40 ms itself
  EXPECT_GE(unknown.reduction_db, 20.0);
  EXPECT_GE(unknown.talker_kept, 0.6);
}

TEST(EchoTest, WithoutAFarEndTheLocalTalkerPassesThrough) {
  EchoCanceller aec;
  const std::vector<float> local = read_speech("Side_Right.wav");
  const std::vector<float> silence(local.size(), 0.0f);
  const std::vector<float> out = cancel(aec, silence, local);
  const size_t frames_end = local.size() / kFrameSamples * kFrameSamples;
  const std::vector<float> out_band = test::speech_band({out.data(), frames_end});
  const std::vector<float> local_band = test::speech_band({local.data(), frames_end});
  const test::Peak kept = test::best_correlation(out_band, local_band, 0, kMaxLatency);
  std::printf("no far end: output vs talker correlation %.2f (speech band, latency %.1f ms)\n",
              kept.correlation, static_cast<double>(kept.lag) * 1000.0 / kSampleRate);
  EXPECT_GE(kept.correlation, 0.9);
}

TEST(EchoTest, AnImpossibleDelayIsAnError) {
  EchoConfig config;
  config.stream_delay_ms = -5;
  EXPECT_THROW(EchoCanceller{config}, Error);
}

}  // namespace
}  // namespace volcast::audio
