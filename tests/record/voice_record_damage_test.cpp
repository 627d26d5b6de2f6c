// Damaged voice recordings (volcast/record): a corrupt voice names its offset, oversized packets
// are refused by the writer and the reader, and version-1 files (no voices) still read. The "Opus
// packets" are synthetic byte patterns (voice_record_support.hpp).
#include <gtest/gtest.h>

#include "voice_record_support.hpp"

namespace volcast {
namespace {

using namespace voice_test;

TEST(VoiceRecording, ACorruptVoiceInTheMiddleIsAnErrorNamingItsOffset) {
  const fs::path dir = temp_dir("corrupt");
  const fs::path path = dir / "v.vcr";
  std::vector<uint8_t> open_image;
  {
    RecordingWriter w(path, tiny_stream());
    write_mixed(w);
    open_image = file_bytes(path);
  }
  const std::vector<uint8_t> closed = file_bytes(path);
  RecordingReader ok(path);
  const RecordedVoice v = ok.info().voices[20];
  const std::string at = "at offset " + std::to_string(v.offset);
  const fs::path bad = dir / "bad.vcr";
  // A flipped Opus byte: a scan refuses the file; with the index, reading the voice does.
  for (const bool indexed : {false, true}) {
    std::vector<uint8_t> b = indexed ? closed : open_image;
    b[v.offset + 16 + 24 + 3] ^= 0x20;
    put_file(bad, b);
    const std::string error = error_of([&] {
      RecordingReader r(bad);
      r.verify();
    });
    EXPECT_NE(error.find("corrupt"), std::string::npos) << error;
    EXPECT_NE(error.find(at), std::string::npos) << error;
    EXPECT_NE(error.find("voice"), std::string::npos) << error;
  }
  // A flipped bit in its record header, or an index entry that moved it.
  std::vector<uint8_t> b = open_image;
  b[v.offset + 5] ^= 0x01;
  put_file(bad, b);
  EXPECT_NE(error_of([&] { RecordingReader r(bad); }).find("corrupt record header " + at),
            std::string::npos);
}

TEST(VoiceRecording, AnOversizedVoicePacketIsRefusedByTheWriterAndTheReader) {
  const fs::path dir = temp_dir("oversized");
  const fs::path path = dir / "v.vcr";
  std::vector<uint8_t> open_image;
  {
    RecordingWriter w(path, tiny_stream());
    w.append_speaker(3, "three", 0);
    const std::vector<uint8_t> big(kMaxRecordedVoiceBytes + 1, 1);
    EXPECT_NE(error_of([&] { w.append_voice(3, 1, 1, 5, big); }).find("1276 bytes"),
              std::string::npos);
    EXPECT_NE(error_of([&] { w.append_voice(3, 1, 1, 5, {}); }).find("0 bytes"), std::string::npos);
    w.append_voice(packet(3, 1));  // the writer goes on
    open_image = file_bytes(path);
  }
  EXPECT_EQ(RecordingReader(path).info().voices.size(), 1u);
  const auto refused = [&](const std::vector<uint8_t>& record) {
    std::vector<uint8_t> b = open_image;
    b.insert(b.end(), record.begin(), record.end());
    const std::vector<uint8_t> after = framed(RecordType::kVoice, voice_payload(4, 4));
    b.insert(b.end(), after.begin(), after.end());
    put_file(dir / "bad.vcr", b);
    return error_of([&] { RecordingReader r(dir / "bad.vcr"); });
  };
  const std::string at = "at offset " + std::to_string(open_image.size());
  // A record longer than any voice, and a length field over 1275 inside a short record.
  std::string e = refused(framed(RecordType::kVoice, voice_payload(1276, 1276)));
  EXPECT_NE(e.find("voice record of 1300 bytes (over the limit of 1299) " + at), std::string::npos)
      << e;
  e = refused(framed(RecordType::kVoice, voice_payload(1276, 100)));
  EXPECT_NE(e.find("voice " + at + ": malformed voice: an Opus packet of 1276 bytes"),
            std::string::npos)
      << e;
  e = refused(framed(RecordType::kVoice, voice_payload(0, 0)));
  EXPECT_NE(e.find("an Opus packet of 0 bytes"), std::string::npos) << e;
  e = refused(framed(RecordType::kVoice, voice_payload(50, 40)));
  EXPECT_NE(e.find("does not fit"), std::string::npos) << e;
  // A voice whose speaker was never named.
  std::vector<uint8_t> stranger = voice_payload(4, 4);
  stranger[0] = 9;
  e = refused(framed(RecordType::kVoice, stranger));
  EXPECT_NE(e.find("participant 9, who has no speaker record"), std::string::npos) << e;
}

// A version-1 file as the format's comment describes it, byte by byte.
std::vector<uint8_t> version1_file(size_t frame_sets, bool closed, bool with_voice) {
  std::vector<uint8_t> f = {'V', 'C', 'R', 'E', 'C', 'O', 'R', 'D', 1, 0, 0, 0, 0, 0, 0, 0};
  wire::store<uint32_t>(f.data() + 12, crc32_of(std::span(f).first(12)));
  const RecordingStream s = tiny_stream();
  std::vector<uint8_t> stream;
  wire::Writer w(stream);
  w.put_string(s.tier.depth_codec);
  w.put_string(s.tier.color_codec);
  w.put<uint8_t>(0);
  w.put<int64_t>(s.started_us);
  w.put_string(s.origin);
  w.put_bytes(protocol::serialize(s.welcome));
  const auto add = [&](const std::vector<uint8_t>& r) { f.insert(f.end(), r.begin(), r.end()); };
  add(framed(RecordType::kStream, stream));
  std::vector<uint8_t> index;
  wire::Writer iw(index);
  iw.put<uint32_t>(static_cast<uint32_t>(frame_sets));
  for (size_t k = 0; k < frame_sets; ++k) {
    const std::vector<uint8_t> body = tiny_body(k);
    iw.put<uint64_t>(f.size());
    iw.put<uint64_t>(k + 1);
    iw.put<int64_t>(1'000'000 + static_cast<int64_t>(k) * 33'333);
    iw.put<uint8_t>(k % 10 == 0);
    add(framed(RecordType::kFrameSet, body));
  }
  if (with_voice) add(framed(RecordType::kVoice, voice_payload(4, 4)));
  if (closed) {
    const uint64_t index_at = f.size();
    add(framed(RecordType::kIndex, index));
    std::vector<uint8_t> end(8);
    wire::store<uint64_t>(end.data(), index_at);
    add(framed(RecordType::kEnd, end));
  }
  return f;
}

TEST(VoiceRecording, AVersion1FileWithoutVoicesStillReads) {
  const fs::path dir = temp_dir("v1");
  for (const bool closed : {true, false}) {
    put_file(dir / "v1.vcr", version1_file(12, closed, false));
    RecordingReader r(dir / "v1.vcr");
    EXPECT_EQ(r.info().version, 1);
    EXPECT_EQ(r.info().closed, closed);
    EXPECT_FALSE(r.info().incomplete_tail_at);
    EXPECT_TRUE(r.info().speakers.empty());
    EXPECT_TRUE(r.info().voices.empty());
    ASSERT_EQ(r.info().frame_sets.size(), 12u);
    std::vector<uint8_t> body;
    for (size_t k = 0; k < 12; ++k) {
      r.read(k, body);
      EXPECT_EQ(body, tiny_body(k));
    }
    EXPECT_NO_THROW(r.verify());
    EXPECT_TRUE(speaker_summaries(r.info()).empty());
  }
  // Voice records belong to version 2: in a version-1 file they are an unknown type.
  put_file(dir / "v1.vcr", version1_file(3, false, true));
  EXPECT_NE(error_of([&] { RecordingReader r(dir / "v1.vcr"); }).find("unknown type 6"),
            std::string::npos);
  // An unknown version is named.
  std::vector<uint8_t> v4 = version1_file(1, true, false);
  v4[8] = 4;
  wire::store<uint32_t>(v4.data() + 12, crc32_of(std::span(v4).first(12)));
  put_file(dir / "v1.vcr", v4);
  EXPECT_NE(error_of([&] { RecordingReader r(dir / "v1.vcr"); }).find("format version 4"),
            std::string::npos);
}

}  // namespace
}  // namespace volcast
