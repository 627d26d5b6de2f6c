// Drawing records (recording.hpp type 7): the session's annotation messages (annotations.hpp) as
// the recorder received them, checked with the session's own parsers; and when each one plays in
// a replay (drawing_plan).
#include <algorithm>
#include <numeric>

#include "record_format.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/session/annotations.hpp"

namespace volcast {

// The largest 0x51: id, author, time, tag, kind, anchor, generation, slice, count, the points of
// the longest stroke, the longest label's text (a stroke has no text, a label one point).
static_assert(4 + 4 + 8 + 4 + 1 + 1 + 4 + 2 + 2 + session::kMaxStrokePoints * 12 + 2 +
                  session::kMaxLabelBytes <=
              kMaxRecordedDrawingBytes);

namespace detail {

void check_drawing(uint8_t type, std::span<const uint8_t> payload) {
  if (type != kDrawingAnnotation && type != kDrawingErased)
    throw Error("malformed drawing: session message type " + std::to_string(type) +
                " (0x51 annotation or 0x52 erased)");
  if (payload.empty() || payload.size() > kMaxRecordedDrawingBytes)
    throw Error("malformed drawing: a session payload of " + std::to_string(payload.size()) +
                " bytes (1.." + std::to_string(kMaxRecordedDrawingBytes) + ")");
  try {
    if (type == kDrawingAnnotation) {
      const session::Annotation a = session::parse_annotation(payload);
      if (a.id == 0) throw Error("annotation id 0");
    } else {
      session::parse_erased(payload);
    }
  } catch (const Error& e) {
    throw Error(std::string("malformed drawing: ") + e.what());
  }
}

std::array<uint8_t, kDrawingHeadBytes> drawing_head(const RecordedDrawing& d) {
  std::array<uint8_t, kDrawingHeadBytes> h{};
  h[0] = d.type;
  wire::store<int64_t>(h.data() + 1, d.received_us);
  wire::store<uint32_t>(h.data() + 9, d.bytes);
  return h;
}

RecordedDrawing parse_drawing(std::span<const uint8_t> payload,
                              std::span<const uint8_t>& session_payload) {
  wire::Reader r(payload, "drawing");
  RecordedDrawing d;
  d.type = r.get<uint8_t>("session message type");
  d.received_us = r.get<int64_t>("receive time");
  const auto n = r.get<uint32_t>("payload length");
  if (r.remaining() != n)
    r.fail("payload length " + std::to_string(n) + " does not fit the record");
  session_payload = payload.subspan(kDrawingHeadBytes);
  check_drawing(d.type, session_payload);
  d.bytes = n;
  return d;
}

}  // namespace detail

std::vector<DrawingCue> drawing_plan(const RecordingInfo& info, const PlaybackTimeline& timeline,
                                     size_t first, size_t last) {
  std::vector<DrawingCue> cues;
  const std::vector<RecordedFrameSet>& sets = info.frame_sets;
  const std::vector<int64_t>& offset = timeline.offset_us;
  if (sets.empty() || first > last || last >= sets.size() || offset.size() != sets.size())
    return cues;
  const int64_t interval = timeline.frame_interval_us;
  // The frame sets in capture order: a drawing follows the last one captured at or before it.
  std::vector<size_t> by_capture(sets.size());
  std::iota(by_capture.begin(), by_capture.end(), size_t{0});
  std::stable_sort(by_capture.begin(), by_capture.end(),
                   [&](size_t a, size_t b) { return sets[a].capture_us < sets[b].capture_us; });
  for (size_t i = 0; i < info.drawings.size(); ++i) {
    const int64_t t = info.drawings[i].received_us;
    const auto after =
        std::upper_bound(by_capture.begin(), by_capture.end(), t,
                         [&](int64_t time, size_t k) { return time < sets[k].capture_us; });
    if (after == by_capture.begin() || *(after - 1) < first) {
      cues.push_back({i, 0});  // before the pass: there when it begins
      continue;
    }
    const size_t k = *(after - 1);
    if (k > last) continue;
    const int64_t d = t - sets[k].capture_us;
    if (k == last) {
      if (d >= interval) continue;  // after the pass
      cues.push_back({i, offset[k] - offset[first] + d});
    } else {
      cues.push_back({i, offset[k] - offset[first] + std::min(d, offset[k + 1] - offset[k])});
    }
  }
  std::stable_sort(cues.begin(), cues.end(),
                   [](const DrawingCue& a, const DrawingCue& b) { return a.at_us < b.at_us; });
  return cues;
}

}  // namespace volcast

namespace volcast {

void RecordingReader::add_drawing(const RecordedDrawing& d, uint64_t at) {
  info_.drawings.push_back(d);
  info_.drawings.back().offset = at;
}

void RecordingReader::read_drawing(const RecordedDrawing& d, std::vector<uint8_t>& payload) {
  const std::string where =
      "recording " + path_.string() + ": drawing at offset " + std::to_string(d.offset);
  std::array<uint8_t, kRecordHeaderBytes> rh{};
  detail::RecordHeader h;
  if (!detail::read_at(fd_, d.offset, rh)) throw Error(where + ": the file ends before it");
  if (d.bytes > kMaxRecordedDrawingBytes || !detail::parse_record_header(rh, h) ||
      h.type != RecordType::kDrawing || h.payload_bytes != detail::kDrawingHeadBytes + d.bytes)
    throw Error(where + ": corrupt record header");
  payload.resize(h.payload_bytes);
  if (!detail::read_at(fd_, d.offset + kRecordHeaderBytes, payload))
    throw Error(where + ": the file ends inside it");
  if (crc32_of(payload) != h.payload_crc) throw Error(where + ": corrupt (fails its CRC)");
  std::span<const uint8_t> session_payload;
  RecordedDrawing got;
  try {
    got = detail::parse_drawing(payload, session_payload);
  } catch (const Error& e) {
    throw Error(where + ": " + e.what());
  }
  if (got.type != d.type || got.received_us != d.received_us)
    throw Error(where + ": differs from its index entry");
  payload.erase(payload.begin(),
                payload.begin() + static_cast<ptrdiff_t>(detail::kDrawingHeadBytes));
}

}  // namespace volcast
