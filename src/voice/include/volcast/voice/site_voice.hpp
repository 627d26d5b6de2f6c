#pragma once
// The OR site speaks and listens (issue 35, item 4): the operating room's own microphone joins
// every session as the OR site's voice (participant 1), and every remote voice plays on the room's
// loudspeaker, mixed (mono: a room speaker, not headphones). Acoustic echo cancellation (Debian's
// webrtc-audio-processing, audio/echo_canceller.hpp) removes from the microphone what the
// loudspeaker played, so that a remote doctor does not hear their own voice come back.
//
// Wiring (serve): SiteVoice's send() goes to SessionHub::site_voice, and the hub's
// SessionHubConfig::site_listener calls put(). The site's clock is the server's.
#include <atomic>
#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "volcast/audio/echo_canceller.hpp"
#include "volcast/audio/opus_voice.hpp"
#include "volcast/audio/voice_stream.hpp"
#include "volcast/session/voice_messages.hpp"
#include "volcast/voice/devices.hpp"

namespace volcast::voice {

struct SiteVoiceConfig {
  audio::VoiceEncoderConfig encoder;
  audio::VoiceStreamConfig playout;  ///< each remote voice's playout buffer
  bool echo_cancellation = true;
  audio::EchoConfig echo;
  bool muted = false;
};

struct SiteVoiceStats {
  int64_t started_us = 0;  ///< wall clock of the loop's first block
  uint64_t frames_captured = 0, packets_sent = 0, dtx_frames = 0, bytes_sent = 0;
  uint64_t frames_played = 0;
  /// Of frames_played: blocks the loop was a whole block late for, played as silence while the
  /// voices' playout buffers held still (VoiceStats::frames_underrun).
  uint64_t frames_underrun = 0;
  audio::EchoStats echo;  ///< when echo cancellation runs
  struct Heard {
    uint32_t id = 0;
    audio::VoiceStreamStats stream;
    double latency_ms_p50 = 0, latency_ms_p99 = 0;  ///< mouth-to-ear
  };
  std::vector<Heard> heard;  ///< by participant id
};

class SiteVoice {
 public:
  /// Sends the site's packets (capture time on the server's clock: the wall clock here).
  using Send = std::function<void(const session::VoicePacketView& packet)>;
  /// Starts the 20 ms loop over `mic` and `speaker` (either may be null: no microphone, or
  /// voices are only measured). Throws Error if the echo canceller does not start.
  SiteVoice(SiteVoiceConfig config, std::unique_ptr<Microphone> mic,
            std::unique_ptr<Speaker> speaker, Send send);
  /// stop().
  ~SiteVoice();
  SiteVoice(const SiteVoice&) = delete;
  SiteVoice& operator=(const SiteVoice&) = delete;
  void stop();

  /// A remote participant's packet (SessionHubConfig::site_listener). Thread-safe, quick.
  void put(uint32_t participant, const session::VoicePacketView& packet);
  void set_muted(bool muted) { muted_ = muted; }
  bool mic_ended() const { return mic_ended_; }
  std::string error() const;
  SiteVoiceStats stats() const;

 private:
  struct Heard;
  void run();
  void capture(int64_t captured_us);
  /// `underrun`: the loop is a whole block late; the block is silence, the voices hold.
  void play(int64_t now_us, bool underrun);

  SiteVoiceConfig config_;
  std::unique_ptr<Microphone> mic_;
  std::unique_ptr<Speaker> speaker_;
  Send send_;
  audio::VoiceEncoder encoder_;
  std::unique_ptr<audio::EchoCanceller> echo_;
  std::vector<float> block_, heard_, mix_;
  std::atomic<bool> muted_{false}, stopping_{false}, mic_ended_{false};
  uint32_t sequence_ = 0, frame_ = 0;
  mutable std::mutex mutex_;  // heard_voices_, stats_, error_
  std::map<uint32_t, std::unique_ptr<Heard>> heard_voices_;
  SiteVoiceStats stats_;
  std::string error_;
  std::thread thread_;
};

}  // namespace volcast::voice
