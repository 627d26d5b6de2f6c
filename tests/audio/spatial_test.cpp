// SpatialMixer with real recorded speech (../shared/data/speech): each voice is heard from
// where it stands (left/right energy ratio and interaural delay have the sign the poses imply),
// two voices at once stay apart, distance attenuates as the inverse-distance model says, and
// several mixers work side by side (three participants in one process).
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <thread>
#include <vector>

#include "test_speech.hpp"
#include "volcast/audio/spatial_mixer.hpp"
#include "volcast/core/error.hpp"

namespace volcast::audio {
namespace {

using test::best_correlation;
using test::db;
using test::energy;
using test::read_speech;

constexpr double kPi = 3.14159265358979323846;

struct Stereo {
  std::vector<float> left, right;
};

struct VoiceInput {
  uint32_t id;
  const std::vector<float>* samples;
  float scale = 0.5f;  // keep well below OpenAL Soft's output limiter
};

// Pushes each voice frame by frame (as a receiver would) and renders one frame after each round,
// plus a few frames to let the last ones out.
Stereo render_voices(SpatialMixer& mixer, const std::vector<VoiceInput>& voices) {
  size_t frames = 0;
  for (const VoiceInput& v : voices) frames = std::max(frames, v.samples->size() / kFrameSamples);
  Stereo out;
  std::vector<float> mono(kFrameSamples);
  std::vector<float> stereo(2 * kFrameSamples);
  for (size_t f = 0; f < frames + 3; ++f) {
    for (const VoiceInput& v : voices) {
      if ((f + 1) * kFrameSamples > v.samples->size()) continue;
      for (size_t i = 0; i < kFrameSamples; ++i)
        mono[i] = v.scale * (*v.samples)[f * kFrameSamples + i];
      mixer.push(v.id, std::span<const float, kFrameSamples>(mono.data(), kFrameSamples));
    }
    mixer.render(std::span<float, 2 * kFrameSamples>(stereo.data(), 2 * kFrameSamples));
    for (size_t i = 0; i < kFrameSamples; ++i) {
      out.left.push_back(stereo[2 * i]);
      out.right.push_back(stereo[2 * i + 1]);
    }
  }
  return out;
}

struct Direction {
  double right_over_left_db = 0;
  double right_lead_us = 0;  // > 0: the right ear hears it first
};

Direction measure_direction(const Stereo& s) {
  Direction d;
  d.right_over_left_db = db(energy(s.right) / energy(s.left));
  // The left channel lags the right one by `lag` samples; search +-1 ms.
  const test::Peak peak = best_correlation(s.left, s.right, -48, 48);
  d.right_lead_us = static_cast<double>(peak.lag) * 1e6 / kSampleRate;
  return d;
}

// One voice at `where` (room frame) for a listener at the origin turned by `head` (room_from_head).
Direction one_voice(const Eigen::Vector3f& where, const Eigen::Quaternionf& head,
                    const std::vector<float>& speech) {
  SpatialMixer mixer;
  mixer.set_listener(Eigen::Vector3f::Zero(), head);
  mixer.set_source(1, where);
  return measure_direction(render_voices(mixer, {{1, &speech}}));
}

class SpatialTest : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    speech_a_ = read_speech("Front_Center.wav");
    speech_b_ = read_speech("Side_Right.wav");
    SpatialMixer probe;
    hrtf_ = probe.hrtf();
    std::printf("OpenAL Soft HRTF: status %s, data set \"%s\"\n", probe.hrtf_status().c_str(),
                probe.hrtf_name().c_str());
  }
  static std::vector<float> speech_a_, speech_b_;
  static bool hrtf_;
};
std::vector<float> SpatialTest::speech_a_;
std::vector<float> SpatialTest::speech_b_;
bool SpatialTest::hrtf_ = false;

TEST_F(SpatialTest, HrtfIsOnWithTheDefaultConfig) {
  // The direction tests below hold with plain panning too (without the interaural delay checks),
  // but on Debian with openal-data's default-48000.mhr HRTF is expected.
  EXPECT_TRUE(hrtf_) << "HRTF could not be enabled; direction is by panning only";
}

TEST_F(SpatialTest, VoiceOnTheRightIsLouderAndEarlierInTheRightEar) {
  const Eigen::Quaternionf ahead = Eigen::Quaternionf::Identity();  // looking down -z
  const Direction right = one_voice({2, 0, 0}, ahead, speech_a_);
  const Direction left = one_voice({-2, 0, 0}, ahead, speech_a_);
  std::printf("voice at +x: R/L %+.1f dB, right ear leads by %+.0f us\n", right.right_over_left_db,
              right.right_lead_us);
  std::printf("voice at -x: R/L %+.1f dB, right ear leads by %+.0f us\n", left.right_over_left_db,
              left.right_lead_us);
  EXPECT_GT(right.right_over_left_db, 3.0);
  EXPECT_LT(left.right_over_left_db, -3.0);
  if (hrtf_) {
    EXPECT_GT(right.right_lead_us, 200.0);
    EXPECT_LT(left.right_lead_us, -200.0);
  }
}

