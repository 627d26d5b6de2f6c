#pragma once
// Recording a server's stream from outside it (`volcast record`; `serve --record` taps its own
// tier instead): one tier's frame sets exactly as the server sent them, to an append-only .vcr
// written on the recorder's own thread (BackgroundRecorder: a slow disk never holds up reading,
// so the server never drops what it queued for us), and, for a session, that session's voices and
// drawing, heard by a participant named "Recorder" that the others see in the session (no silent
// recording): a Speaker record for each participant heard or drawing, named as the session shows
// them, then their voice packets and annotations (drawn, erased) with the server's times.
#include <atomic>
#include <filesystem>
#include <functional>
#include <string>

#include "volcast/net/stream/client.hpp"
#include "volcast/record/recorder.hpp"

namespace volcast {

struct StreamRecordingOptions {
  std::filesystem::path out;
  RecordingWriterOptions writer;  ///< overwrite, fdatasync interval
  std::string session;            ///< the session whose voices and drawing to record; empty: none
  double seconds = 0;             ///< stop after this long (0: until stopped or the stream ends)
  const std::atomic<bool>* stop = nullptr;  ///< set: stop (Ctrl-C)
  /// Called about twice a second on the recording thread with the figures so far and the
  /// seconds since it began.
  std::function<void(const RecorderStats&, double)> progress;
};

struct StreamRecordingResult {
  RecorderStats stats;  ///< as the recorder closed the file
  double seconds = 0;   ///< how long it recorded
  std::string ended;    ///< "time", "interrupted" or "the server closed the stream"
};

/// Records `client`'s stream (connected with ClientConfig::decode false and keep_encoded true: the
/// bytes as sent; its tier, every frame set) until o.seconds, o.stop or the server closes the
/// stream; `origin` is written into the file ("volcast record HOST:PORT"). Throws Error if the
/// file cannot be made, the session cannot be joined, or the disk fails (what was written before
/// stays, and the message says how much). The result's stats say what the disk could not keep
/// up with (dropped, voice_dropped).
StreamRecordingResult record_stream(Client& client, const std::string& origin,
                                    const StreamRecordingOptions& o);

}  // namespace volcast
