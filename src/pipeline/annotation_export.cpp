#include "volcast/pipeline/annotation_export.hpp"

#include <nlohmann/json.hpp>

#include <charconv>
#include <map>

#include "volcast/core/private_file.hpp"

namespace volcast {
namespace {

using Json = nlohmann::ordered_json;  // keys in the order written, for people

// The shortest decimal that reads back as `f` (0.1234567, not 0.12345670163631439), as a double:
// JSON's numbers are doubles, and this one rounds to `f` exactly when read as a float.
double shortest(float f) {
  char text[32];
  const auto [end, error] = std::to_chars(text, text + sizeof text, f);
  double d = f;
  if (error == std::errc()) std::from_chars(text, end, d);
  return d;
}

}  // namespace

std::vector<RecordedAnnotation> recorded_annotations(RecordingReader& reader) {
  std::vector<RecordedAnnotation> out;
  std::map<uint32_t, size_t> by_id;  // recorded id -> its entry in `out`
  std::vector<uint8_t> payload;
  for (const RecordedDrawing& d : reader.info().drawings) {
    reader.read_drawing(d, payload);
    if (d.type == kDrawingAnnotation) {
      session::Annotation a = session::parse_annotation(payload);
      if (const auto it = by_id.find(a.id); it != by_id.end()) {
        out[it->second].annotation = std::move(a);  // sent again (a rejoin): the last holds
        continue;
      }
      by_id[a.id] = out.size();
      out.push_back({std::move(a), d.received_us, std::nullopt, 0});
    } else {
      const auto [id, by] = session::parse_erased(payload);
      if (const auto it = by_id.find(id); it != by_id.end() && !out[it->second].erased_us) {
        out[it->second].erased_us = d.received_us;
        out[it->second].erased_by = by;
      }
    }
  }
  return out;
}

size_t export_annotations(const std::filesystem::path& recording,
                          const std::filesystem::path& json) {
  RecordingReader reader(recording);
  const RecordingInfo& info = reader.info();
  const std::vector<RecordedAnnotation> all = recorded_annotations(reader);
  const int64_t zero = !info.frame_sets.empty() ? info.frame_sets.front().capture_us
                       : !info.drawings.empty() ? info.drawings.front().received_us
                                                : 0;
  const auto who = [&](uint32_t id) {
    Json name = nullptr;
    for (const RecordedSpeaker& s : info.speakers)
      if (s.participant == id) name = s.name;
    return Json{{"id", id}, {"name", name}};
  };
  const auto seconds = [&](int64_t us) { return static_cast<double>(us - zero) / 1e6; };
  Json list = Json::array();
  for (const RecordedAnnotation& r : all) {
    const session::Annotation& a = r.annotation;
    Json points = Json::array();
    for (const Eigen::Vector3f& p : a.points)
      points.push_back({shortest(p.x()), shortest(p.y()), shortest(p.z())});
    list.push_back(
        {{"id", a.id},
         {"author", who(a.author)},
         {"kind", session::to_string(a.kind)},
         {"anchor", a.anchor == session::AnnotationAnchor::kMonitor ? "monitor" : "room"},
         {"generation", a.generation},
         {"slice", a.slice},
         {"tag", a.tag},
         {"points", points},
         {"text", a.text},
         {"drawn_us", a.time_us},
         {"drawn_s", seconds(a.time_us)},
         {"received_us", r.received_us},
         {"erased_us", r.erased_us ? Json(*r.erased_us) : Json(nullptr)},
         {"erased_s", r.erased_us ? Json(seconds(*r.erased_us)) : Json(nullptr)},
         {"erased_by", r.erased_us ? who(r.erased_by) : Json(nullptr)}});
  }
  const Json j = {{"kind", "Volcast annotations"},
                  {"recording", recording.string()},
                  {"frame", "room"},
                  {"units", "metres"},
                  {"time_zero_us", zero},
                  {"annotations", list}};
  // A recording's text may be anything: invalid UTF-8 is replaced, never a throw.
  write_private_file(json, j.dump(2, ' ', false, Json::error_handler_t::replace) + "\n");
  return all.size();
}

}  // namespace volcast
