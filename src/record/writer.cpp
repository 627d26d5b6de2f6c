#include <fcntl.h>
#include <sys/stat.h>
#include <sys/uio.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>

#include "record_format.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"

namespace volcast {
namespace {

bool out_of_space(int e) {
  return e == ENOSPC || e == EDQUOT || e == EFBIG;
}

// Writes every byte of `iov` (a short write continues where it stopped). Returns 0 or errno.
int write_fully(int fd, iovec* iov, int count) {
  while (count > 0) {
    const ssize_t n = ::writev(fd, iov, count);
    if (n < 0) {
      if (errno == EINTR) continue;
      return errno;
    }
    size_t left = static_cast<size_t>(n);
    while (count > 0 && left >= iov->iov_len) {
      left -= iov->iov_len;
      ++iov;
      --count;
    }
    if (count > 0) {
      iov->iov_base = static_cast<uint8_t*>(iov->iov_base) + left;
      iov->iov_len -= left;
    }
  }
  return 0;
}

std::string megabytes(uint64_t bytes) {
  char s[32];
  std::snprintf(s, sizeof s, "%.1f MB", static_cast<double>(bytes) / 1e6);
  return s;
}

}  // namespace

RecordingWriter::RecordingWriter(const std::filesystem::path& path, const RecordingStream& stream,
                                 RecordingWriterOptions options)
    : path_(path), options_(options) {
  const int flags = O_WRONLY | O_CREAT | O_CLOEXEC | (options.overwrite ? O_TRUNC : O_EXCL);
  // Mode 0600: a recording shows the OR, for its owner only (also when it replaces a file).
  fd_ = ::open(path.c_str(), flags, 0600);
  if (fd_ < 0) {
    if (errno == EEXIST)
      throw Error("recording " + path.string() + ": exists already (choose another name)");
    throw Error("recording " + path.string() + ": cannot create: " + std::strerror(errno));
  }
  if (::fchmod(fd_, 0600) != 0) {
    const int e = errno;
    ::close(fd_);
    fd_ = -1;
    throw Error("recording " + path.string() + ": cannot make it private: " + std::strerror(e));
  }
  const auto header = detail::file_header();
  iovec iov{const_cast<uint8_t*>(header.data()), header.size()};
  if (const int e = write_fully(fd_, &iov, 1)) fail_write(e, "the file header");
  end_ = header.size();
  const std::vector<uint8_t> s = detail::serialize_stream(stream);
  write_record(RecordType::kStream, s, {});
  if (::fdatasync(fd_) != 0) fail_write(errno, "the stream description");
  last_sync_us_ = wall_clock_us();
}

RecordingWriter::~RecordingWriter() {
  try {
    close();
  } catch (const Error&) {
  }
  if (fd_ >= 0) ::close(fd_);
}

void RecordingWriter::fail_write(int error_number, const char* what) {
  failed_ = true;
  // Cut back a partial record so the file ends in a complete one, and keep what came before.
  if (fd_ >= 0) {
    [[maybe_unused]] const int t = ::ftruncate(fd_, static_cast<off_t>(end_));
    ::fdatasync(fd_);
  }
  const std::string kept =
      std::to_string(index_.size()) + " frame sets" +
      (voices_.empty() ? "" : ", " + std::to_string(voices_.size()) + " voices") +
      (drawings_.empty() ? "" : ", " + std::to_string(drawings_.size()) + " drawings") + " (" +
      megabytes(end_) + ") written before it are kept and replay";
  if (out_of_space(error_number))
    throw Error("recording " + path_.string() + ": disk full (" + std::strerror(error_number) +
                ") while writing " + what + "; " + kept);
  throw Error("recording " + path_.string() + ": cannot write " + what + ": " +
              std::strerror(error_number) + "; " + kept);
}

void RecordingWriter::write_record(RecordType type, std::span<const uint8_t> head,
                                   std::span<const uint8_t> body) {
  const auto header = detail::record_header(type, head, body);
  iovec iov[3] = {{const_cast<uint8_t*>(header.data()), header.size()},
                  {const_cast<uint8_t*>(head.data()), head.size()},
                  {const_cast<uint8_t*>(body.data()), body.size()}};
  if (const int e = write_fully(fd_, iov, 3))
    fail_write(e, type == RecordType::kFrameSet  ? "a frame set"
                  : type == RecordType::kVoice   ? "a voice"
                  : type == RecordType::kSpeaker ? "a speaker"
                  : type == RecordType::kDrawing ? "a drawing"
                                                 : "the index");
  end_ += header.size() + head.size() + body.size();
}

void RecordingWriter::check_open() const {
  if (failed_ || closed_)
    throw Error("recording " + path_.string() + ": " +
                (closed_ ? "closed" : "stopped by an error"));
}

void RecordingWriter::maybe_sync(const char* what) {
  const int64_t now = wall_clock_us();
  if (now - last_sync_us_ >= int64_t{options_.sync_interval_ms} * 1000) {
    if (::fdatasync(fd_) != 0) fail_write(errno, what);
    last_sync_us_ = now;
  }
}

void RecordingWriter::append(std::span<const uint8_t> body) {
  check_open();
  if (body.size() > kMaxRecordBytes)
    throw Error("recording " + path_.string() + ": frame set of " + std::to_string(body.size()) +
                " bytes is over the limit");
  RecordedFrameSet entry = frame_set_head(body);
  entry.offset = end_;
  write_record(RecordType::kFrameSet, {}, body);
  index_.push_back(entry);
  maybe_sync("a frame set (sync)");
}

void RecordingWriter::append_speaker(uint32_t participant, const std::string& name, uint8_t role) {
  check_open();
  if (name.size() > 65535)
    throw Error("recording " + path_.string() + ": display name of " + std::to_string(name.size()) +
                " bytes is over 65535");
  // The last record of this participant holds; write only what changes it.
  for (auto it = speakers_.rbegin(); it != speakers_.rend(); ++it)
    if (it->speaker.participant == participant) {
      if (it->speaker.name == name && it->speaker.role == role) return;
      break;
    }
  const RecordedSpeaker s{participant, name, role};
  detail::serialize_speaker(s, scratch_);
  const uint64_t at = end_;
  write_record(RecordType::kSpeaker, scratch_, {});
  speakers_.push_back({at, s});
  maybe_sync("a speaker (sync)");
}

void RecordingWriter::append_voice(uint32_t participant, uint32_t sequence, uint32_t frame,
                                   int64_t capture_us, std::span<const uint8_t> opus) {
  check_open();
  if (opus.empty() || opus.size() > kMaxRecordedVoiceBytes)
    throw Error("recording " + path_.string() + ": voice packet of " + std::to_string(opus.size()) +
                " bytes from participant " + std::to_string(participant) +
                " refused (Opus packets are 1.." + std::to_string(kMaxRecordedVoiceBytes) +
                " bytes)");
  const bool known = std::any_of(speakers_.begin(), speakers_.end(), [&](const SpeakerEntry& e) {
    return e.speaker.participant == participant;
  });
  if (!known) append_speaker(participant, "participant " + std::to_string(participant), 0);
  RecordedVoice v{end_,  participant, sequence,
                  frame, capture_us,  static_cast<uint16_t>(opus.size())};
  const auto head = detail::voice_head(v);
  write_record(RecordType::kVoice, head, opus);
  voices_.push_back(v);
  maybe_sync("a voice (sync)");
}

void RecordingWriter::append_drawing(uint8_t type, int64_t received_us,
                                     std::span<const uint8_t> payload) {
  check_open();
  try {
    detail::check_drawing(type, payload);
  } catch (const Error& e) {
    throw Error("recording " + path_.string() + ": drawing refused: " + e.what());
  }
  const RecordedDrawing d{end_, type, received_us, static_cast<uint32_t>(payload.size())};
  const auto head = detail::drawing_head(d);
  write_record(RecordType::kDrawing, head, payload);
  drawings_.push_back(d);
  maybe_sync("a drawing (sync)");
}

void RecordingWriter::close() {
  if (closed_ || fd_ < 0) return;
  closed_ = true;
  if (failed_) return;  // what was written stays; a reader indexes it by scanning
  std::vector<uint8_t> index;
  wire::Writer w(index);
  w.put<uint32_t>(static_cast<uint32_t>(index_.size()));
  for (const RecordedFrameSet& e : index_) {
    w.put<uint64_t>(e.offset);
    w.put<uint64_t>(e.sequence);
    w.put<int64_t>(e.capture_us);
    w.put<uint8_t>(e.key ? 1 : 0);
  }
  w.put<uint32_t>(static_cast<uint32_t>(speakers_.size()));
  for (const SpeakerEntry& e : speakers_) {
    w.put<uint64_t>(e.offset);
    w.put<uint32_t>(e.speaker.participant);
    w.put<uint8_t>(e.speaker.role);
    w.put_string(e.speaker.name);
  }
  w.put<uint32_t>(static_cast<uint32_t>(voices_.size()));
  for (const RecordedVoice& v : voices_) {
    w.put<uint64_t>(v.offset);
    w.put<uint32_t>(v.participant);
    w.put<uint32_t>(v.sequence);
    w.put<uint32_t>(v.frame);
    w.put<int64_t>(v.capture_us);
    w.put<uint16_t>(v.bytes);
  }
  w.put<uint32_t>(static_cast<uint32_t>(drawings_.size()));
  for (const RecordedDrawing& d : drawings_) {
    w.put<uint64_t>(d.offset);
    w.put<uint8_t>(d.type);
    w.put<int64_t>(d.received_us);
    w.put<uint32_t>(d.bytes);
  }
  const uint64_t index_at = end_;
  write_record(RecordType::kIndex, index, {});
  std::array<uint8_t, 8> end_payload{};
  wire::store<uint64_t>(end_payload.data(), index_at);
  write_record(RecordType::kEnd, end_payload, {});
  if (::fsync(fd_) != 0) fail_write(errno, "the index (sync)");
  ::close(fd_);
  fd_ = -1;
}

}  // namespace volcast