TEST_F(SpatialTest, TurningTheHeadAroundSwapsTheSides) {
  const Eigen::Quaternionf turned(
      Eigen::AngleAxisf(static_cast<float>(kPi), Eigen::Vector3f::UnitY()));
  const Direction d = one_voice({2, 0, 0}, turned, speech_a_);
  std::printf("voice at +x, head turned 180 deg: R/L %+.1f dB, right ear leads by %+.0f us\n",
              d.right_over_left_db, d.right_lead_us);
  EXPECT_LT(d.right_over_left_db, -3.0);
  if (hrtf_) {
    EXPECT_LT(d.right_lead_us, -200.0);
  }
  // A quarter turn to the left (about +y): the head looks down -x, so a voice at -z is on its
  // right.
  const Eigen::Quaternionf quarter(
      Eigen::AngleAxisf(static_cast<float>(kPi / 2), Eigen::Vector3f::UnitY()));
  const Direction q = one_voice({0, 0, -2}, quarter, speech_a_);
  std::printf("voice at -z, head turned 90 deg left: R/L %+.1f dB\n", q.right_over_left_db);
  EXPECT_GT(q.right_over_left_db, 3.0);
}

TEST_F(SpatialTest, TwoVoicesAtOnceComeFromTheirOwnSides) {
  SpatialMixer mixer;
  mixer.set_listener({0, 1.6f, 0}, Eigen::Quaternionf::Identity());
  mixer.set_source(7, {-2, 1.6f, 0});  // A on the left
  mixer.set_source(9, {2, 1.6f, 0});   // B on the right
  const Stereo s = render_voices(mixer, {{7, &speech_a_}, {9, &speech_b_}});
  // The mixer delays by one frame (it keeps one queued against jitter); search up to 25 ms.
  const long max_lag = static_cast<long>(kFrameSamples) + 240;
  const double left_a = best_correlation(s.left, speech_a_, 0, max_lag).correlation;
  const double left_b = best_correlation(s.left, speech_b_, 0, max_lag).correlation;
  const double right_a = best_correlation(s.right, speech_a_, 0, max_lag).correlation;
  const double right_b = best_correlation(s.right, speech_b_, 0, max_lag).correlation;
  std::printf("two voices: left ear corr A %.2f B %.2f; right ear corr A %.2f B %.2f\n", left_a,
              left_b, right_a, right_b);
  EXPECT_GT(left_a, left_b);
  EXPECT_GT(right_b, right_a);
  EXPECT_GT(left_a, 0.5);
  EXPECT_GT(right_b, 0.5);
}

TEST_F(SpatialTest, FartherVoicesAreQuieterByTheInverseDistanceModel) {
  auto level_at = [&](float distance) {
    SpatialMixer mixer;
    mixer.set_listener(Eigen::Vector3f::Zero(), Eigen::Quaternionf::Identity());
    mixer.set_source(3, {0, 0, -distance});
    const Stereo s = render_voices(mixer, {{3, &speech_a_}});
    return energy(s.left) + energy(s.right);
  };
  const double measured = db(level_at(4.0f) / level_at(1.0f));
  const double expected = 20.0 * std::log10(1.0 / (1.0 + 1.0 * (4.0 - 1.0)));  // ref 1, rolloff 1
  std::printf("4 m vs 1 m: %.1f dB (inverse distance: %.1f dB)\n", measured, expected);
  EXPECT_NEAR(measured, expected, 2.0);
}

