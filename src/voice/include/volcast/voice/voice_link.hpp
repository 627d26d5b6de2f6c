#pragma once
// A participant's voice (issue 35): its microphone encoded to Opus (audio/opus_voice.hpp) and sent
// on its session connection (session/voice_messages.hpp), and everyone else's voices received,
// each through its own jitter buffer with loss concealment (audio/voice_stream.hpp), played from
// where that speaker's head is in the room (HRTF, audio/spatial_mixer.hpp) on its loudspeaker.
// The OR site's voice plays from a point above the table. One thread runs the 20 ms loop, paced
// by the microphone (or the wall clock without one).
//
// Mouth-to-ear latency: each packet carries the capture time of its first sample on the server's
// clock; when a frame is played the link measures now (server clock) + the loudspeaker's latency
// minus that time.
#include <atomic>
#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "volcast/audio/opus_voice.hpp"
#include "volcast/audio/voice_stream.hpp"
#include "volcast/session/participant.hpp"

namespace volcast::voice {

struct VoiceConfig {
  std::string mic;      ///< devices.hpp spec: a .wav file or a device; empty: listen only
  std::string speaker;  ///< devices.hpp spec; empty: voices are received and measured, not played
  int64_t mic_start_us = 0;  ///< a file microphone's first sample (local wall clock; 0: at start)
  audio::VoiceEncoderConfig encoder;
  audio::VoiceStreamConfig playout;  ///< each heard voice's playout buffer
  bool spatial = true;               ///< HRTF to stereo; false: a mono mix (one channel)
  bool muted = false;                ///< start muted
  bool push_to_talk = false;         ///< send only while set_talking(true)
  /// Where the OR site's voice (participant 1) plays from: room frame, metres (above the table).
  Eigen::Vector3f site_position{0.0f, 1.5f, 0.0f};
  /// Volume per display name (1: as sent, 0: silent); others 1.
  std::map<std::string, float> volumes;
  /// A text file of what the loudspeaker played, or empty: a line per 20 ms block and voice,
  /// "BLOCK<TAB>ID<TAB>HOW<TAB>FRAME": the block's index in the loudspeaker's output (its file's
  /// samples BLOCK x 960 on), the speaker's participant id, how its voice played there (p: its
  /// packet, f: in-band FEC, c: concealed, s: silence -- before it spoke, DTX, a pause inserted)
  /// and the speaker's frame number it stands for (audio::PlayedFrame). A phrase said in the
  /// speaker's frames F.. is lined up with where it was heard without searching, however the
  /// path and the playout buffer delayed and paused it (tests, audits). Throws Error (in the
  /// constructor) if it cannot be written.
  std::string played_log;
};

/// One speaker as this participant hears it.
struct HeardVoice {
  uint32_t id = 0;
  std::string name;
  audio::VoiceStreamStats stream;
  double latency_ms_p50 = 0, latency_ms_p99 = 0;  ///< mouth-to-ear, played frames
  /// The newest of its frames the loudspeaker has played, from a packet or not (FEC, concealment,
  /// the silence after a talk spurt), numbered on its microphone's time line (a frame is 20 ms
  /// of it; VoiceConfig::played_log's fourth column); -1 before the first. A file's listener
  /// knows from it that a speaker's time line has been played up to a point (the tests' wait).
  int64_t played_frame = -1;
  bool speaking = false;  ///< voice energy in the last 300 ms (the avatar's speaking indicator)
  bool muted = false;     ///< its microphone is muted (the avatar's badge)
  float volume = 1;  ///< the gain it plays at: set_volume's, else VoiceConfig::volumes' by name
};

struct VoiceStats {
  /// Local wall clock of the loop's first block, the loudspeaker file's sample 0: the
  /// microphone's first block's capture time, or the loop's start without a microphone.
  int64_t started_us = 0;
  uint64_t frames_captured = 0, packets_sent = 0, dtx_frames = 0, bytes_sent = 0;
  /// 20 ms blocks the loudspeaker has played (its file's length: sample 0 at started_us).
  uint64_t frames_played = 0;
  /// Of frames_played: blocks the loop was a whole block late for (its thread did not run),
  /// played as silence while every voice's playout buffer held still (VoiceStream::hold): the
  /// stall heard as a pause, not the speech it held up lost. Files only: a sound device keeps its
  /// own clock.
  uint64_t frames_underrun = 0;
  double bytes_per_second = 0;    ///< sent, over the frames captured while not muted
  bool hrtf = false;              ///< the spatial mixer runs with HRTF
  std::vector<HeardVoice> heard;  ///< by id
};

class VoiceLink {
 public:
  /// Installs the voice handler on `participant` (which must outlive this object) and starts the
  /// loop. Throws Error on a device or file that does not open.
  VoiceLink(Participant& participant, VoiceConfig config);
  /// stop().
  ~VoiceLink();
  VoiceLink(const VoiceLink&) = delete;
  VoiceLink& operator=(const VoiceLink&) = delete;
  /// Ends the loop and removes the handler (the speaker file is complete after it). Idempotent.
  void stop();

  void set_muted(bool muted);  ///< also tells the others (VoiceState)
  bool muted() const { return muted_; }
  void set_talking(bool talking);  ///< push-to-talk pressed (with VoiceConfig::push_to_talk)
  bool talking() const { return talking_; }
  /// A participant's gain from now on (clamped to 0..4), in place of VoiceConfig::volumes'.
  void set_volume(uint32_t participant, float volume);
  /// The configuration it was made with (push_to_talk, volumes, devices).
  const VoiceConfig& config() const { return config_; }
  /// Whether the microphone (a file) has been read to its end.
  bool mic_ended() const { return mic_ended_; }
  /// The loop's error, if it stopped on one (a device failed, the disk filled).
  std::string error() const;
  VoiceStats stats() const;

 private:
  struct Speaker;
  void run();
  void capture(std::span<const float, audio::kFrameSamples> block, int64_t capture_us);
  void play(int64_t now_us);
  void play_underrun();

  Participant& participant_;
  VoiceConfig config_;
  struct Devices;
  std::unique_ptr<Devices> devices_;
  audio::VoiceEncoder encoder_;
  VoiceScene scene_;  // play()'s, reused every frame (the loop's thread only)
  std::atomic<bool> muted_{false}, talking_{false}, stopping_{false}, mic_ended_{false};
  uint32_t sequence_ = 0, frame_ = 0;
  mutable std::mutex mutex_;  // speakers_, stats_, error_
  std::map<uint32_t, std::unique_ptr<Speaker>> speakers_;
  VoiceStats stats_;
  std::string error_;
  std::thread thread_;
};

}  // namespace volcast::voice
