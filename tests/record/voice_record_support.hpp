#pragma once
// Shared by the voice recording tests: temporary files, synthetic frame sets and voice packets
// (byte patterns standing in for Opus packets: records are not decoded here), hand-framed records.
#include <gtest/gtest.h>
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <functional>

#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/net/protocol/frame_set.hpp"
#include "volcast/record/recording.hpp"

namespace volcast::voice_test {

namespace fs = std::filesystem;

inline fs::path temp_dir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("voice_record_test_" + std::to_string(getpid()) + "_" + name);
  fs::remove_all(d);
  fs::create_directories(d);
  return d;
}

inline std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

inline std::vector<uint8_t> file_bytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return {std::istreambuf_iterator<char>(in), {}};
}

inline void put_file(const fs::path& p, std::span<const uint8_t> bytes) {
  std::ofstream out(p, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(bytes.data()),
            static_cast<std::streamsize>(bytes.size()));
}

// Synthetic (for exact behaviour only): a one-camera 8x4 site, as record_test has it.
inline RecordingStream tiny_stream() {
  RecordingStream s;
  s.tier.depth_codec = "raw";
  s.tier.color_codec = "none";
  s.started_us = 1;
  s.origin = "voice_record_test";
  protocol::CameraInfo c;
  c.calibration.depth = Intrinsics{8, 4, 10, 10, 4, 2};
  c.description = "synthetic";
  s.welcome.cameras.push_back(c);
  return s;
}

inline std::vector<uint8_t> tiny_body(uint64_t k) {
  protocol::EncodedCamera cam;
  cam.depth.assign(200, static_cast<uint8_t>(k));
  protocol::SenderTimes t;
  t.capture_us = 1'000'000 + static_cast<int64_t>(k) * 33'333;
  std::vector<uint8_t> body;
  protocol::serialize_frame_set_body(k + 1, k % 10 == 0, t, std::span(&cam, 1), body);
  return body;
}

// A synthetic voice packet: participant p's packet n (sequence n, frame n + n / 5: DTX skips).
inline RecordedVoicePacket packet(uint32_t p, uint32_t n) {
  RecordedVoicePacket v{p, n, n + n / 5, 1'000'000 + int64_t{n + n / 5} * 20'000 + p, {}};
  const size_t len = n == 0 ? 1 : n == 1 ? kMaxRecordedVoiceBytes : 40 + (n * 37 + p) % 120;
  v.bytes.resize(len);
  for (size_t i = 0; i < len; ++i) v.bytes[i] = static_cast<uint8_t>(p * 101 + n * 7 + i);
  return v;
}

inline bool same(const RecordedVoicePacket& a, const RecordedVoicePacket& b) {
  return a.participant == b.participant && a.sequence == b.sequence && a.frame == b.frame &&
         a.capture_us == b.capture_us && a.bytes == b.bytes;
}

// Writes frame sets and two speakers' voices interleaved (10 frame sets, 30 voices each): the
// order a recorder sees them. Returns the packets in the order written.
inline std::vector<RecordedVoicePacket> write_mixed(RecordingWriter& w) {
  std::vector<RecordedVoicePacket> written;
  w.append_speaker(7, "Dr. Aiko Tanaka", 0);
  w.append_speaker(1, "OR 3", 1);
  for (uint32_t n = 0; n < 30; ++n) {
    if (n % 3 == 0) w.append(tiny_body(n / 3));
    for (uint32_t p : {7u, 1u}) {
      written.push_back(packet(p, n));
      w.append_voice(written.back());
    }
  }
  return written;
}

inline void expect_voices(RecordingReader& r, const std::vector<RecordedVoicePacket>& written,
                          size_t count) {
  ASSERT_EQ(r.info().voices.size(), count);
  std::vector<uint8_t> bytes;
  for (size_t k = 0; k < count; ++k) {
    const RecordedVoice& v = r.info().voices[k];
    r.read_voice(v, bytes);
    RecordedVoicePacket got{v.participant, v.sequence, v.frame, v.capture_us, bytes};
    ASSERT_TRUE(same(got, written[k])) << "voice " << k;
  }
}

// A record with valid CRCs around `payload`, as a (hostile) writer would frame it.
inline std::vector<uint8_t> framed(RecordType type, const std::vector<uint8_t>& payload) {
  std::vector<uint8_t> h(16, 0);
  h[0] = static_cast<uint8_t>(type);
  wire::store<uint32_t>(h.data() + 4, static_cast<uint32_t>(payload.size()));
  wire::store<uint32_t>(h.data() + 8, crc32_of(payload));
  wire::store<uint32_t>(h.data() + 12, crc32_of(std::span(h).first(12)));
  h.insert(h.end(), payload.begin(), payload.end());
  return h;
}

inline std::vector<uint8_t> voice_payload(uint32_t length_field, size_t actual) {
  std::vector<uint8_t> p;
  wire::Writer w(p);
  w.put<uint32_t>(3);  // participant
  w.put<uint32_t>(1);
  w.put<uint32_t>(1);
  w.put<int64_t>(5);
  w.put<uint32_t>(length_field);
  p.resize(p.size() + actual, 0x55);
  return p;
}

}  // namespace volcast::voice_test
