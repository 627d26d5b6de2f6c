#pragma once
// Replaying a recording (volcast/record/recording.hpp) as a site: its frame sets published to a
// Server at the pace they were recorded, decoded for every other tier and passed through as
// recorded to viewers of the recorded tier (no re-encoding); its voices (format version 2) sent to
// the sessions' participants in sync with the frame sets, each recorded speaker a participant of
// the SessionHub (SessionHub::add_recorded_speaker); its drawing (format version 3: annotations
// drawn and erased) applied to the sessions at its time on the same timeline
// (SessionHub::recorded_drawing).
#include <atomic>
#include <chrono>
#include <filesystem>
#include <functional>
#include <map>
#include <memory>
#include <thread>
#include <vector>

#include "volcast/core/frame_pool.hpp"
#include "volcast/net/stream/server.hpp"
#include "volcast/record/decode.hpp"
#include "volcast/record/recording.hpp"
#include "volcast/session/voice_messages.hpp"

namespace volcast {

class SessionHub;

struct ReplayOptions {
  double from_s = 0;  ///< start this many seconds after the recording's first frame set
  double to_s = -1;   ///< stop this many seconds after it (< 0: at its end)
  bool loop = true;   ///< start again at `from_s` after `to_s`
};

class ReplayPlayer {
 public:
  using Publish = std::function<void(std::shared_ptr<const CapturedFrameSet>)>;
  /// One recorded voice packet to send: `speaker` is its recorded participant id (a
  /// VoicePlan::Speaker's), the packet's sequence and frame renumbered for its pass and its
  /// capture time when it plays (this machine's wall clock, as the frame sets' capture times).
  using Speak = std::function<void(uint32_t speaker, const session::VoicePacketView& packet)>;
  /// One recorded drawing message to apply: session message `type` (0x51 Annotation, 0x52 Erased)
  /// and its payload exactly as recorded (annotations.hpp; ids and authors the recorded session's).
  using Draw = std::function<void(uint8_t type, std::span<const uint8_t> payload)>;

  /// Opens the recording (RecordingReader: throws Error naming what is wrong with the file) and
  /// picks the frame sets played in [from_s, to_s] after its first (timeline()). Throws Error if
  /// that range holds none, or the recording's codecs are not in this build.
  ReplayPlayer(const std::filesystem::path& path, ReplayOptions options = {});
  ~ReplayPlayer();

  /// The cameras as the recording's server announced them (calibration, world_from_camera,
  /// names).
  std::vector<protocol::CameraInfo> cameras() const;
  const RecordingInfo& info() const { return reader_.info(); }
  /// The selected frame sets: [first_frame_set(), last_frame_set()] of info().frame_sets.
  size_t first_frame_set() const { return first_; }
  size_t last_frame_set() const { return last_; }
  /// Frame sets per second of the selected range (as recorded).
  double fps() const;
  /// When each frame set plays: its recorded capture time minus the first one's, with absurd gaps
  /// (backwards, or over kMaxReplayGapUs: a lying or edited file) clamped to the frame interval
  /// and logged once when the player opens the file.
  const PlaybackTimeline& timeline() const { return timeline_; }
  /// The recorded voices of the selected range and when they play (voice_plan(); empty for a
  /// recording without voices). Voices outside the recording's frame sets are counted there and
  /// logged once when the player opens the file.
  const VoicePlan& voices() const { return voices_; }
  /// The recorded drawing of the selected range and when it plays in a pass (drawing_plan(): what
  /// was drawn before the range at 0; empty for a recording without drawing). Its records are read
  /// when the player opens the file; one that cannot be read is skipped with a warning.
  const std::vector<DrawingCue>& drawing() const { return drawing_; }
  /// Starts publishing on a background thread: in pass p (0, 1, ... while looping; each lasts
  /// voices().pass_us, one frame interval past its last frame set) frame set k at the start time
  /// plus p x pass_us plus its timeline() offset minus the first selected one's, stamped with
  /// that time on this machine's wall clock (as the voices are: a thread woken late adds latency,
  /// never a shift between clouds and voices) and carrying its recorded body
  /// (CapturedFrameSet::encoded). Voice
  /// cues go to `speak` (none: voices are not played) from a second thread on the same schedule,
  /// at_us into their pass, so that decoding a frame set never holds up a voice. A frame set that
  /// cannot be read or decoded is skipped with one warning naming it and the offset; so is a
  /// voice record (its CRC fails, it differs from the index), once, and in later passes silently.
  /// Drawing cues go to `draw` (none: not played) from a third thread on the same schedule; when
  /// a looping pass ends, every annotation it added and did not erase is erased (a 0x52 by 0, the
  /// server, for its recorded id), so that the next pass begins as the recording did.
  void start(Publish publish, Speak speak = {}, Draw draw = {});
  /// As start(Server&, SessionHub*), publishing to `publish`.
  void start(Publish publish, SessionHub* hub);
  /// Publishes to `server`; with a `hub`, each speaker of voices() becomes a recorded speaker of
  /// the hub (add_recorded_speaker: its recorded name, " (recorded)"; a recorded OR site placed
  /// above the table) and its voice goes to every session's participants (recorded_voice). So does
  /// each author (or eraser) of the recording's drawing that has a Speaker record; the drawing is
  /// applied to every session (recorded_drawing), as drawn by that recorded speaker (by 0, as the
  /// server, where the recording does not name one). The hub keeps the speakers, and the
  /// annotations standing, after stop(); a later start() with the same hub reuses the speakers.
  void start(Server& server, SessionHub* hub = nullptr);
  /// Stops the threads (returns once they have). Idempotent.
  void stop();
  uint64_t frame_sets_published() const { return published_; }
  uint64_t frame_sets_skipped() const { return skipped_; }
  uint64_t voices_sent() const { return voices_sent_; }
  uint64_t voices_skipped() const { return voices_skipped_; }  ///< unreadable records, each pass
  uint64_t drawings_sent() const { return drawings_sent_; }    ///< drawing cues played (all passes)
  /// True once a non-looping replay has published its last frame set.
  bool finished() const { return frames_done_ && voices_done_ && drawing_done_; }

 private:
  using Clock = std::chrono::steady_clock;
  void run(const Publish& publish, Clock::time_point epoch, int64_t epoch_wall_us);
  void run_voices(const Speak& speak, Clock::time_point epoch, int64_t epoch_wall_us);
  void run_drawing(const Draw& draw, Clock::time_point epoch);
  bool sleep_until(Clock::time_point due) const;  // false if stopped meanwhile
  RecordingReader reader_;
  RecordingDecoder decoder_;
  ReplayOptions options_;
  PlaybackTimeline timeline_;    // when each frame set plays (absurd gaps clamped)
  size_t first_ = 0, last_ = 0;  // the selected frame sets [first_, last_]
  FramePool buffers_;            // per camera, recycled
  VoicePlan voices_;
  std::vector<uint8_t> bad_voice_;  // per cue: its record could not be read (warned once)
  std::vector<DrawingCue> drawing_;
  std::vector<std::vector<uint8_t>> drawing_payloads_;  // per cue, read on opening (empty: bad)
  SessionHub* hub_ = nullptr;  // the hub the speakers were added to, and their ids there
  std::map<uint32_t, uint32_t> hub_ids_;
  std::thread thread_, voice_thread_, drawing_thread_;
  std::atomic<bool> stop_{false}, frames_done_{false}, voices_done_{false}, drawing_done_{false};
  std::atomic<uint64_t> published_{0}, skipped_{0}, voices_sent_{0}, voices_skipped_{0};
  std::atomic<uint64_t> drawings_sent_{0};
};

}  // namespace volcast
