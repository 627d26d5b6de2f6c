#pragma once
// Internal: the byte layout of recording.hpp's file header and record headers, and the Stream
// record's payload, shared by the writer and the reader.
#include <array>
#include <cstdint>
#include <span>
#include <string>
#include <vector>

#include "volcast/record/recording.hpp"

namespace volcast::detail {

inline constexpr std::array<uint8_t, 8> kRecordingMagic = {'V', 'C', 'R', 'E', 'C', 'O', 'R', 'D'};

/// The file header of format `version`.
std::array<uint8_t, kRecordingFileHeaderBytes> file_header(uint16_t version = kRecordingVersion);

struct RecordHeader {
  RecordType type{};
  uint32_t payload_bytes = 0;
  uint32_t payload_crc = 0;
};

std::array<uint8_t, kRecordHeaderBytes> record_header(RecordType type,
                                                      std::span<const uint8_t> head,
                                                      std::span<const uint8_t> body);
/// False if the header's own CRC fails or a reserved byte is not 0 (the type is not checked).
bool parse_record_header(std::span<const uint8_t, kRecordHeaderBytes> bytes, RecordHeader& out);

std::vector<uint8_t> serialize_stream(const RecordingStream& s);
/// Throws Error("malformed recording stream: ...").
RecordingStream parse_stream(std::span<const uint8_t> payload);

/// A Voice record's payload before its Opus bytes: participant, sequence, frame, capture time, the
/// byte string's length u32.
inline constexpr size_t kVoiceHeadBytes = 24;
/// The largest Speaker record payload: participant, a name of 65535 bytes, role.
inline constexpr uint32_t kMaxSpeakerRecordBytes = 4 + 2 + 65535 + 1;

/// Appends a Speaker record's payload to `out` (cleared first).
void serialize_speaker(const RecordedSpeaker& s, std::vector<uint8_t>& out);
/// Throws Error("malformed speaker: ...").
RecordedSpeaker parse_speaker(std::span<const uint8_t> payload);
/// A Voice record's head (kVoiceHeadBytes; the Opus bytes follow it).
std::array<uint8_t, kVoiceHeadBytes> voice_head(const RecordedVoice& v);
/// Parses a Voice record's payload (offset left 0); `opus` is set to its Opus bytes. Throws
/// Error("malformed voice: ...") for a wrong length or a packet of 0 or over 1275 bytes.
RecordedVoice parse_voice(std::span<const uint8_t> payload, std::span<const uint8_t>& opus);

/// A Drawing record's payload before the session payload: type u8, receive time i64, the byte
/// string's length u32.
inline constexpr size_t kDrawingHeadBytes = 13;
inline constexpr uint32_t kMaxDrawingRecordBytes = kDrawingHeadBytes + kMaxRecordedDrawingBytes;
/// A Drawing record's head (kDrawingHeadBytes; the session payload follows it).
std::array<uint8_t, kDrawingHeadBytes> drawing_head(const RecordedDrawing& d);
/// Parses a Drawing record's payload (offset left 0); `session_payload` is set to the session
/// message's payload. Throws Error("malformed drawing: ...") for another type, a wrong length, or
/// a session payload that session::parse_annotation / parse_erased refuses (its error named).
RecordedDrawing parse_drawing(std::span<const uint8_t> payload,
                              std::span<const uint8_t>& session_payload);
/// Throws Error("malformed drawing: ...") unless `payload` is a valid session message of `type`
/// (kDrawingAnnotation or kDrawingErased) of 1..kMaxRecordedDrawingBytes bytes.
void check_drawing(uint8_t type, std::span<const uint8_t> payload);

/// What a record of `type` is, for people ("frame set", "voice", ...).
inline const char* record_kind(RecordType type) {
  switch (type) {
    case RecordType::kStream:
      return "stream description";
    case RecordType::kFrameSet:
      return "frame set";
    case RecordType::kIndex:
      return "index";
    case RecordType::kEnd:
      return "end record";
    case RecordType::kSpeaker:
      return "speaker";
    case RecordType::kVoice:
      return "voice";
    case RecordType::kDrawing:
      return "drawing";
  }
  return "record";
}

/// Reads exactly out.size() bytes at `offset`; false if the file ends first. Throws Error on an
/// I/O error.
bool read_at(int fd, uint64_t offset, std::span<uint8_t> out);

}  // namespace volcast::detail
