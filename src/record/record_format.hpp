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

std::array<uint8_t, kRecordingFileHeaderBytes> file_header();

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

/// Reads exactly out.size() bytes at `offset`; false if the file ends first. Throws Error on an
/// I/O error.
bool read_at(int fd, uint64_t offset, std::span<uint8_t> out);

}  // namespace volcast::detail
