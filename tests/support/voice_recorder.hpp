#pragma once
// `volcast record --session` as a child process, and a participant saying a prepared phrase list
// into it, and waiting for a loudspeaker file: what the voice tests share.
#include <gtest/gtest.h>
#include <spawn.h>
#include <sys/types.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdint>
#include <filesystem>
#include <limits>
#include <string>
#include <thread>
#include <vector>

#include "support/session_site.hpp"
#include "support/speech.hpp"
#include "support/test_paths.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/record/recording.hpp"
#include "volcast/voice/voice_link.hpp"

namespace volcast::test {

/// Waits (up to 30 s) until `listener`'s loudspeaker file reaches wall time `until_us`: a loaded
/// machine holds its loop back, and it catches up. False if it does not.
inline bool played_until(const voice::VoiceLink& listener, int64_t until_us) {
  return eventually(
      [&] {
        const voice::VoiceStats v = listener.stats();
        return v.started_us + int64_t(v.frames_played) * audio::kFrameUs >= until_us;
      },
      std::chrono::seconds(30));
}

/// Waits (up to 30 s) until every one of the `sent` packets of speaker `id` has reached
/// `listener`, however late a loaded machine delivers them, and then until its loudspeaker has
/// played on past its playout buffer's delay (plus 100 ms): what was said is in its file. False
/// if that does not happen.
inline bool heard_through(const voice::VoiceLink& listener, uint32_t id, uint64_t sent) {
  int delay_ms = 0;
  const bool arrived = eventually(
      [&] {
        for (const voice::HeardVoice& h : listener.stats().heard)
          if (h.id == id && h.stream.packets >= sent) {
            delay_ms = h.stream.delay_ms;
            return true;
          }
        return false;
      },
      std::chrono::seconds(30));
  return arrived && played_until(listener, wall_clock_us() + (int64_t(delay_ms) + 100) * 1000);
}

/// Waits (up to 30 s) until `listener` has played speaker `id`'s time line through its frame
/// `frame` (HeardVoice::played_frame): what that speaker's microphone held up to there, sent or
/// not (the silence after a phrase is not sent), is in the listener's file and its played log.
/// False if that does not happen.
inline bool played_through_frame(const voice::VoiceLink& listener, uint32_t id, int64_t frame) {
  return eventually(
      [&] {
        for (const voice::HeardVoice& h : listener.stats().heard)
          if (h.id == id && h.played_frame >= frame) return true;
        return false;
      },
      std::chrono::seconds(30));
}

/// Starts `volcast record --connect LINK --out FILE --session SESSION`; returns its pid, 0 when
/// it could not be started (a test failure is added).
inline pid_t spawn_recorder(const std::string& link, const std::string& file,
                            const std::string& session = "OR") {
  std::vector<std::string> args{
      test::paths::volcast(), "record", "--connect", link, "--out", file, "--session", session};
  std::vector<char*> argv;
  for (auto& x : args) argv.push_back(x.data());
  argv.push_back(nullptr);
  pid_t pid = 0;
  if (posix_spawn(&pid, argv[0], nullptr, nullptr, argv.data(), environ) != 0) {
    ADD_FAILURE() << "cannot start " << test::paths::volcast() << " record";
    return 0;
  }
  return pid;
}

/// `p` says `said` (48 kHz mono, written to `wav` as its microphone file) from 200 ms on, and
/// returns `tail` after the file has ended (the last packets' way through).
inline uint64_t speak(TestParticipant& p, const std::filesystem::path& wav,
                      const std::vector<float>& said) {
  voice::VoiceConfig c;
  c.mic = write_voice(wav, said).string();
  c.mic_start_us = wall_clock_us() + 200'000;
  voice::VoiceLink link(p.p(), c);
  EXPECT_TRUE(eventually([&] { return link.mic_ended(); }, std::chrono::seconds(30)));
  return link.stats().packets_sent;
}

/// Waits (up to 30 s) until the recording `file`, while its recorder writes it, holds `packets`
/// voice packets: every one a speaker sent, however late a loaded machine delivered them. False
/// if it does not.
inline bool recorded_voices(const std::filesystem::path& file, uint64_t packets) {
  return eventually(
      [&] {
        try {
          return RecordingReader(file).info().voices.size() >= packets;
        } catch (const Error&) {
          return false;  // not yet written far enough to read
        }
      },
      std::chrono::seconds(30));
}

/// Waits (up to 30 s) until the recording `file`, while its recorder writes it, holds a frame
/// set: what a speaker sends after that is captured after the file's first frame set (a replay
/// plays no voice captured before it: record/timeline.cpp, voice_plan). False if it does not.
inline bool recorded_a_frame_set(const std::filesystem::path& file) {
  return eventually(
      [&] {
        try {
          return !RecordingReader(file).info().frame_sets.empty();
        } catch (const Error&) {
          return false;  // not yet written far enough to read
        }
      },
      std::chrono::seconds(30));
}

/// Waits (up to 30 s) until the recording `file`, while its recorder writes it, holds a frame set
/// captured at or after its last voice packet. A replay plays each voice beside the frame set it
/// was captured with (record/timeline.cpp, voice_plan): a voice captured more than a frame
/// interval after the file's last frame set is not replayed. False if it does not.
inline bool recorded_frame_set_after_voices(const std::filesystem::path& file) {
  return eventually(
      [&] {
        try {
          const RecordingInfo info = RecordingReader(file).info();
          int64_t last_voice = std::numeric_limits<int64_t>::min();
          for (const RecordedVoice& v : info.voices)
            last_voice = std::max(last_voice, v.capture_us);
          for (const RecordedFrameSet& f : info.frame_sets)
            if (f.capture_us >= last_voice) return true;
          return false;
        } catch (const Error&) {
          return false;  // not yet written far enough to read
        }
      },
      std::chrono::seconds(30));
}

}  // namespace volcast::test
