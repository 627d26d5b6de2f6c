// Voice in a session (issue 35), end to end over the real stream (TLS, join token) of a real site
// (the hands sequence): real recorded speech (shared data speech/) from one participant's
// microphone file to another's loudspeaker file, spatial audio heard by a third, the OR site's
// microphone and loudspeaker in a simulated room with echo cancellation, and hostile voice
// packets. Measured: correlation after alignment, mouth-to-ear latency, level ratios, echo
// reduction.
#include <gtest/gtest.h>
#include <signal.h>
#include <sys/wait.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstring>
#include <deque>
#include <fstream>
#include <map>
#include <mutex>
#include <set>

#include "support/session_site.hpp"
#include "support/speech.hpp"
#include "support/voice_recorder.hpp"
#include "volcast/bench/impaired_link.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/pipeline/sender.hpp"
#include "volcast/record/recording.hpp"
#include "volcast/session/voice_messages.hpp"
#include "volcast/voice/site_voice.hpp"
#include "volcast/voice/voice_export.hpp"
#include "volcast/voice/voice_link.hpp"

namespace volcast {
namespace {

using namespace std::chrono_literals;
using audio::kFrameSamples;
using audio::kSampleRate;
using session::Type;
using test::eventually;
using test::named;
using test::SessionSite;
using test::stand;
using test::TestParticipant;

constexpr double kSiteFps = 5;  // the stream is not what is tested: a light one

bool sees(const TestParticipant& p, const std::string& name) {
  return p.other(name).has_value();
}

// Samples of `seconds`.
size_t samples(double seconds) {
  return static_cast<size_t>(seconds * kSampleRate);
}

// A speaks real phrases into its microphone (a file); B's loudspeaker (a file) holds them: each
// phrase correlates >= 0.9 with what A said once aligned, and arrives after the mouth-to-ear
// latency B measured from the packets' capture times.
TEST(Voice, TwoParticipantsHearEachOther) {
  SessionSite s({}, kSiteFps);
  TestParticipant a(s, test::hand_driven("A")), b(s, test::hand_driven("B"));
  ASSERT_TRUE(eventually([&] { return sees(a, "B") && sees(b, "A"); }));
  const auto dir = test::temp_dir("voice_two");
  std::vector<size_t> starts;
  const std::vector<std::string> names{"Front_Center", "Front_Left", "Side_Right"};
  // A first phrase, not measured, lets B's jitter buffer find its delay: on a loaded machine it
  // may grow in the middle of the first phrase, which then no longer matches as a whole.
  std::vector<std::string> said_names = names;
  said_names.insert(said_names.begin(), "Front_Right");
  const std::vector<float> said = test::phrases(said_names, 0.4, &starts);
  starts.erase(starts.begin());
  voice::VoiceConfig ca;
  ca.mic = test::write_voice(dir / "a_mic.wav", said).string();
  ca.mic_start_us = wall_clock_us() + 300'000;
  ca.spatial = false;
  voice::VoiceConfig cb;
  cb.speaker = (dir / "b_heard.wav").string();
  cb.played_log = (dir / "b_played.tsv").string();
  cb.spatial = false;
  voice::VoiceStats heard;
  {
    voice::VoiceLink vb(b.p(), cb);
    voice::VoiceLink va(a.p(), ca);
    ASSERT_TRUE(eventually([&] { return va.mic_ended(); }, 30s));
    const voice::VoiceStats sent = va.stats();
    // The last phrase's way through: every packet A sent, played into B's file.
    ASSERT_TRUE(test::heard_through(vb, a.now().id, sent.packets_sent));
    heard = vb.stats();
    EXPECT_EQ(va.error(), "");
    EXPECT_EQ(vb.error(), "");
    EXPECT_GT(sent.packets_sent, 100u);
    EXPECT_GT(sent.dtx_frames, 10u) << "the silences between phrases are not sent (DTX)";
    std::printf("A sent %llu packets (%llu frames of silence not sent), %.0f bytes/s\n",
                (unsigned long long)sent.packets_sent, (unsigned long long)sent.dtx_frames,
                sent.bytes_per_second);
    ca.mic_start_us -= heard.started_us;  // A's first sample, on B's file's time line
  }
  ASSERT_EQ(heard.heard.size(), 1u);
  const voice::HeardVoice& from_a = heard.heard[0];
  EXPECT_EQ(from_a.name, "A");
  EXPECT_GT(from_a.stream.frames_from_packets, 100u);
  const audio::Pcm out = audio::read_wav(dir / "b_heard.wav");
  ASSERT_EQ(out.channels, 1);
  const std::span<const float> b_heard(out.samples);
  // What B played of A, on A's time line (B's played log): a stall of a loaded machine, resumed
  // by the playout buffer as a pause inside a phrase, is taken out again.
  const test::AsSaid as_said = test::heard_as_said(b_heard, dir / "b_played.tsv", a.now().id);
  // The latency at which B played each of A's frames from packets, by its played log.
  const std::vector<double> played_ms =
      test::played_latencies_ms(dir / "b_played.tsv", a.now().id, ca.mic_start_us);
  for (size_t i = 0; i < names.size(); ++i) {
    const std::span<const float> phrase =
        std::span<const float>(said).subspan(starts[i], test::speech(names[i]).size());
    const test::Heard exact = test::heard_where_said(phrase, as_said, starts[i]);
    // Where the phrase was said, on B's time line: it is heard 0..1 s later, or as late as the
    // played log says a loaded machine's stalls held it.
    const std::ptrdiff_t at =
        std::ptrdiff_t(starts[i]) + std::ptrdiff_t(ca.mic_start_us * kSampleRate / 1'000'000);
    const size_t first = starts[i] / kFrameSamples,
                 last = (starts[i] + phrase.size() - 1) / kFrameSamples;
    double latest_ms = 1000.0 - 100.0;
    for (size_t f = first; f <= last && f < played_ms.size(); ++f)
      if (!std::isnan(played_ms[f])) latest_ms = std::max(latest_ms, played_ms[f]);
    const test::Alignment found =
        test::align(phrase, b_heard, at, at + std::ptrdiff_t(samples((latest_ms + 100.0) / 1000)));
    const double latency_ms = double(found.offset - at) * 1000.0 / kSampleRate;
    std::printf(
        "phrase '%s': correlation %.3f where it was said over %zu frames from packets (%zu "
        "concealed; %.3f as a whole in the loudspeaker's file), heard %.1f ms after it was said\n",
        names[i].c_str(), exact.correlation, exact.frames, exact.concealed, found.correlation,
        latency_ms);
    EXPECT_GT(exact.frames, 0u) << names[i];
    EXPECT_GE(exact.correlation, 0.9) << names[i];
    // The file holds the phrase where B's played log puts it: at the latency of one of its frames
    // played from packets, within a frame (the codec's delay). A stall inside the phrase, resumed
    // as a pause, leaves its two parts at two latencies; the alignment finds one of them.
    double nearest_ms = INFINITY;
    for (size_t f = first; f <= last && f < played_ms.size(); ++f)
      if (!std::isnan(played_ms[f]))
        nearest_ms = std::min(nearest_ms, std::abs(latency_ms - played_ms[f]));
    EXPECT_LE(nearest_ms, 20.0) << names[i] << ": not where B's played log puts it";
  }
  // The latency the link measured from capture times is the one B played A at, by its played log
  // (one frame of resolution either way, and the file's start is taken a moment before its first
  // block).
  std::vector<double> played;
  for (const double ms : played_ms)
    if (!std::isnan(ms)) played.push_back(ms);
  ASSERT_FALSE(played.empty());
  std::nth_element(played.begin(), played.begin() + std::ptrdiff_t(played.size() / 2),
                   played.end());
  const double played_p50 = played[played.size() / 2];
  std::printf(
      "mouth-to-ear p50 %.1f ms (%.1f ms by the played log), p99 %.1f ms; concealed %.2f %%\n",
      from_a.latency_ms_p50, played_p50, from_a.latency_ms_p99, from_a.stream.concealed_percent());
  EXPECT_NEAR(played_p50, from_a.latency_ms_p50, 45.0);
}

// C hears A on its left and B on its right (HRTF through OpenAL Soft's loopback device): the
// louder ear and the ear that hears first are the ones the poses imply; turned round, they swap.
TEST(Voice, ThreeParticipantsHearEachVoiceFromItsSpeaker) {
  SessionSite s({}, kSiteFps);
  TestParticipant a(s, test::hand_driven("A")), b(s, test::hand_driven("B")),
      c(s, test::hand_driven("C"));
  ASSERT_TRUE(eventually([&] { return sees(c, "A") && sees(c, "B") && sees(a, "C"); }));
  const Eigen::Vector3f listener(0.0f, 1.6f, 2.0f);
  stand(c, listener, 0);                                  // facing -z
  stand(a, listener + Eigen::Vector3f(-1.5f, 0, 0), 90);  // on C's left
  stand(b, listener + Eigen::Vector3f(1.5f, 0, 0), -90);  // on C's right
  ASSERT_TRUE(eventually([&] {
    const auto pa = c.other("A"), pb = c.other("B");
    return pa && pb && pa->has_pose && pb->has_pose && a.now().has_own_body;
  }));
  const auto dir = test::temp_dir("voice_three");
  const std::vector<float> phrase = test::speech("Front_Center");
  // A speaks first, then B: one voice at a time, so each ear's share is one speaker's. B's
  // microphone starts only once C has played A's to its end (an event, not a gap in time: a
  // loaded run whose A sent late, after a stall, had C play A's phrase over B's, 2 s apart as
  // said, and each ear's level held both voices).
  const auto last_frame =
      int64_t((phrase.size() + audio::kFrameSamples - 1) / audio::kFrameSamples) - 1;
  voice::VoiceConfig ca, cb, cc;
  ca.mic = test::write_voice(dir / "a.wav", phrase).string();
  cb.mic = test::write_voice(dir / "b.wav", phrase).string();
  cc.speaker = (dir / "c_heard.wav").string();  // stereo, HRTF
  cc.played_log = (dir / "c_played.tsv").string();
  voice::VoiceStats heard;
  {
    voice::VoiceLink vc(c.p(), cc);
    // Every packet each speaker sent, played into C's file (a loaded machine may hold a loop
    // back: it catches up), and C has played the speaker's time line to the microphone's end:
    // the phrase's quiet last frames are not sent, and are in C's played log only once C's loop
    // has played on past them (a loaded run whose C held B's voice back played B's last packet in
    // its last block: the phrase's last 115 ms were missing from what C heard of B).
    const auto speak = [&](TestParticipant& who, voice::VoiceConfig& config) {
      config.mic_start_us = wall_clock_us() + 300'000;
      auto link = std::make_unique<voice::VoiceLink>(who.p(), config);
      EXPECT_TRUE(eventually([&] { return link->mic_ended(); }, 30s));
      EXPECT_TRUE(test::heard_through(vc, who.now().id, link->stats().packets_sent));
      EXPECT_TRUE(test::played_through_frame(vc, who.now().id, last_frame));
      return link;
    };
    const auto va = speak(a, ca);
    ASSERT_FALSE(HasFailure()) << "C heard A to its end";
    const auto vb = speak(b, cb);
    ASSERT_FALSE(HasFailure()) << "C heard B to its end";
    heard = vc.stats();
    EXPECT_EQ(vc.error(), "");
  }
  // One voice at a time in what C played (its played log: block, speaker, how, frame): no block
  // played a frame of both phrases (silence, and the quiet packets a speaker sends after its
  // phrase, aside).
  {
    std::ifstream log(dir / "c_played.tsv");
    std::map<uint64_t, std::set<uint32_t>> voiced;
    uint64_t block = 0;
    uint32_t id = 0, frame = 0;
    char how = 0;
    while (log >> block >> id >> how >> frame)
      if (how != 's' && int64_t{frame} <= last_frame) voiced[block].insert(id);
    ASSERT_FALSE(voiced.empty());
    size_t both = 0;
    for (const auto& entry : voiced) both += entry.second.size() > 1;
    EXPECT_EQ(both, 0u) << "blocks in which C played A and B at once";
  }
  std::printf("HRTF: %s\n", heard.hrtf ? "on" : "off (panning)");
  const audio::Pcm out = audio::read_wav(dir / "c_heard.wav");
  ASSERT_EQ(out.channels, 2);
  const std::vector<float> left = test::channel(out, 0), right = test::channel(out, 1);
  // What C played of each speaker, each ear, on that speaker's time line (C's played log): the
  // phrase is where it was said however late a loaded machine delivered it.
  for (const bool first : {true, false}) {
    const uint32_t id = (first ? a : b).now().id;
    const test::AsSaid l_said = test::heard_as_said(left, dir / "c_played.tsv", id);
    const test::AsSaid r_said = test::heard_as_said(right, dir / "c_played.tsv", id);
    std::vector<float> mono(std::min(l_said.samples.size(), r_said.samples.size()));
    for (size_t i = 0; i < mono.size(); ++i) mono[i] = l_said.samples[i] + r_said.samples[i];
    const test::Alignment found = test::align(phrase, mono, -1440, 1440);  // where it was said
    const size_t from = size_t(std::max<std::ptrdiff_t>(found.offset, 0)), n = phrase.size();
    ASSERT_LE(from + n, mono.size()) << "C played the phrase to its end";
    const double l = test::energy(l_said.samples, from, n),
                 r = test::energy(r_said.samples, from, n);
    const int lag = test::interaural_lag(l_said.samples, r_said.samples, from, n);
    std::printf("%s: correlation %.3f, left/right %.1f dB, right ear %d µs %s\n",
                first ? "A (left)" : "B (right)", found.correlation, test::db(l / r),
                lag * 1'000'000 / kSampleRate, lag > 0 ? "later" : "earlier");
    if (first) {
      EXPECT_GT(test::db(l / r), 3.0);
      EXPECT_GT(lag, 0) << "the left ear hears A first";
    } else {
      EXPECT_LT(test::db(l / r), -3.0);
      EXPECT_LT(lag, 0) << "the right ear hears B first";
    }
  }
}

// Over a real impaired path (50 ms round trip, 2 % of the IP packets lost each way, in both the
// speaker's and the listener's connection: TCP retransmits, so losses arrive late), B hears A
// through the talk-spurt playout buffer and C through speexdsp's jitter buffer, at the same time:
// both are measured and printed (latency, concealed share, correlation), B's asserted: every
// phrase arrives (>= 0.75 each, >= 0.85 on average, where it was said: B's played log takes out
// the pauses a TCP stall made).
TEST(Voice, SpeechCrossesAnImpairedPath) {
  std::string why;
  auto link = ImpairedLink::create({.one_way_delay_us = 25'000, .loss = 0.02}, &why);
  if (!link) GTEST_SKIP() << why;
  SessionHub hub;
  hub.create_session("OR");
  SitePlayer site(two_camera_site(test::data_dir()), 30);
  ServerConfig config;
  config.bind_address = link->server_address();
  config.port = 0;
  config.session = &hub;
  auto server =
      link->in_server_namespace([&] { return std::make_unique<Server>(site.cameras(), config); });
  hub.attach(server.get());
  ClientConfig c = client_config_from_link(server->join_link(link->server_address()));
  c.decode = false;
  c.receive_timeout_ms = 0;
  {
    // Sockets made in the client namespace stay there.
    auto participant = [&](const char* name) {
      return link->in_client_namespace(
          [&] { return std::make_unique<TestParticipant>(c, test::hand_driven(name)); });
    };
    auto a = participant("A"), b = participant("B"), cc = participant("C");
    ASSERT_TRUE(eventually([&] { return sees(*a, "B") && sees(*b, "A") && sees(*cc, "A"); }));
    const auto dir = test::temp_dir("voice_impaired");
    std::vector<size_t> starts;
    const std::vector<std::string> names{"Front_Center", "Front_Left", "Front_Right", "Side_Left",
                                         "Side_Right"};
    const std::vector<float> said = test::phrases(names, 0.3, &starts);
    voice::VoiceConfig ca, cb, ccc;
    ca.mic = test::write_voice(dir / "a.wav", said).string();
    ca.mic_start_us = wall_clock_us() + 300'000;
    ca.spatial = cb.spatial = ccc.spatial = false;
    cb.speaker = (dir / "b_heard.wav").string();
    cb.played_log = (dir / "b_played.tsv").string();
    ccc.speaker = (dir / "c_heard.wav").string();
    ccc.playout = {.playout = audio::PlayoutKind::kSpeexdsp, .max_late_percent = 1};  // as shipped
    voice::VoiceStats heard_b, heard_c;
    {
      voice::VoiceLink vb(b->p(), cb), vc(cc->p(), ccc);
      voice::VoiceLink va(a->p(), ca);
      ASSERT_TRUE(eventually([&] { return va.mic_ended(); }, 40s));
      std::this_thread::sleep_for(1s);
      heard_b = vb.stats();
      heard_c = vc.stats();
    }
    const auto counters = link->counters();
    std::printf("50 ms RTT + 2%% loss: %llu + %llu IP packets lost\n",
                (unsigned long long)counters.client_to_server.dropped_loss,
                (unsigned long long)counters.server_to_client.dropped_loss);
    EXPECT_GT(counters.client_to_server.dropped_loss + counters.server_to_client.dropped_loss, 0u);
    // Each phrase's correlation: where it was said, for a listener with a played log (B), else
    // the better of as a whole and in pieces in its loudspeaker's file (test::hear: where a stall
    // was heard as a pause, the rest of the phrase comes later).
    auto measure = [&](const char* who, const voice::VoiceStats& heard, const std::string& file,
                       const std::string& played_log) {
      const voice::HeardVoice* h = nullptr;
      for (const voice::HeardVoice& v : heard.heard)
        if (v.name == "A") h = &v;
      EXPECT_NE(h, nullptr) << who;
      if (h == nullptr) return std::vector<double>(names.size(), 0.0);
      std::printf(
          "%s (%s): mouth-to-ear p50 %.1f ms, p99 %.1f ms; %.2f %% of talking frames concealed "
          "(%llu late packets); %llu quiet frames inserted, %llu skipped\n",
          who, file.c_str(), h->latency_ms_p50, h->latency_ms_p99, h->stream.concealed_percent(),
          (unsigned long long)h->stream.late, (unsigned long long)h->stream.frames_inserted,
          (unsigned long long)h->stream.frames_skipped);
      const audio::Pcm out = audio::read_wav(dir / file);
      const auto offset =
          std::ptrdiff_t((ca.mic_start_us - heard.started_us) * kSampleRate / 1'000'000);
      const test::AsSaid as_said = played_log.empty()
                                       ? test::AsSaid{}
                                       : test::heard_as_said(out.samples, dir / played_log, h->id);
      std::vector<double> best;
      for (size_t i = 0; i < names.size(); ++i) {
        const std::span<const float> phrase =
            std::span<const float>(said).subspan(starts[i], test::speech(names[i]).size());
        if (!played_log.empty()) {
          best.push_back(test::heard_where_said(phrase, as_said, starts[i]).correlation);
          std::printf("  phrase '%s': correlation %.3f where it was said\n", names[i].c_str(),
                      best.back());
          continue;
        }
        const std::ptrdiff_t at = offset + std::ptrdiff_t(starts[i]);
        const test::Hearing found =
            test::hear(phrase, out.samples, at, at + std::ptrdiff_t(samples(1.5)));
        best.push_back(found.correlation());
        std::printf("  phrase '%s': correlation %.3f whole, %.3f in pieces of 100 ms\n",
                    names[i].c_str(), found.whole.correlation, found.resumed);
      }
      return best;
    };
    const std::vector<double> b_best =
        measure("B, talk-spurt buffer", heard_b, "b_heard.wav", "b_played.tsv");
    measure("C, speexdsp", heard_c, "c_heard.wav", "");
    double mean = 0;
    for (size_t i = 0; i < names.size(); ++i) {
      EXPECT_GE(b_best[i], 0.75) << names[i];
      mean += b_best[i] / double(names.size());
    }
    EXPECT_GE(mean, 0.85);
  }
  hub.attach(nullptr);
  server->stop();
}

// A room for the OR site's microphone and loudspeaker (synthetic): what the loudspeaker plays
// reaches the microphone 30 ms later at half its amplitude, plus the OR's own talker (a real
// voice, from `local`, from the microphone's sample `local_from` on), in real time.
struct SimulatedRoom {
  std::mutex mutex;
  std::deque<float> air;    // played, not yet heard
  std::vector<float> echo;  // every sample of echo the microphone picked up
  std::vector<float> local;
  size_t local_from = SIZE_MAX;
  size_t heard = 0;
  int64_t start_us = 0;

  SimulatedRoom() { air.resize(samples(0.030), 0.0f); }

  struct Mic final : voice::Microphone {
    SimulatedRoom& room;
    size_t blocks = 0;
    explicit Mic(SimulatedRoom& r) : room(r) {}
    int64_t read(std::span<float, kFrameSamples> out) override {
      const int64_t at = room.start_us + int64_t(blocks++) * audio::kFrameUs;
      const int64_t wait = at + audio::kFrameUs - wall_clock_us();
      if (wait > 0) std::this_thread::sleep_for(std::chrono::microseconds(wait));
      std::lock_guard lock(room.mutex);
      for (float& x : out) {
        float e = 0;
        if (room.air.size() > samples(0.030)) {
          e = 0.5f * room.air.front();
          room.air.pop_front();
        }
        room.echo.push_back(e);
        const size_t i = room.heard - room.local_from;  // wraps to huge before local_from
        x = e + (room.heard >= room.local_from && i < room.local.size() ? room.local[i] : 0.0f);
        ++room.heard;
      }
      return at;
    }
    bool ended() const override { return false; }
    bool on_wall_clock() const override { return true; }
  };
  struct Speaker final : voice::Speaker {
    SimulatedRoom& room;
    explicit Speaker(SimulatedRoom& r) : room(r) {}
    int channels() const override { return 1; }
    void write(std::span<const float> block) override {
      std::lock_guard lock(room.mutex);
      room.air.insert(room.air.end(), block.begin(), block.end());
    }
    int64_t latency_us() const override { return 0; }
    bool on_wall_clock() const override { return true; }
  };
};

// The OR site: B's voice plays on the OR's loudspeaker and comes back into its microphone (the
// simulated room); echo cancellation removes it: B hears its own voice back >= 20 dB below the
// echo the microphone picked up. The OR's own talker, once B's voice has played out, still
// reaches B.
TEST(Voice, OrSiteCancelsItsLoudspeakersEcho) {
  std::atomic<voice::SiteVoice*> site_voice{nullptr};
  SessionHubConfig config;
  config.site_listener = [&](uint32_t id, const session::VoicePacketView& p) {
    if (voice::SiteVoice* v = site_voice.load()) v->put(id, p);
  };
  SessionSite s(config, kSiteFps);
  TestParticipant b(s, test::hand_driven("B"));
  ASSERT_TRUE(eventually([&] { return b.now().joined; }));
  const auto dir = test::temp_dir("voice_echo");
  // B talks for 4 s (phrases); the OR's talker says one phrase after that.
  const std::vector<std::string> names{"Front_Center", "Front_Left", "Front_Right"};
  const std::vector<float> b_said = test::phrases(names, 0.2);
  SimulatedRoom room;
  room.start_us = wall_clock_us() + 300'000;
  const std::vector<float> or_phrase = test::speech("Side_Left");
  room.local = or_phrase;
  voice::VoiceConfig cb;
  cb.mic = test::write_voice(dir / "b.wav", b_said).string();
  cb.mic_start_us = room.start_us;
  cb.speaker = (dir / "b_heard.wav").string();
  cb.played_log = (dir / "b_played.tsv").string();
  cb.spatial = false;
  voice::VoiceStats heard;
  voice::SiteVoiceStats site;
  {
    voice::SiteVoice v({}, std::make_unique<SimulatedRoom::Mic>(room),
                       std::make_unique<SimulatedRoom::Speaker>(room),
                       [&](const session::VoicePacketView& p) { s.hub.site_voice(p); });
    site_voice = &v;
    voice::VoiceLink vb(b.p(), cb);
    // The OR's talker speaks 0.5 s after the loudspeaker played B's last packet, not at a time
    // set in advance: a loaded machine delays B's voice at the OR (a stalled path, a held
    // loop), and the OR's phrase then began under it -- double talk, which the canceller
    // rightly damps (CI: its first 16 frames 10-20 dB down, 0.649).
    ASSERT_TRUE(eventually([&] { return vb.mic_ended(); }, 30s));
    const uint64_t b_sent = vb.stats().packets_sent;
    uint64_t played_then = 0;
    int delay_ms = 0;
    ASSERT_TRUE(eventually(
        [&] {
          const voice::SiteVoiceStats now = v.stats();
          for (const auto& h : now.heard)
            if (h.id == b.now().id && h.stream.packets >= b_sent) {
              played_then = now.frames_played;
              delay_ms = h.stream.delay_ms;
              return true;
            }
          return false;
        },
        30s));
    // Its last packet, due delay_ms after it arrived, and a frame more: counted in blocks played.
    const uint64_t blocks = uint64_t(delay_ms) / 20 + 2;
    ASSERT_TRUE(eventually([&] { return v.stats().frames_played >= played_then + blocks; }, 30s));
    {
      std::lock_guard lock(room.mutex);
      room.local_from = room.heard + samples(0.5);
    }
    ASSERT_TRUE(eventually(
        [&] {
          std::lock_guard lock(room.mutex);
          return room.heard > room.local_from + room.local.size() + samples(0.5);
        },
        30s));
    // The OR's phrase's way to B: every packet the OR sent, played into B's file.
    ASSERT_TRUE(test::heard_through(vb, 1, v.stats().packets_sent));  // the OR site is 1
    heard = vb.stats();
    site_voice = nullptr;
    site = v.stats();
    EXPECT_EQ(v.error(), "");
  }
  std::printf("echo canceller: ERLE %.1f dB (its own figure), delay %d ms\n", site.echo.erle_db,
              site.echo.delay_ms);
  const audio::Pcm out = audio::read_wav(dir / "b_heard.wav");
  const std::vector<float> b_heard = out.samples;
  // The echo the microphone picked up while B talked, after the canceller's first second.
  const size_t from = samples(1.0), n = b_said.size() - samples(1.0);
  std::vector<float> echo;
  {
    std::lock_guard lock(room.mutex);
    echo = room.echo;
  }
  const double echo_energy = test::energy(echo, from, n);
  // What B heard back over the same stretch: the room's time line starts at room.start_us.
  const auto offset = size_t((room.start_us - heard.started_us) * kSampleRate / 1'000'000);
  const double back = test::energy(b_heard, offset + from, n + samples(0.2));
  std::printf("echo at the OR's microphone %.1f dBFS, heard back by B %.1f dBFS: %.1f dB less\n",
              test::db(echo_energy), test::db(back), test::db(echo_energy / back));
  EXPECT_GT(test::db(echo_energy), -40.0) << "the room fed B's voice back";
  EXPECT_GE(test::db(echo_energy / back), 20.0);
  // The OR's own talker reaches B, where the OR said it: its microphone's blocks are the room's
  // samples from the first, so the phrase is at the room's sample where it begins, on the OR's
  // time line as B played it (B's played log: a stall of a loaded machine, resumed as a pause,
  // is taken out again). The canceller's band split shifts bands of different pitch by up to a
  // millisecond against each other, so the phrase is compared below about 2 kHz (align_band).
  const size_t or_said_at = room.local_from;
  const test::AsSaid as_said =
      test::heard_as_said(b_heard, dir / "b_played.tsv", 1);  // the OR site is participant 1
  const test::Heard found = test::heard_where_said(or_phrase, as_said, or_said_at, true);
  std::printf(
      "the OR's talker at B: correlation %.3f below 2 kHz where it was said, over %zu frames from "
      "packets (%zu concealed)\n",
      found.correlation, found.frames, found.concealed);
  EXPECT_GT(found.frames, 0u);
  EXPECT_GE(found.correlation, 0.7);
}

// A malformed voice packet loses only itself; kMaxMalformedVoice of them drop the sender; the
// others go on. A packet reaches the others stamped with its sender's id, whatever it carries.
TEST(Voice, MalformedPacketsLoseThemselvesThenTheirSender) {
  SessionSite s({}, kSiteFps);
  TestParticipant good(s, test::hand_driven("Good")), bad(s, test::hand_driven("Bad"));
  ASSERT_TRUE(eventually([&] { return sees(good, "Bad") && sees(bad, "Good"); }));
  std::mutex mutex;
  std::vector<uint32_t> from;
  good.p().set_voice_handler([&](uint32_t id, const session::VoicePacketView&) {
    std::lock_guard lock(mutex);
    from.push_back(id);
  });
  const uint8_t opus_silence[] = {0xf8, 0xff, 0xfe};  // an Opus 20 ms CELT frame, RFC 6716
  bad.p().send_voice({1, 1, wall_clock_us(), opus_silence});
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(mutex);
    return from.size() == 1;
  }));
  EXPECT_EQ(from[0], bad.now().id) << "stamped with its sender";
  // An Opus length over the limit (within the message's limit): that packet only.
  std::vector<uint8_t> oversized(session::kMaxVoiceOpusBytes + 1, 0x55);
  std::vector<uint8_t> payload = session::serialize({2, 2, 0, opus_silence});
  payload.resize(16);
  wire::Writer(payload).put_bytes(oversized);
  for (uint32_t i = 1; i < session::kMaxMalformedVoice; ++i)
    bad.client->post_session(session::message(Type::kVoice, payload));
  bad.p().send_voice({3, 3, wall_clock_us(), opus_silence});
  ASSERT_TRUE(eventually([&] {
    std::lock_guard lock(mutex);
    return from.size() == 2;
  }));
  EXPECT_FALSE(bad.ended) << "dropped for fewer than kMaxMalformedVoice bad packets";
  EXPECT_EQ(s.hub.stats().voice_malformed, session::kMaxMalformedVoice - 1);
  bad.client->post_session(session::message(Type::kVoice, payload));
  EXPECT_TRUE(eventually([&] { return bad.ended.load(); })) << "the server did not drop it";
  EXPECT_TRUE(eventually([&] { return !sees(good, "Bad"); }));
  EXPECT_FALSE(good.ended) << good.error;
  good.p().set_voice_handler(nullptr);
}

// Mute reaches the others (the avatar's badge), and a muted microphone sends nothing.
TEST(Voice, MuteIsShownAndSendsNothing) {
  SessionSite s({}, kSiteFps);
  TestParticipant a(s, test::hand_driven("A")), b(s, test::hand_driven("B"));
  ASSERT_TRUE(eventually([&] { return sees(a, "B") && sees(b, "A"); }));
  const auto dir = test::temp_dir("voice_mute");
  voice::VoiceConfig ca;
  ca.mic = test::write_voice(dir / "a.wav", test::speech("Front_Center")).string();
  ca.muted = true;
  voice::VoiceLink va(a.p(), ca);
  ASSERT_TRUE(eventually([&] { return b.other("A")->muted; }));
  ASSERT_TRUE(eventually([&] { return va.mic_ended(); }, 30s));
  EXPECT_EQ(va.stats().packets_sent, 0u);
  EXPECT_EQ(b.other("A")->voice_packets, 0u);
  va.set_muted(false);
  EXPECT_TRUE(eventually([&] { return !b.other("A")->muted; }));
  // A latecomer sees the state too.
  va.set_muted(true);
  TestParticipant late(s, test::hand_driven("Late"));
  EXPECT_TRUE(eventually([&] { return sees(late, "A") && late.other("A")->muted; }));
}

// `volcast record --session` records the voices with the stream; killed (SIGKILL) after the
// speech, its file keeps every voice packet written, and `export --wav` gives the speech back
// (each phrase correlates >= 0.85 with what A said: Opus's own fidelity) with A's name.
TEST(Voice, AKilledRecorderKeepsTheVoicesAndExportGivesThemBack) {
  SessionSite s({}, kSiteFps);
  TestParticipant a(s, test::hand_driven("A"));
  ASSERT_TRUE(eventually([&] { return a.now().joined; }));
  const auto dir = test::temp_dir("voice_record");
  const std::string file = (dir / "talk.vcr").string();
  const pid_t pid = test::spawn_recorder(s.link(), file);
  ASSERT_NE(pid, 0);
  ASSERT_TRUE(eventually([&] { return sees(a, "Recorder"); }));
  std::vector<size_t> starts;
  const std::vector<std::string> names{"Front_Center", "Side_Left"};
  const std::vector<float> said = test::phrases(names, 0.3, &starts);
  // Killed once its file holds every packet A sent (on a loaded machine, later).
  ASSERT_TRUE(test::recorded_voices(file, test::speak(a, dir / "a.wav", said)));
  kill(pid, SIGKILL);
  int status = 0;
  waitpid(pid, &status, 0);
  RecordingReader reader(file);
  ASSERT_EQ(reader.info().speakers.size(), 1u);
  EXPECT_EQ(reader.info().speakers[0].name, "A");
  const size_t packets = reader.info().voices.size();
  EXPECT_GT(packets, 100u);
  const auto exported = voice::export_voices(file, dir / "wav");
  ASSERT_EQ(exported.size(), 1u);
  EXPECT_EQ(exported[0].packets, packets);
  std::printf("killed recorder: %zu voice packets kept, %zu frame sets; exported %.1f s\n", packets,
              reader.info().frame_sets.size(), exported[0].seconds);
  const audio::Pcm out = audio::read_wav(exported[0].path);
  for (size_t i = 0; i < names.size(); ++i) {
    const std::span<const float> phrase =
        std::span<const float>(said).subspan(starts[i], test::speech(names[i]).size());
    const test::Alignment found =
        test::align(phrase, out.samples, 0, std::ptrdiff_t(out.samples.size() - phrase.size()));
    std::printf("exported phrase '%s': correlation %.3f\n", names[i].c_str(), found.correlation);
    // Opus itself (VBR, about 20 kbit/s on this speech) keeps 0.89..0.94 of these phrases.
    EXPECT_GE(found.correlation, 0.85) << names[i];
  }
}

}  // namespace
}  // namespace volcast
