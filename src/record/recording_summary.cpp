// What `volcast info FILE.vcr` says of a recording (recording_summary.hpp).
#include "volcast/record/recording_summary.hpp"

#include <fmt/format.h>

#include <algorithm>
#include <cstdlib>
#include <nlohmann/json.hpp>

#include "volcast/codec/tier.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"

namespace volcast {
namespace {

std::string mb(uint64_t bytes) {
  return fmt::format("{:.1f} MB", static_cast<double>(bytes) / 1e6);
}

}  // namespace

RecordingSummary summarize_recording(RecordingReader& reader, const std::string& path,
                                     const std::function<void(size_t, size_t)>& progress) {
  RecordingSummary s;
  s.path = path;
  s.info = &reader.info();
  const RecordingInfo& info = reader.info();
  for (const auto& f : info.frame_sets) s.key_frame_sets += f.key;
  try {
    reader.verify([&](size_t done, size_t total) {
      if (progress) progress(done, total);
    });
  } catch (const Error& e) {
    s.error = e.what();
  }
  // Played as replay plays it: a capture time that jumps or goes back is a gap clamped to the
  // frame interval, and named here (a file may lie although its CRCs hold).
  s.timeline = playback_timeline(info.frame_sets);
  s.duration_s = static_cast<double>(s.timeline.duration_us()) / 1e6;
  const PlaybackTimeline& t = s.timeline;
  if (t.clamped_gaps)
    s.gap_warning = fmt::format(
        "the capture time {} by {} between frame sets {} and {}{}: replay and export play them "
        "one frame interval ({}) apart",
        t.first_clamped_gap_us < 0 ? "goes back" : "jumps",
        describe_span_us(std::abs(t.first_clamped_gap_us)), t.first_clamped - 1, t.first_clamped,
        t.clamped_gaps > 1 ? fmt::format(" (and {} more such gaps)", t.clamped_gaps - 1)
                           : std::string(),
        describe_span_us(t.frame_interval_us));
  s.speakers = speaker_summaries(info);
  // Drawing (format 3): annotations drawn (0x51, those standing when the recorder joined
  // included) and erased (0x52).
  s.annotations_drawn =
      static_cast<size_t>(std::count_if(info.drawings.begin(), info.drawings.end(),
                                        [](const RecordedDrawing& d) { return d.type == 0x51; }));
  s.annotations_erased = info.drawings.size() - s.annotations_drawn;
  return s;
}

std::string summary_json(const RecordingSummary& s) {
  const RecordingInfo& info = *s.info;
  const RecordingStream& stream = info.stream;
  nlohmann::json voices = nlohmann::json::array();
  for (const SpeakerSummary& v : s.speakers)
    voices.push_back({{"participant", v.speaker.participant},
                      {"name", v.speaker.name},
                      {"role", v.speaker.role == 1 ? "OR site" : "remote"},
                      {"packets", v.packets},
                      {"voice_s", static_cast<double>(v.sent_us) / 1e6},
                      {"spanned_s", static_cast<double>(v.spanned_us) / 1e6},
                      {"first_s", static_cast<double>(v.first_us) / 1e6},
                      {"last_s", static_cast<double>(v.last_us) / 1e6}});
  nlohmann::json cams = nlohmann::json::array();
  for (const auto& c : stream.welcome.cameras) {
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
  const double fps =
      s.duration_s > 0 ? static_cast<double>(info.frame_sets.size() - 1) / s.duration_s : 0.0;
  const nlohmann::json j = {
      {"kind", "Volcast recording"},
      {"path", s.path},
      {"depth_codec", stream.tier.depth_codec},
      {"color_codec", stream.tier.color_codec},
      {"color_quality", stream.tier.color_quality},
      {"origin", stream.origin},
      {"cameras", cams},
      {"format_version", info.version},
      {"speakers", voices},
      {"annotations_drawn", s.annotations_drawn},
      {"annotations_erased", s.annotations_erased},
      {"frame_sets", info.frame_sets.size()},
      {"key_frame_sets", s.key_frame_sets},
      {"duration_s", s.duration_s},
      {"clamped_gaps", s.timeline.clamped_gaps},
      {"warning", s.gap_warning},
      {"fps", fps},
      {"file_bytes", info.file_bytes},
      {"closed", info.closed},
      {"incomplete_tail_at", info.incomplete_tail_at ? nlohmann::json(*info.incomplete_tail_at)
                                                     : nlohmann::json(nullptr)},
      {"verified", s.error.empty()},
      {"error", s.error}};
  return j.dump(2);
}

std::string summary_text(const RecordingSummary& s) {
  const RecordingInfo& info = *s.info;
  const RecordingStream& stream = info.stream;
  std::string out = fmt::format("{}: Volcast recording, tier {}, from {}\n", s.path,
                                to_string(stream.tier), stream.origin);
  out += fmt::format("  {} frame sets ({} key) over {:.2f} s, {}\n", info.frame_sets.size(),
                     s.key_frame_sets, s.duration_s, mb(info.file_bytes));
  for (size_t i = 0; i < stream.welcome.cameras.size(); ++i) {
    const Intrinsics& k = stream.welcome.cameras[i].calibration.depth;
    out += fmt::format("  camera {}: {}, {}x{}, fx {:.1f} fy {:.1f} cx {:.1f} cy {:.1f}\n", i,
                       stream.welcome.cameras[i].description, k.width, k.height, k.fx, k.fy, k.cx,
                       k.cy);
  }
  for (const SpeakerSummary& v : s.speakers)
    if (v.packets > 0)  // a Speaker record also names who drew
      out += fmt::format(
          "  voice of {} ({}, participant {}): {} packets ({:.2f} s of voice) spanning {:.2f} s, "
          "from {} to {} after the first frame set\n",
          printable(v.speaker.name), v.speaker.role == 1 ? "OR site" : "remote",
          v.speaker.participant, v.packets, static_cast<double>(v.sent_us) / 1e6,
          static_cast<double>(v.spanned_us) / 1e6, describe_span_us(v.first_us),
          describe_span_us(v.last_us));
  if (!info.drawings.empty())
    out += fmt::format(
        "  drawing: {} annotations drawn, {} erased (`volcast export "
        "--annotations`)\n",
        s.annotations_drawn, s.annotations_erased);
  if (info.closed)
    out += "  closed by its recorder (indexed)\n";
  else if (info.incomplete_tail_at)
    out += fmt::format(
        "  not closed: the recorder stopped; incomplete tail at offset {} ({}), the frame sets "
        "before it replay\n",
        *info.incomplete_tail_at, info.tail_reason);
  else
    out += "  not closed (no index): indexed by scanning, every record complete\n";
  if (!s.gap_warning.empty()) out += "  warning: " + s.gap_warning + "\n";
  out += "  " +
         (s.error.empty() ? std::string(info.voices.empty() && info.drawings.empty()
                                            ? "every frame set checked (CRC)"
                                            : "every record checked (CRC)")
                          : s.error) +
         "\n";
  return out;
}

}  // namespace volcast
