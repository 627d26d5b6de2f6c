// Recording a server's stream from outside it (stream_recording.hpp).
#include "volcast/pipeline/stream_recording.hpp"

#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <chrono>
#include <map>
#include <memory>

#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/pipeline/session_client.hpp"
#include "volcast/session/annotations.hpp"

namespace volcast {
namespace {

// The recorder's participant: joins `session` as "Recorder" (heartbeats only) and hands what it
// hears and sees drawn to `recorder`. What it hears arrives on the receiving thread, inside
// client.receive(), and is queued for the recorder's thread.
std::unique_ptr<SessionClient> join_as_recorder(Client& client, BackgroundRecorder& recorder,
                                                const std::string& session,
                                                std::map<uint32_t, std::string>& speakers) {
  SessionClientOptions o;
  o.participant.session = session;
  o.participant.create = false;
  o.participant.name = "Recorder";
  o.drive_poses = false;  // heartbeats only
  auto listener = std::make_unique<SessionClient>(std::move(o));
  listener->start(client);
  Participant* p = listener->participant();
  // A Speaker record for each participant heard or drawing, named as the session shows them.
  const auto speaker = [&recorder, &speakers, p](uint32_t id) {
    if (id == 0 || speakers.contains(id)) return;  // 0: the server
    std::string name = "participant " + std::to_string(id);
    uint8_t role = 0;
    for (const RemoteParticipant& r : p->snapshot(wall_clock_us()).others)
      if (r.id == id) name = r.name, role = static_cast<uint8_t>(r.role);
    recorder.push_speaker(id, name, role);
    speakers[id] = name;
  };
  p->set_voice_handler([&recorder, speaker](uint32_t id, const session::VoicePacketView& v) {
    speaker(id);
    recorder.push_voice(id, v.sequence, v.frame, v.capture_us, v.opus);
  });
  // The drawing (annotations.hpp): those standing when it joins first, then each one drawn and
  // erased, stamped with the server's clock.
  p->set_drawing_handler([&recorder, speaker, p](uint8_t type, std::span<const uint8_t> payload) {
    try {
      speaker(type == kDrawingAnnotation ? session::parse_annotation(payload).author
                                         : session::parse_erased(payload).second);
    } catch (const Error&) {
      return;  // the participant took it, so it parses
    }
    recorder.push_drawing(type, wall_clock_us() + p->clock_offset_us(), payload);
  });
  spdlog::info("recording the voices and drawing of session '{}' (joined as 'Recorder')", session);
  return listener;
}

}  // namespace

StreamRecordingResult record_stream(Client& client, const std::string& origin,
                                    const StreamRecordingOptions& o) {
  RecordingStream stream;
  stream.tier = client.tier().tier;
  stream.started_us = wall_clock_us();
  stream.origin = origin;
  stream.welcome = client.welcome();
  BackgroundRecorder recorder(o.out, stream, o.writer);
  spdlog::info(
      "recording {} camera(s), tier {} to {} (Ctrl-C stops; the file replays whenever it stops)",
      stream.welcome.cameras.size(), to_string(stream.tier), o.out.string());
  std::map<uint32_t, std::string> speakers;  // those with a Speaker record
  std::unique_ptr<SessionClient> listener;
  if (!o.session.empty()) listener = join_as_recorder(client, recorder, o.session, speakers);
  StreamRecordingResult result;
  result.ended = "interrupted";
  ReceivedFrameSet f;
  const auto start = std::chrono::steady_clock::now();
  auto shown = start;
  while (!(o.stop && *o.stop)) {
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (o.seconds > 0 && elapsed >= o.seconds) {
      result.ended = "time";
      break;
    }
    if (!client.receive(f)) {
      result.ended = "the server closed the stream";
      break;
    }
    // A copy the recorder's thread writes while the next frame set arrives into `f`.
    auto body = std::make_shared<const std::vector<uint8_t>>(f.encoded_body);
    TierFrameSet queued;
    queued.key = f.key;
    queued.body = *body;
    queued.keep = std::move(body);
    recorder.push(queued);
    const RecorderStats st = recorder.stats();
    if (!st.error.empty()) break;  // a full disk: what was written stays (said below)
    const auto now = std::chrono::steady_clock::now();
    if (o.progress && now - shown >= std::chrono::milliseconds(500)) {
      shown = now;
      o.progress(st, elapsed);
    }
  }
  if (listener) {
    listener->participant()->set_voice_handler(nullptr);
    listener->participant()->set_drawing_handler(nullptr);
    listener->stop();
  }
  client.close();
  recorder.stop();  // writes what is queued and the index
  result.stats = recorder.stats();
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  const RecorderStats& st = result.stats;
  if (!st.error.empty())
    throw Error(
        fmt::format("record: {} ({} frame sets and {} voice packets before it are kept in {})",
                    st.error, st.frame_sets, st.voice_packets, o.out.string()));
  return result;
}

}  // namespace volcast
