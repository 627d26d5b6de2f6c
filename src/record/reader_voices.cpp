// RecordingReader: the Index record's payload (frame sets, in version 2 speakers and voices, in
// version 3 drawing), and reading voices back.
#include <algorithm>

#include "record_format.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"

namespace volcast {
namespace {

// 8 (offset) + 8 (sequence) + 8 (capture time) + 1 (flags) bytes per frame set in the Index.
constexpr size_t kIndexEntryBytes = 25;
// 8 (offset) + 4 (participant) + 4 (sequence) + 4 (frame) + 8 (capture time) + 2 (length).
constexpr size_t kVoiceIndexEntryBytes = 30;
// 8 (offset) + 1 (type) + 8 (receive time) + 4 (length).
constexpr size_t kDrawingIndexEntryBytes = 21;

struct SpeakerAt {
  uint64_t offset;
  RecordedSpeaker speaker;
  uint32_t bytes;  // its payload's length
};

// The Index payload's lists (format version `version`); throws Error("malformed recording
// index: ...").
void parse_index_lists(std::span<const uint8_t> payload, uint16_t version,
                       std::vector<RecordedFrameSet>& frame_sets, std::vector<SpeakerAt>& speakers,
                       std::vector<RecordedVoice>& voices, std::vector<RecordedDrawing>& drawings) {
  wire::Reader r(payload, "recording index");
  const uint32_t count = r.get<uint32_t>("count");
  if (uint64_t{count} * kIndexEntryBytes > r.remaining()) r.fail("wrong length");
  frame_sets.resize(count);
  for (RecordedFrameSet& e : frame_sets) {
    e.offset = r.get<uint64_t>("offset");
    e.sequence = r.get<uint64_t>("sequence");
    e.capture_us = r.get<int64_t>("capture time");
    e.key = (r.get<uint8_t>("flags") & 1) != 0;
  }
  if (version >= 2) {
    const uint32_t n_speakers = r.get<uint32_t>("speaker count");
    if (n_speakers > r.remaining() / 15) r.fail("wrong length");  // 15: an empty name's entry
    speakers.resize(n_speakers);
    for (SpeakerAt& e : speakers) {
      e.offset = r.get<uint64_t>("speaker offset");
      e.speaker.participant = r.get<uint32_t>("participant");
      e.speaker.role = r.get<uint8_t>("role");
      e.speaker.name = r.get_string("display name");
      e.bytes = static_cast<uint32_t>(4 + 2 + e.speaker.name.size() + 1);
    }
    const uint32_t n_voices = r.get<uint32_t>("voice count");
    const uint64_t after_voices = version >= 3 ? 4 : 0;  // the drawing count
    if (uint64_t{n_voices} * kVoiceIndexEntryBytes + after_voices > r.remaining())
      r.fail("wrong length");
    voices.resize(n_voices);
    for (RecordedVoice& v : voices) {
      v.offset = r.get<uint64_t>("voice offset");
      v.participant = r.get<uint32_t>("participant");
      v.sequence = r.get<uint32_t>("sequence");
      v.frame = r.get<uint32_t>("frame");
      v.capture_us = r.get<int64_t>("capture time");
      v.bytes = r.get<uint16_t>("Opus length");
      if (v.bytes == 0 || v.bytes > kMaxRecordedVoiceBytes) r.fail("bad Opus length");
    }
  }
  if (version >= 3) {
    const uint32_t n_drawings = r.get<uint32_t>("drawing count");
    if (uint64_t{n_drawings} * kDrawingIndexEntryBytes != r.remaining()) r.fail("wrong length");
    drawings.resize(n_drawings);
    for (RecordedDrawing& d : drawings) {
      d.offset = r.get<uint64_t>("drawing offset");
      d.type = r.get<uint8_t>("session message type");
      d.received_us = r.get<int64_t>("receive time");
      d.bytes = r.get<uint32_t>("payload length");
      if (d.type != kDrawingAnnotation && d.type != kDrawingErased)
        r.fail("drawing of session message type " + std::to_string(d.type));
      if (d.bytes == 0 || d.bytes > kMaxRecordedDrawingBytes) r.fail("bad drawing length");
    }
  }
  r.expect_end();
}

}  // namespace

void RecordingReader::add_speaker(const RecordedSpeaker& s) {
  for (RecordedSpeaker& known : info_.speakers)
    if (known.participant == s.participant) {
      known = s;  // the last record holds
      return;
    }
  info_.speakers.push_back(s);
}

void RecordingReader::add_voice(const RecordedVoice& v, uint64_t at) {
  const bool known =
      std::any_of(info_.speakers.begin(), info_.speakers.end(),
                  [&](const RecordedSpeaker& s) { return s.participant == v.participant; });
  if (!known)
    throw Error("from participant " + std::to_string(v.participant) +
                ", who has no speaker record before it");
  info_.voices.push_back(v);
  info_.voices.back().offset = at;
}

// Parses the Index payload and checks that its frame sets, speakers and voices tile the file
// from the end of the Stream record to the Index, each record where the one before it ends.
void RecordingReader::parse_index(std::span<const uint8_t> payload, uint64_t index_at) {
  const std::string where =
      "recording " + path_.string() + ": index at offset " + std::to_string(index_at);
  std::vector<SpeakerAt> speakers;
  std::vector<RecordedVoice> voices;
  std::vector<RecordedDrawing> drawings;
  try {
    parse_index_lists(payload, info_.version, info_.frame_sets, speakers, voices, drawings);
  } catch (const Error& e) {
    throw Error(where + ": " + e.what());
  }
  // Walk the four lists in file order (a merge: each is in file order itself).
  size_t f = 0, s = 0, v = 0, d = 0;
  uint64_t at = records_at_;         // where the next record must begin
  RecordedFrameSet* open = nullptr;  // a frame set whose length is up to the next record
  const auto bad = [&](const char* kind, size_t k, uint64_t offset) {
    throw Error(where + ": " + kind + " " + std::to_string(k) + " has a bad offset " +
                std::to_string(offset));
  };
  const auto reach = [&](uint64_t offset) {  // the next record begins at `offset`
    if (!open) return offset == at;
    if (offset < open->offset + kRecordHeaderBytes ||
        offset - open->offset - kRecordHeaderBytes > kMaxRecordBytes)
      return false;
    open->bytes = static_cast<uint32_t>(offset - open->offset - kRecordHeaderBytes);
    open = nullptr;
    return true;
  };
  constexpr uint64_t kNone = UINT64_MAX;
  while (true) {
    const uint64_t fo = f < info_.frame_sets.size() ? info_.frame_sets[f].offset : kNone;
    const uint64_t so = s < speakers.size() ? speakers[s].offset : kNone;
    const uint64_t vo = v < voices.size() ? voices[v].offset : kNone;
    const uint64_t dr = d < drawings.size() ? drawings[d].offset : kNone;
    const uint64_t next = std::min({fo, so, vo, dr});
    if (next == kNone) break;
    if (next == fo) {
      if (!reach(fo)) bad("frame set", f, fo);
      open = &info_.frame_sets[f++];
    } else if (next == so) {
      if (!reach(so)) bad("speaker", s, so);
      add_speaker(speakers[s].speaker);
      at = so + kRecordHeaderBytes + speakers[s++].bytes;
    } else if (next == dr) {
      if (!reach(dr)) bad("drawing", d, dr);
      add_drawing(drawings[d], dr);
      at = dr + kRecordHeaderBytes + detail::kDrawingHeadBytes + drawings[d++].bytes;
    } else {
      if (!reach(vo)) bad("voice", v, vo);
      try {
        add_voice(voices[v], vo);
      } catch (const Error& e) {
        throw Error(where + ": voice at offset " + std::to_string(vo) + ": " + e.what());
      }
      at = vo + kRecordHeaderBytes + detail::kVoiceHeadBytes + voices[v++].bytes;
    }
  }
  if (!reach(index_at)) throw Error(where + ": its records do not end where the index begins");
}

std::vector<RecordedVoice> RecordingReader::voices_of(uint32_t participant) const {
  std::vector<RecordedVoice> out;
  for (const RecordedVoice& v : info_.voices)
    if (v.participant == participant) out.push_back(v);
  std::stable_sort(out.begin(), out.end(), [](const RecordedVoice& a, const RecordedVoice& b) {
    return a.capture_us != b.capture_us ? a.capture_us < b.capture_us : a.frame < b.frame;
  });
  return out;
}

void RecordingReader::read_voice(const RecordedVoice& v, std::vector<uint8_t>& bytes) {
  const std::string where =
      "recording " + path_.string() + ": voice at offset " + std::to_string(v.offset);
  std::array<uint8_t, kRecordHeaderBytes> rh{};
  detail::RecordHeader h;
  if (!detail::read_at(fd_, v.offset, rh)) throw Error(where + ": the file ends before it");
  if (!detail::parse_record_header(rh, h) || h.type != RecordType::kVoice ||
      h.payload_bytes != detail::kVoiceHeadBytes + v.bytes)
    throw Error(where + ": corrupt record header");
  bytes.resize(h.payload_bytes);
  if (!detail::read_at(fd_, v.offset + kRecordHeaderBytes, bytes))
    throw Error(where + ": the file ends inside it");
  if (crc32_of(bytes) != h.payload_crc) throw Error(where + ": corrupt (fails its CRC)");
  std::span<const uint8_t> opus;
  RecordedVoice got;
  try {
    got = detail::parse_voice(bytes, opus);
  } catch (const Error& e) {
    throw Error(where + ": " + e.what());
  }
  if (got.participant != v.participant || got.sequence != v.sequence || got.frame != v.frame ||
      got.capture_us != v.capture_us)
    throw Error(where + ": differs from its index entry");
  bytes.erase(bytes.begin(), bytes.begin() + static_cast<ptrdiff_t>(detail::kVoiceHeadBytes));
}

std::vector<RecordedVoicePacket> RecordingReader::voices(uint32_t participant) {
  std::vector<RecordedVoicePacket> out;
  for (const RecordedVoice& v : voices_of(participant)) {
    RecordedVoicePacket p{v.participant, v.sequence, v.frame, v.capture_us, {}};
    read_voice(v, p.bytes);
    out.push_back(std::move(p));
  }
  return out;
}

std::vector<SpeakerSummary> speaker_summaries(const RecordingInfo& info) {
  int64_t start = 0;
  if (!info.frame_sets.empty()) {
    start = info.frame_sets.front().capture_us;
  } else if (!info.voices.empty()) {
    start = std::min_element(info.voices.begin(), info.voices.end(),
                             [](const RecordedVoice& a, const RecordedVoice& b) {
                               return a.capture_us < b.capture_us;
                             })
                ->capture_us;
  }
  std::vector<SpeakerSummary> out;
  for (const RecordedSpeaker& s : info.speakers) {
    SpeakerSummary m;
    m.speaker = s;
    int64_t first = INT64_MAX, last = INT64_MIN, lo = INT64_MAX, hi = INT64_MIN;
    for (const RecordedVoice& v : info.voices) {
      if (v.participant != s.participant) continue;
      ++m.packets;
      first = std::min(first, v.capture_us);
      last = std::max(last, v.capture_us);
      lo = std::min<int64_t>(lo, v.frame);
      hi = std::max<int64_t>(hi, v.frame);
    }
    if (m.packets) {
      m.sent_us = static_cast<int64_t>(m.packets) * kVoiceFrameUs;
      m.spanned_us = (hi - lo + 1) * kVoiceFrameUs;
      m.first_us = first - start;
      m.last_us = last - start;
    }
    out.push_back(m);
  }
  return out;
}

}  // namespace volcast