TEST_F(SpatialTest, AVoiceThatStopsIsSilentAndOneThatRunsAheadIsBounded) {
  SpatialMixer mixer;
  mixer.set_source(5, {0, 0, -1});
  std::vector<float> mono(kFrameSamples);
  for (int f = 0; f < 20; ++f) {  // 400 ms pushed at once: only the newest frames are kept
    for (size_t i = 0; i < kFrameSamples; ++i) {  // a steady 440 Hz tone: every frame audible
      const double t =
          static_cast<double>(static_cast<size_t>(f) * kFrameSamples + i) / kSampleRate;
      mono[i] = static_cast<float>(0.3 * std::sin(2 * kPi * 440.0 * t));
    }
    mixer.push(5, std::span<const float, kFrameSamples>(mono.data(), kFrameSamples));
  }
  std::vector<float> stereo(2 * kFrameSamples);
  int audible = 0;
  for (int f = 0; f < 20; ++f) {
    mixer.render(std::span<float, 2 * kFrameSamples>(stereo.data(), stereo.size()));
    if (energy(stereo) / static_cast<double>(stereo.size()) > 1e-8) ++audible;
  }
  std::printf("20 frames pushed ahead: %d audible frames rendered\n", audible);
  EXPECT_GE(audible, SpatialMixer::kMaxQueuedFrames - 1);
  EXPECT_LE(audible, SpatialMixer::kMaxQueuedFrames + 1);  // + the HRTF filter's tail
  EXPECT_EQ(energy(stereo), 0.0);                          // silent once drained
  EXPECT_THROW(mixer.push(6, std::span<const float, kFrameSamples>(mono.data(), kFrameSamples)),
               Error);
  mixer.remove_source(5);
  mixer.remove_source(5);
}

TEST_F(SpatialTest, AVoicePushedFrameByFramePlaysWithoutGapsOrClicks) {
  // A steady 440 Hz tone pushed one frame per render, as a jitter buffer delivers it: after the
  // one frame the mixer holds back, every frame is as loud as the others and the waveform steps
  // no more at frame boundaries than within frames.
  SpatialMixer mixer;
  mixer.set_source(2, {1, 0, -1});
  std::vector<float> mono(kFrameSamples), stereo(2 * kFrameSamples), left;
  for (size_t f = 0; f < 30; ++f) {
    for (size_t i = 0; i < kFrameSamples; ++i) {
      const double t = static_cast<double>(f * kFrameSamples + i) / kSampleRate;
      mono[i] = static_cast<float>(0.3 * std::sin(2 * kPi * 440.0 * t));
    }
    mixer.push(2, std::span<const float, kFrameSamples>(mono.data(), kFrameSamples));
    mixer.render(std::span<float, 2 * kFrameSamples>(stereo.data(), stereo.size()));
    for (size_t i = 0; i < kFrameSamples; ++i) left.push_back(stereo[2 * i]);
  }
  double lowest = 1e9, highest = 0, step_inside = 0, step_at_boundary = 0;
  for (size_t f = 3; f < 30; ++f) {
    const std::span<const float> frame(left.data() + f * kFrameSamples, kFrameSamples);
    lowest = std::min(lowest, energy(frame));
    highest = std::max(highest, energy(frame));
    for (size_t i = 1; i < kFrameSamples; ++i) {
      step_inside = std::max(step_inside, static_cast<double>(std::abs(frame[i] - frame[i - 1])));
    }
    step_at_boundary = std::max(
        step_at_boundary, static_cast<double>(std::abs(frame[0] - left[f * kFrameSamples - 1])));
  }
  std::printf(
      "steady tone: frame energies within %.2f dB; largest step at a boundary %.4f, inside %.4f\n",
      db(highest / lowest), step_at_boundary, step_inside);
  EXPECT_LT(db(highest / lowest), 0.5);
  EXPECT_LE(step_at_boundary, 1.1 * step_inside);
}

TEST_F(SpatialTest, SeveralMixersRunAtOnceOnSeveralThreads) {
  // Three participants in one process: each has its own mixer on its own thread.
  std::vector<Direction> heard(3);
  std::vector<std::thread> threads;
  const float sides[3] = {2, -2, 2};
  for (size_t i = 0; i < 3; ++i) {
    threads.emplace_back([&, i] {
      heard[i] = one_voice({sides[i], 0, 0}, Eigen::Quaternionf::Identity(), speech_b_);
    });
  }
  for (std::thread& t : threads) t.join();
  for (size_t i = 0; i < 3; ++i) {
    if (sides[i] > 0) {
      EXPECT_GT(heard[i].right_over_left_db, 3.0) << i;
    } else {
      EXPECT_LT(heard[i].right_over_left_db, -3.0) << i;
    }
  }
}

TEST_F(SpatialTest, TooManySourcesIsAnError) {
  SpatialConfig config;
  config.max_sources = 2;
  SpatialMixer mixer(config);
  mixer.set_source(1, {1, 0, 0});
  mixer.set_source(2, {-1, 0, 0});
  mixer.set_source(2, {-1, 0, 1});  // moving a placed voice is fine
  EXPECT_THROW(mixer.set_source(3, {0, 0, 1}), Error);
  mixer.remove_source(1);
  mixer.set_source(3, {0, 0, 1});
  config.max_sources = 0;
  EXPECT_THROW(SpatialMixer{config}, Error);
}

}  // namespace
}  // namespace volcast::audio
