// volcast record, export and info FILE.vcr: recordings of the encoded stream.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "cli.hpp"
#include "commands.hpp"
#include "volcast/codec/tier.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/pipeline/annotation_export.hpp"
#include "volcast/pipeline/export.hpp"
#include "volcast/pipeline/session_client.hpp"
#include "volcast/record/recorder.hpp"
#include "volcast/record/recording.hpp"
#include "volcast/session/annotations.hpp"
#include "volcast/voice/voice_export.hpp"

namespace volcast {
namespace {

std::string mb(uint64_t bytes) {
  return fmt::format("{:.1f} MB", static_cast<double>(bytes) / 1e6);
}

// A progress line on stderr, redrawn in place on a terminal (a line per call otherwise).
void progress_line(const std::string& text) {
  if (isatty(STDERR_FILENO))
    std::fprintf(stderr, "\r\033[K%s", text.c_str());
  else
    std::fprintf(stderr, "%s\n", text.c_str());
}
void end_progress() {
  if (isatty(STDERR_FILENO)) std::fprintf(stderr, "\n");
}

}  // namespace

int run_record(const RecordArgs& a) {
  ClientConfig c = connect_client_config("record", a.connect, a.connect_file, a.token,
                                         a.fingerprint, a.insecure, a.known_servers);
  c.tier = parse_tier(a.tier, "--tier", TierRate::kEveryFrameSet);
  c.decode = false;  // the bytes are kept as sent; replay and export decode them
  c.keep_encoded = true;
  Client client(c);
  RecordingStream stream;
  stream.tier = c.tier;
  stream.started_us = wall_clock_us();
  stream.origin = fmt::format("volcast record {}:{}", c.host, c.port);
  stream.welcome = client.welcome();
  RecordingWriterOptions wo;
  wo.overwrite = a.overwrite;
  wo.sync_interval_ms = std::max(0, a.sync_interval_ms);
  // The disk is written on the recorder's own thread: a slow write or the periodic fdatasync
  // never holds up reading, so the server never drops the session's voices queued for us.
  BackgroundRecorder recorder(a.out, stream, wo);
  spdlog::info(
      "recording {} camera(s), tier {} to {} (Ctrl-C stops; the file replays whenever it stops)",
      stream.welcome.cameras.size(), to_string(c.tier), a.out);
  // The session's voices (--session): the recorder joins as a listener; what it hears arrives
  // on this thread, inside client.receive(), and is queued for the recorder's thread.
  std::unique_ptr<SessionClient> listener;
  std::map<uint32_t, std::string> speakers;  // those with a Speaker record
  if (!a.session.empty()) {
    SessionClientOptions o;
    o.participant.session = a.session;
    o.participant.create = false;
    o.participant.name = "Recorder";
    o.drive_poses = false;  // heartbeats only
    listener = std::make_unique<SessionClient>(std::move(o));
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
    // The drawing (annotations.hpp), received on this thread too: those standing when it joins
    // first, then each one drawn and erased, stamped with the server's clock.
    p->set_drawing_handler([&recorder, speaker, p](uint8_t type, std::span<const uint8_t> payload) {
      try {
        speaker(type == kDrawingAnnotation ? session::parse_annotation(payload).author
                                           : session::parse_erased(payload).second);
      } catch (const Error&) {
        return;  // the participant took it, so it parses
      }
      recorder.push_drawing(type, wall_clock_us() + p->clock_offset_us(), payload);
    });
    spdlog::info("recording the voices and drawing of session '{}' (joined as 'Recorder')",
                 a.session);
  }
  ReceivedFrameSet f;
  const auto start = std::chrono::steady_clock::now();
  auto shown = start;
  std::string ended = "interrupted";
  while (!g_interrupted) {
    const double elapsed =
        std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
    if (a.seconds > 0 && elapsed >= a.seconds) {
      ended = "time";
      break;
    }
    if (!client.receive(f)) {
      ended = "the server closed the stream";
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
    if (now - shown >= std::chrono::milliseconds(500)) {
      shown = now;
      progress_line(fmt::format("recording: {:.1f} s, {} frame sets, {} ({:.1f} Mbit/s)", elapsed,
                                st.frame_sets, mb(st.bytes),
                                static_cast<double>(st.bytes) * 8 / 1e6 / std::max(elapsed, 1e-3)));
    }
  }
  end_progress();
  if (listener) {
    listener->participant()->set_voice_handler(nullptr);
    listener->participant()->set_drawing_handler(nullptr);
    listener->stop();
  }
  client.close();
  recorder.stop();  // writes what is queued and the index
  const RecorderStats st = recorder.stats();
  if (!st.error.empty())
    throw Error(
        fmt::format("record: {} ({} frame sets and {} voice packets before it are kept "
                    "in {})",
                    st.error, st.frame_sets, st.voice_packets, a.out));
  const double seconds =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  std::printf(
      "recorded %llu frame sets and %llu voice packets in %.1f s, %s, to %s (stopped: "
      "%s)\n",
      static_cast<unsigned long long>(st.frame_sets),
      static_cast<unsigned long long>(st.voice_packets), seconds, mb(st.bytes).c_str(),
      a.out.c_str(), ended.c_str());
  if (st.dropped > 0 || st.voice_dropped > 0)
    spdlog::warn(
        "record: the disk was slower than the stream: {} frame sets and {} voice "
        "packets were not recorded",
        st.dropped, st.voice_dropped);
  if (st.frame_sets == 0) throw Error("record: no frame set arrived");
  return 0;
}

int run_recording_info(const InfoArgs& a) {
  RecordingReader reader(a.file);
  const RecordingInfo& info = reader.info();
  size_t keys = 0;
  for (const auto& f : info.frame_sets) keys += f.key;
  const bool tty = isatty(STDERR_FILENO) && !a.json;
  std::string bad;
  try {
    reader.verify([&](size_t done, size_t total) {
      if (tty && (done % 30 == 0 || done == total))
        std::fprintf(stderr, "\rchecking every record: %zu/%zu", done, total);
    });
  } catch (const Error& e) {
    bad = e.what();
  }
  if (tty) std::fprintf(stderr, "\r\033[K");
  // Played as replay plays it: a capture time that jumps or goes back is a gap clamped to the
  // frame interval, and named here (a file may lie although its CRCs hold).
  const PlaybackTimeline timeline = playback_timeline(info.frame_sets);
  const double seconds = static_cast<double>(timeline.duration_us()) / 1e6;
  std::string gaps;
  if (timeline.clamped_gaps)
    gaps = fmt::format(
        "the capture time {} by {} between frame sets {} and {}{}: replay and export play them "
        "one frame interval ({}) apart",
        timeline.first_clamped_gap_us < 0 ? "goes back" : "jumps",
        describe_span_us(std::abs(timeline.first_clamped_gap_us)), timeline.first_clamped - 1,
        timeline.first_clamped,
        timeline.clamped_gaps > 1
            ? fmt::format(" (and {} more such gaps)", timeline.clamped_gaps - 1)
            : std::string(),
        describe_span_us(timeline.frame_interval_us));
  const RecordingStream& s = info.stream;
  // Voices: who spoke, how much, when (relative to the first frame set's capture time).
  const std::vector<SpeakerSummary> speakers = speaker_summaries(info);
  nlohmann::json voices = nlohmann::json::array();
  for (const SpeakerSummary& v : speakers)
    voices.push_back({{"participant", v.speaker.participant},
                      {"name", v.speaker.name},
                      {"role", v.speaker.role == 1 ? "OR site" : "remote"},
                      {"packets", v.packets},
                      {"voice_s", static_cast<double>(v.sent_us) / 1e6},
                      {"spanned_s", static_cast<double>(v.spanned_us) / 1e6},
                      {"first_s", static_cast<double>(v.first_us) / 1e6},
                      {"last_s", static_cast<double>(v.last_us) / 1e6}});
  // Drawing (format 3): annotations drawn (0x51, those standing when the recorder joined included)
  // and erased (0x52).
  const size_t drawn =
      static_cast<size_t>(std::count_if(info.drawings.begin(), info.drawings.end(),
                                        [](const RecordedDrawing& d) { return d.type == 0x51; }));
  nlohmann::json cams = nlohmann::json::array();
  for (const auto& c : s.welcome.cameras) {
    const Intrinsics& k = c.calibration.depth;
    const auto& t = c.calibration.world_from_camera.translation;
    cams.push_back({{"name", c.description},
                    {"width", k.width},
                    {"height", k.height},
                    {"fx", k.fx},
                    {"fy", k.fy},
                    {"cx", k.cx},
                    {"cy", k.cy},
                    {"world_from_camera_translation_m", {t.x(), t.y(), t.z()}}});
  }
  nlohmann::json j = {
      {"kind", "Volcast recording"},
      {"path", a.file},
      {"depth_codec", s.tier.depth_codec},
      {"color_codec", s.tier.color_codec},
      {"color_quality", s.tier.color_quality},
      {"origin", s.origin},
      {"cameras", cams},
      {"format_version", info.version},
      {"speakers", voices},
      {"annotations_drawn", drawn},
      {"annotations_erased", info.drawings.size() - drawn},
      {"frame_sets", info.frame_sets.size()},
      {"key_frame_sets", keys},
      {"duration_s", seconds},
      {"clamped_gaps", timeline.clamped_gaps},
      {"warning", gaps},
      {"fps", seconds > 0 ? static_cast<double>(info.frame_sets.size() - 1) / seconds : 0.0},
      {"file_bytes", info.file_bytes},
      {"closed", info.closed},
      {"incomplete_tail_at", info.incomplete_tail_at ? nlohmann::json(*info.incomplete_tail_at)
                                                     : nlohmann::json(nullptr)},
      {"verified", bad.empty()},
      {"error", bad}};
  if (a.json) {
    std::printf("%s\n", j.dump(2).c_str());
  } else {
    std::printf("%s: Volcast recording, tier %s, from %s\n", a.file.c_str(),
                to_string(s.tier).c_str(), s.origin.c_str());
    std::printf("  %zu frame sets (%zu key) over %.2f s, %s\n", info.frame_sets.size(), keys,
                seconds, mb(info.file_bytes).c_str());
    for (size_t i = 0; i < s.welcome.cameras.size(); ++i) {
      const Intrinsics& k = s.welcome.cameras[i].calibration.depth;
      std::printf("  camera %zu: %s, %dx%d, fx %.1f fy %.1f cx %.1f cy %.1f\n", i,
                  s.welcome.cameras[i].description.c_str(), k.width, k.height, k.fx, k.fy, k.cx,
                  k.cy);
    }
    for (const SpeakerSummary& v : speakers)
      if (v.packets > 0)  // a Speaker record also names who drew
        std::printf(
            "  voice of %s (%s, participant %u): %zu packets (%.2f s of voice) spanning "
            "%.2f s, from %s to %s after the first frame set\n",
            printable(v.speaker.name).c_str(), v.speaker.role == 1 ? "OR site" : "remote",
            v.speaker.participant, v.packets, static_cast<double>(v.sent_us) / 1e6,
            static_cast<double>(v.spanned_us) / 1e6, describe_span_us(v.first_us).c_str(),
            describe_span_us(v.last_us).c_str());
    if (!info.drawings.empty())
      std::printf("  drawing: %zu annotations drawn, %zu erased (`volcast export --annotations`)\n",
                  drawn, info.drawings.size() - drawn);
    if (info.closed)
      std::printf("  closed by its recorder (indexed)\n");
    else if (info.incomplete_tail_at)
      std::printf(
          "  not closed: the recorder stopped; incomplete tail at offset %llu (%s), the "
          "frame sets before it replay\n",
          static_cast<unsigned long long>(*info.incomplete_tail_at), info.tail_reason.c_str());
    else
      std::printf("  not closed (no index): indexed by scanning, every record complete\n");
    if (!gaps.empty()) std::printf("  warning: %s\n", gaps.c_str());
    std::printf("  %s\n", bad.empty() ? (info.voices.empty() && info.drawings.empty()
                                             ? "every frame set checked (CRC)"
                                             : "every record checked (CRC)")
                                      : bad.c_str());
  }
  if (!bad.empty()) throw Error(bad);
  return 0;
}

int run_export(const ExportArgs& a) {
  if (!a.annotations.empty()) {
    const size_t n = export_annotations(a.file, a.annotations);
    std::printf("wrote %s: %zu annotations\n", a.annotations.c_str(), n);
    if (a.ply.empty() && a.png.empty() && a.mkv.empty() && a.wav.empty()) return 0;
  }
  if (!a.wav.empty()) {
    const std::vector<voice::ExportedVoice> voices = voice::export_voices(a.file, a.wav);
    for (const voice::ExportedVoice& v : voices) {
      std::printf("wrote %s: %s, %.1f s (%llu packets, %llu frames concealed)\n", v.path.c_str(),
                  printable(v.name).c_str(), v.seconds, static_cast<unsigned long long>(v.packets),
                  static_cast<unsigned long long>(v.concealed));
      if (v.before_start > 0)
        std::printf(
            "  %llu of them (%.2f s) said before the first frame set: left out, so that "
            "sample 0 is the first frame set\n",
            static_cast<unsigned long long>(v.before_start),
            double(v.before_start) * double(kVoiceFrameUs) / 1e6);
    }
    if (voices.empty()) std::printf("%s holds no voices\n", a.file.c_str());
    if (a.ply.empty() && a.png.empty() && a.mkv.empty()) return 0;
  }
  ExportOptions o;
  o.ply_dir = a.ply;
  o.png_dir = a.png;
  o.mkv = a.mkv;
  o.from_s = a.from_s;
  o.to_s = a.to_s;
  o.progress = [](size_t done, size_t total) {
    if (done % 10 == 0 || done == total)
      progress_line(fmt::format("export: {}/{} frame sets", done, total));
  };
  const ExportReport r = export_recording(a.file, o);
  end_progress();
  std::printf(
      "exported %zu frame sets: %zu files, %llu points (%llu valid depth pixels)%s\n", r.frame_sets,
      r.files, static_cast<unsigned long long>(r.points),
      static_cast<unsigned long long>(r.valid_pixels),
      r.skipped ? fmt::format(", {} frame sets skipped (see warnings)", r.skipped).c_str() : "");
  return 0;
}

void register_record(CLI::App& app, Commands& commands) {
  auto [rc, record] = add_command<RecordArgs>(
      app, commands, run_record, "record",
      "Record a server's stream, one tier as sent, to an append-only .vcr that survives a kill "
      "(replay it with `volcast replay`, export it with `volcast export`)");
  add_connect_flags(rc, record.connect, record.connect_file);
  rc->add_option("--token", record.token, kTokenHelp);
  rc->add_option("--fingerprint", record.fingerprint,
                 "With HOST:PORT: the server certificate's SHA-256 (64 hex digits)");
  rc->add_option("--known-servers", record.known_servers,
                 "Pinned server certificates (default: $XDG_CONFIG_HOME/volcast/known_servers)");
  rc->add_flag("--insecure", record.insecure, "Plain TCP (loopback only)");
  rc->add_option("--out", record.out, "The recording to write (.vcr)")->required();
  rc->add_option("--tier", record.tier, "The tier to record: DEPTH/COLOR[/QUALITY]")
      ->capture_default_str();
  rc->add_option("--seconds", record.seconds, "Stop after this many seconds (default: Ctrl-C)");
  rc->add_flag("--overwrite", record.overwrite, "Replace --out if it exists");
  rc->add_option("--session", record.session,
                 "Also record the voices and drawing (annotations) of this session: joins it as "
                 "'Recorder' (everyone in it sees that), listening only");
  rc->add_option("--sync-interval", record.sync_interval_ms,
                 "Flush to disk at least this often (ms): what a power cut can lose")
      ->capture_default_str();
}

void register_export(CLI::App& app, Commands& commands) {
  auto [ex, export_args] = add_command<ExportArgs>(
      app, commands, run_export, "export",
      "Export a recording (.vcr): binary PLY point clouds, 16-bit depth + color PNGs, or Azure "
      "Kinect-style Matroska");
  ex->add_option("file", export_args.file, "Volcast recording (.vcr)")->required();
  ex->add_option("--ply", export_args.ply,
                 "Folder for one binary PLY per camera and frame set (world frame, metres, "
                 "with color)");
  ex->add_option("--png", export_args.png,
                 "Folder for depth (16-bit PNG, mm) and color (PNG) per camera and frame set");
  ex->add_option("--mkv", export_args.mkv,
                 "Azure Kinect-style Matroska: DEPTH track (b16g), calibration.json, color "
                 "registered to depth as a COLOR_ON_DEPTH track; one file per camera "
                 "(FILE-camera-C.mkv) for several; `volcast info` reads it back");
  ex->add_option("--wav", export_args.wav,
                 "Folder for one WAV per speaker of the recording's voices (48 kHz mono, on the "
                 "recording's time line: second 0 is its first frame set)");
  ex->add_option("--annotations", export_args.annotations,
                 "JSON file for the recording's annotations (strokes, arrows, labels: points in "
                 "the room frame, metres; who drew and erased each, and when)");
  ex->add_option("--from", export_args.from_s, "Start this many seconds in")->capture_default_str();
  ex->add_option("--to", export_args.to_s, "End this many seconds in (default: the end)");
}

}  // namespace volcast
