#include <unistd.h>
#include <zlib.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "record_format.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"

namespace volcast {

namespace {

// zlib's crc32_z returns its initial value for a null buffer, whatever `crc` was: skip empties.
uLong crc_update(uLong crc, std::span<const uint8_t> bytes) {
  return bytes.empty() ? crc : crc32_z(crc, bytes.data(), bytes.size());
}

}  // namespace

uint32_t crc32_of(std::span<const uint8_t> bytes) {
  return static_cast<uint32_t>(crc_update(crc32_z(0, nullptr, 0), bytes));
}

RecordedFrameSet frame_set_head(std::span<const uint8_t> body) {
  wire::Reader r(body, "frame set");
  RecordedFrameSet h;
  h.bytes = static_cast<uint32_t>(body.size());
  h.sequence = r.get<uint64_t>("sequence");
  h.key = (r.get<uint8_t>("flags") & 1) != 0;
  h.capture_us = r.get<int64_t>("capture time");
  r.get<int64_t>("filter time");
  r.get<int64_t>("encode time");
  return h;
}

namespace detail {

std::array<uint8_t, kRecordingFileHeaderBytes> file_header(uint16_t version) {
  std::array<uint8_t, kRecordingFileHeaderBytes> h{};
  std::copy(kRecordingMagic.begin(), kRecordingMagic.end(), h.begin());
  wire::store<uint16_t>(h.data() + 8, version);
  wire::store<uint32_t>(h.data() + 12, crc32_of(std::span(h).first(12)));
  return h;
}

std::array<uint8_t, kRecordHeaderBytes> record_header(RecordType type,
                                                      std::span<const uint8_t> head,
                                                      std::span<const uint8_t> body) {
  std::array<uint8_t, kRecordHeaderBytes> h{};
  h[0] = static_cast<uint8_t>(type);
  const uint32_t n = static_cast<uint32_t>(head.size() + body.size());
  const uLong crc = crc_update(crc_update(crc32_z(0, nullptr, 0), head), body);
  const uint32_t payload_crc = static_cast<uint32_t>(crc);
  wire::store<uint32_t>(h.data() + 4, n);
  wire::store<uint32_t>(h.data() + 8, payload_crc);
  wire::store<uint32_t>(h.data() + 12, crc32_of(std::span(h).first(12)));
  return h;
}

bool parse_record_header(std::span<const uint8_t, kRecordHeaderBytes> b, RecordHeader& out) {
  const auto header_crc = wire::load<uint32_t>(b.data() + 12);
  if (header_crc != crc32_of(b.first(12)) || b[1] != 0 || b[2] != 0 || b[3] != 0) return false;
  out.type = static_cast<RecordType>(b[0]);
  out.payload_bytes = wire::load<uint32_t>(b.data() + 4);
  out.payload_crc = wire::load<uint32_t>(b.data() + 8);
  return true;
}

std::vector<uint8_t> serialize_stream(const RecordingStream& s) {
  std::vector<uint8_t> out;
  wire::Writer w(out);
  w.put_string(s.tier.depth_codec);
  w.put_string(s.tier.color_codec);
  w.put<uint8_t>(static_cast<uint8_t>(s.tier.color_quality));
  w.put<int64_t>(s.started_us);
  w.put_string(s.origin);
  w.put_bytes(protocol::serialize(s.welcome));
  return out;
}

RecordingStream parse_stream(std::span<const uint8_t> payload) {
  wire::Reader r(payload, "recording stream");
  RecordingStream s;
  s.tier.depth_codec = r.get_string("depth codec");
  s.tier.color_codec = r.get_string("color codec");
  s.tier.color_quality = r.get<uint8_t>("color quality");
  if (s.tier.color_quality > 100) r.fail("color quality above 100");
  s.started_us = r.get<int64_t>("start time");
  s.origin = r.get_string("origin");
  s.welcome = protocol::parse_welcome(r.get_span("welcome"));
  r.expect_end();
  if (s.tier.depth_codec.empty() || s.tier.color_codec.empty()) r.fail("no codec named");
  return s;
}

void serialize_speaker(const RecordedSpeaker& s, std::vector<uint8_t>& out) {
  out.clear();
  wire::Writer w(out);
  w.put<uint32_t>(s.participant);
  w.put_string(s.name);
  w.put<uint8_t>(s.role);
}

RecordedSpeaker parse_speaker(std::span<const uint8_t> payload) {
  wire::Reader r(payload, "speaker");
  RecordedSpeaker s;
  s.participant = r.get<uint32_t>("participant");
  s.name = r.get_string("display name");
  s.role = r.get<uint8_t>("role");
  r.expect_end();
  return s;
}

std::array<uint8_t, kVoiceHeadBytes> voice_head(const RecordedVoice& v) {
  std::array<uint8_t, kVoiceHeadBytes> h{};
  wire::store<uint32_t>(h.data(), v.participant);
  wire::store<uint32_t>(h.data() + 4, v.sequence);
  wire::store<uint32_t>(h.data() + 8, v.frame);
  wire::store<int64_t>(h.data() + 12, v.capture_us);
  wire::store<uint32_t>(h.data() + 20, v.bytes);
  return h;
}

RecordedVoice parse_voice(std::span<const uint8_t> payload, std::span<const uint8_t>& opus) {
  wire::Reader r(payload, "voice");
  RecordedVoice v;
  v.participant = r.get<uint32_t>("participant");
  v.sequence = r.get<uint32_t>("sequence");
  v.frame = r.get<uint32_t>("frame");
  v.capture_us = r.get<int64_t>("capture time");
  const auto n = r.get<uint32_t>("Opus length");
  if (n == 0 || n > kMaxRecordedVoiceBytes)
    r.fail("an Opus packet of " + std::to_string(n) + " bytes (1.." +
           std::to_string(kMaxRecordedVoiceBytes) + ")");
  if (r.remaining() != n) r.fail("Opus length " + std::to_string(n) + " does not fit the record");
  opus = payload.subspan(kVoiceHeadBytes);
  v.bytes = static_cast<uint16_t>(n);
  return v;
}

bool read_at(int fd, uint64_t offset, std::span<uint8_t> out) {
  size_t done = 0;
  while (done < out.size()) {
    const ssize_t n =
        ::pread(fd, out.data() + done, out.size() - done, static_cast<off_t>(offset + done));
    if (n < 0) {
      if (errno == EINTR) continue;
      throw Error(std::string("read failed: ") + std::strerror(errno));
    }
    if (n == 0) return false;
    done += static_cast<size_t>(n);
  }
  return true;
}

}  // namespace detail
}  // namespace volcast
