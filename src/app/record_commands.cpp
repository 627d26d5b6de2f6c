// volcast record, export and info FILE.vcr: recordings of the encoded stream.
#include <fmt/format.h>
#include <spdlog/spdlog.h>
#include <unistd.h>

#include <algorithm>
#include <cstdlib>

#include "cli.hpp"
#include "commands.hpp"
#include "volcast/codec/tier.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/pipeline/annotation_export.hpp"
#include "volcast/pipeline/export.hpp"
#include "volcast/pipeline/stream_recording.hpp"
#include "volcast/record/recorder.hpp"
#include "volcast/record/recording.hpp"
#include "volcast/record/recording_summary.hpp"
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
  StreamRecordingOptions o;
  o.out = a.out;
  o.writer.overwrite = a.overwrite;
  o.writer.sync_interval_ms = std::max(0, a.sync_interval_ms);
  o.session = a.session;
  o.seconds = a.seconds;
  o.stop = &g_interrupted;
  o.progress = [](const RecorderStats& st, double elapsed) {
    progress_line(fmt::format("recording: {:.1f} s, {} frame sets, {} ({:.1f} Mbit/s)", elapsed,
                              st.frame_sets, mb(st.bytes),
                              static_cast<double>(st.bytes) * 8 / 1e6 / std::max(elapsed, 1e-3)));
  };
  StreamRecordingResult r;
  try {
    r = record_stream(client, fmt::format("volcast record {}:{}", c.host, c.port), o);
  } catch (...) {
    end_progress();
    throw;
  }
  end_progress();
  const RecorderStats& st = r.stats;
  std::printf(
      "recorded %llu frame sets and %llu voice packets in %.1f s, %s, to %s (stopped: "
      "%s)\n",
      static_cast<unsigned long long>(st.frame_sets),
      static_cast<unsigned long long>(st.voice_packets), r.seconds, mb(st.bytes).c_str(),
      a.out.c_str(), r.ended.c_str());
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
  const bool tty = isatty(STDERR_FILENO) && !a.json;
  const RecordingSummary s = summarize_recording(reader, a.file, [&](size_t done, size_t total) {
    if (tty && (done % 30 == 0 || done == total))
      std::fprintf(stderr, "\rchecking every record: %zu/%zu", done, total);
  });
  if (tty) std::fprintf(stderr, "\r\033[K");
  if (a.json)
    std::printf("%s\n", summary_json(s).c_str());
  else
    std::fputs(summary_text(s).c_str(), stdout);
  if (!s.error.empty()) throw Error(s.error);
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
