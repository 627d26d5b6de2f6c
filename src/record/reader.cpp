#include <fcntl.h>
#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "record_format.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"

namespace volcast {
RecordingReader::RecordingReader(const std::filesystem::path& path) : path_(path) {
  const std::string where = "recording " + path.string();
  fd_ = ::open(path.c_str(), O_RDONLY | O_CLOEXEC);
  if (fd_ < 0) throw Error(where + ": cannot open: " + std::strerror(errno));
  try {
    struct stat st {};
    if (::fstat(fd_, &st) != 0) throw Error(where + ": cannot stat: " + std::strerror(errno));
    if (!S_ISREG(st.st_mode)) throw Error(where + ": not a regular file");
    info_.file_bytes = static_cast<uint64_t>(st.st_size);
    std::array<uint8_t, kRecordingFileHeaderBytes> fh{};
    if (!detail::read_at(fd_, 0, fh))
      throw Error(where + ": not a Volcast recording (" + std::to_string(info_.file_bytes) +
                  " bytes, shorter than the 16-byte file header)");
    if (!std::equal(detail::kRecordingMagic.begin(), detail::kRecordingMagic.end(), fh.begin()))
      throw Error(where + ": not a Volcast recording (no VCRECORD magic at offset 0)");
    const auto version = wire::load<uint16_t>(fh.data() + 8);
    if (version < 1 || version > kRecordingVersion)
      throw Error(where + ": format version " + std::to_string(version) +
                  ", this build reads 1 to " + std::to_string(kRecordingVersion));
    if (fh != detail::file_header(version))
      throw Error(where + ": corrupt file header at offset 0 (fails its CRC)");
    info_.version = version;
    // The Stream record: without it nothing can be replayed.
    std::array<uint8_t, kRecordHeaderBytes> rh{};
    detail::RecordHeader h;
    const uint64_t at = kRecordingFileHeaderBytes;
    if (!detail::read_at(fd_, at, rh))
      throw Error(where + ": ends at offset " + std::to_string(info_.file_bytes) +
                  " before its stream description (a recorder stopped while starting)");
    if (!detail::parse_record_header(rh, h) || h.type != RecordType::kStream ||
        h.payload_bytes > protocol::kMaxWelcomeBytes + (1u << 18))
      throw Error(where + ": corrupt stream description at offset " + std::to_string(at));
    std::vector<uint8_t> payload(h.payload_bytes);
    if (!detail::read_at(fd_, at + kRecordHeaderBytes, payload))
      throw Error(where + ": ends at offset " + std::to_string(info_.file_bytes) +
                  " inside its stream description (a recorder stopped while starting)");
    if (crc32_of(payload) != h.payload_crc)
      throw Error(where + ": corrupt stream description at offset " + std::to_string(at) +
                  " (fails its CRC)");
    try {
      info_.stream = detail::parse_stream(payload);
    } catch (const Error& e) {
      throw Error(where + ": stream description at offset " + std::to_string(at) + ": " + e.what());
    }
    records_at_ = at + kRecordHeaderBytes + h.payload_bytes;
    if (!read_index()) scan();
  } catch (...) {
    ::close(fd_);
    throw;
  }
}

RecordingReader::~RecordingReader() {
  if (fd_ >= 0) ::close(fd_);
}

// A closed file ends in End -> Index. Returns false (scan instead) if it does not; throws if they
// are there but disagree with the file.
bool RecordingReader::read_index() {
  const std::string where = "recording " + path_.string();
  const uint64_t size = info_.file_bytes;
  constexpr uint64_t kEndBytes = kRecordHeaderBytes + 8;
  if (size < kRecordingFileHeaderBytes + 2 * kRecordHeaderBytes + kEndBytes) return false;
  std::array<uint8_t, kEndBytes> end{};
  if (!detail::read_at(fd_, size - kEndBytes, end)) return false;
  detail::RecordHeader h;
  if (!detail::parse_record_header(std::span(end).first<kRecordHeaderBytes>(), h) ||
      h.type != RecordType::kEnd || h.payload_bytes != 8 ||
      crc32_of(std::span(end).subspan(kRecordHeaderBytes)) != h.payload_crc)
    return false;
  const auto index_at = wire::load<uint64_t>(end.data() + kRecordHeaderBytes);
  const std::string at_index = " at offset " + std::to_string(index_at);
  std::array<uint8_t, kRecordHeaderBytes> rh{};
  if (index_at >= size - kEndBytes || !detail::read_at(fd_, index_at, rh) ||
      !detail::parse_record_header(rh, h) || h.type != RecordType::kIndex ||
      index_at + kRecordHeaderBytes + h.payload_bytes != size - kEndBytes)
    throw Error(where + ": corrupt index" + at_index + " (named by the end record at offset " +
                std::to_string(size - kEndBytes) + ")");
  std::vector<uint8_t> payload(h.payload_bytes);
  if (!detail::read_at(fd_, index_at + kRecordHeaderBytes, payload) ||
      crc32_of(payload) != h.payload_crc)
    throw Error(where + ": corrupt index" + at_index + " (fails its CRC)");
  parse_index(payload, index_at);
  info_.closed = true;
  return true;
}

void RecordingReader::scan() {
  const std::string where = "recording " + path_.string();
  const uint64_t size = info_.file_bytes;
  std::array<uint8_t, kRecordHeaderBytes> rh{};
  detail::RecordHeader h;
  uint64_t at = records_at_;
  std::vector<uint8_t> payload;
  const auto tail = [&](const std::string& why) {
    info_.incomplete_tail_at = at;
    info_.tail_reason = why;
  };
  // True if every byte from `from` to the end of the file is 0 (space a lost write left).
  const auto zeros_to_end = [&](uint64_t from) {
    std::vector<uint8_t> buf(1 << 16);
    for (uint64_t p = from; p < size; p += buf.size()) {
      const size_t n = static_cast<size_t>(std::min<uint64_t>(buf.size(), size - p));
      if (!detail::read_at(fd_, p, std::span(buf).first(n))) return false;
      if (std::any_of(buf.begin(), buf.begin() + static_cast<ptrdiff_t>(n),
                      [](uint8_t b) { return b != 0; }))
        return false;
    }
    return true;
  };
  while (at < size) {
    if (size - at < kRecordHeaderBytes) {
      tail("a record header cut short (" + std::to_string(size - at) + " of 16 bytes)");
      return;
    }
    if (!detail::read_at(fd_, at, rh)) throw Error(where + ": changed while being read");
    if (!detail::parse_record_header(rh, h)) {
      if (zeros_to_end(at)) {
        tail("zeros to the end of the file (a write the disk never finished)");
        return;
      }
      throw Error(where + ": corrupt record header at offset " + std::to_string(at));
    }
    const uint64_t next = at + kRecordHeaderBytes + h.payload_bytes;
    const bool voices = info_.version >= 2, drawings = info_.version >= 3;
    const bool voice = h.type == RecordType::kVoice, speaker = h.type == RecordType::kSpeaker;
    const bool drawing = h.type == RecordType::kDrawing;
    if (h.type != RecordType::kFrameSet && h.type != RecordType::kIndex &&
        h.type != RecordType::kEnd && !(voices && (voice || speaker)) && !(drawings && drawing))
      throw Error(where + ": record of unknown type " + std::to_string(static_cast<int>(h.type)) +
                  " at offset " + std::to_string(at));
    const uint32_t limit = voice     ? uint32_t{detail::kVoiceHeadBytes + kMaxRecordedVoiceBytes}
                           : speaker ? detail::kMaxSpeakerRecordBytes
                           : drawing ? detail::kMaxDrawingRecordBytes
                                     : kMaxRecordBytes;
    const std::string kind = detail::record_kind(h.type);
    if (h.payload_bytes > limit)
      throw Error(where + ": " + kind + " record of " + std::to_string(h.payload_bytes) +
                  " bytes (over the limit of " + std::to_string(limit) + ") at offset " +
                  std::to_string(at));
    if (next > size) {
      tail("the last record (" + kind + ") cut short (" +
           std::to_string(size - at - kRecordHeaderBytes) + " of " +
           std::to_string(h.payload_bytes) + " bytes)");
      return;
    }
    payload.resize(h.payload_bytes);
    if (!detail::read_at(fd_, at + kRecordHeaderBytes, payload))
      throw Error(where + ": changed while being read");
    if (crc32_of(payload) != h.payload_crc) {
      if (next == size) {
        tail("a last record (" + kind + ") whose bytes never all reached the disk (fails its CRC)");
        return;
      }
      throw Error(where + ": corrupt " + kind + " at offset " + std::to_string(at) +
                  " (fails its CRC)");
    }
    try {
      if (speaker) add_speaker(detail::parse_speaker(payload));
      if (voice) {
        std::span<const uint8_t> opus;
        add_voice(detail::parse_voice(payload, opus), at);
      }
      if (drawing) {
        std::span<const uint8_t> session_payload;
        add_drawing(detail::parse_drawing(payload, session_payload), at);
      }
    } catch (const Error& err) {
      throw Error(where + ": " + kind + " at offset " + std::to_string(at) + ": " + err.what());
    }
    if (h.type == RecordType::kFrameSet) {
      RecordedFrameSet e;
      try {
        e = frame_set_head(payload);
      } catch (const Error& err) {
        throw Error(where + ": frame set at offset " + std::to_string(at) + ": " + err.what());
      }
      e.offset = at;
      info_.frame_sets.push_back(e);
    }
    // An Index or End record here belongs to a close that did not complete; skip it.
    at = next;
  }
}

void RecordingReader::read(size_t k, std::vector<uint8_t>& body, size_t at_front) {
  const std::string where = "recording " + path_.string();
  if (k >= info_.frame_sets.size())
    throw Error(where + ": no frame set " + std::to_string(k) + " (it has " +
                std::to_string(info_.frame_sets.size()) + ")");
  const RecordedFrameSet& e = info_.frame_sets[k];
  const std::string at = " at offset " + std::to_string(e.offset);
  std::array<uint8_t, kRecordHeaderBytes> rh{};
  detail::RecordHeader h;
  if (!detail::read_at(fd_, e.offset, rh))
    throw Error(where + ": ends before frame set " + std::to_string(k) + at);
  if (!detail::parse_record_header(rh, h) || h.type != RecordType::kFrameSet ||
      h.payload_bytes != e.bytes)
    throw Error(where + ": corrupt record header of frame set " + std::to_string(k) + at);
  body.resize(at_front + e.bytes);
  const std::span<uint8_t> payload = std::span(body).subspan(at_front);
  if (!detail::read_at(fd_, e.offset + kRecordHeaderBytes, payload))
    throw Error(where + ": ends inside frame set " + std::to_string(k) + at);
  if (crc32_of(payload) != h.payload_crc)
    throw Error(where + ": corrupt frame set " + std::to_string(k) + at + " (fails its CRC)");
  const RecordedFrameSet head = frame_set_head(payload);
  if (head.sequence != e.sequence || head.key != e.key || head.capture_us != e.capture_us)
    throw Error(where + ": frame set " + std::to_string(k) + at + " differs from its index entry");
}

void RecordingReader::verify(const std::function<void(size_t, size_t)>& progress) {
  std::vector<uint8_t> body;
  const size_t total = info_.frame_sets.size() + info_.voices.size() + info_.drawings.size();
  for (size_t k = 0; k < info_.frame_sets.size(); ++k) {
    read(k, body);
    if (progress) progress(k + 1, total);
  }
  for (size_t k = 0; k < info_.voices.size(); ++k) {
    read_voice(info_.voices[k], body);
    if (progress) progress(info_.frame_sets.size() + k + 1, total);
  }
  for (size_t k = 0; k < info_.drawings.size(); ++k) {
    read_drawing(info_.drawings[k], body);
    if (progress) progress(info_.frame_sets.size() + info_.voices.size() + k + 1, total);
  }
}

}  // namespace volcast
