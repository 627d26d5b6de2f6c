// libFuzzer target: the recording reader and decoder (volcast/record) on hostile files. The first
// byte picks how the input becomes a file: 0 the input itself; 1 a valid recording (raw depth,
// 8x4, 5 frame sets, a speaker, a voice, and drawing: a stroke, a label and an erasure) with the
// input's (offset, xor) patches and a cut; 2 the same with every record's CRCs made right again, so
// that the parsers behind them see the damage. Opening, verifying, reading and decoding may throw
// Error, nothing else (no crash, no read past the file, no allocation the file's size does not
// bound).
#include <sys/mman.h>
#include <unistd.h>

#include <cstdint>
#include <cstring>
#include <span>
#include <string>
#include <vector>

#include "volcast/codec/depth_codec.hpp"
#include "volcast/core/error.hpp"
#include "volcast/record/decode.hpp"
#include "volcast/record/recording.hpp"
#include "volcast/session/annotations.hpp"

namespace {

using namespace volcast;

struct Template {
  std::vector<uint8_t> bytes;
  std::vector<std::pair<size_t, size_t>> records;  // (offset, payload length)
};

Template make_template() {
  RecordingStream s;
  s.tier = {"raw", "none"};
  protocol::CameraInfo c;
  c.calibration.depth = Intrinsics{8, 4, 10, 10, 4, 2};
  s.welcome.cameras.push_back(c);
  char path[] = "/tmp/volcast-fuzz-XXXXXX";
  const int fd = mkstemp(path);
  close(fd);
  unlink(path);
  {
    RecordingWriter w(path, s);
    auto enc = make_depth_encoder("raw");
    DepthImage d(8, 4);
    for (int k = 0; k < 5; ++k) {
      for (size_t i = 0; i < d.pixels.size(); ++i) d.pixels[i] = static_cast<uint16_t>(k * 100 + i);
      protocol::EncodedCamera cam;
      enc->encode(d, true, cam.depth);
      std::vector<uint8_t> body;
      protocol::serialize_frame_set_body(k + 1, true, {k * 33333, 0, 0, 0}, std::span(&cam, 1),
                                         body);
      w.append(body);
      if (k == 1) {
        w.append_speaker(5, "Dr. Fuzz", 0);
        const uint8_t opus[3] = {1, 2, 3};
        w.append_voice(5, 1, 1, 40000, opus);
        session::Annotation a;
        a.id = 1;
        a.author = 5;
        a.points = {{0.f, 1.f, 0.f}, {0.1f, 1.f, 0.f}, {0.2f, 1.1f, 0.f}};
        w.append_drawing(kDrawingAnnotation, 40000, session::serialize(a));
        a.id = 2;
        a.kind = session::AnnotationKind::kLabel;
        a.points.resize(1);
        a.text = "here";
        w.append_drawing(kDrawingAnnotation, 45000, session::serialize(a));
      }
      if (k == 3) w.append_drawing(kDrawingErased, 110000, session::serialize_erased(1, 5));
    }
  }
  Template t;
  FILE* f = std::fopen(path, "rb");
  for (int ch; (ch = std::fgetc(f)) != EOF;) t.bytes.push_back(static_cast<uint8_t>(ch));
  std::fclose(f);
  unlink(path);
  for (size_t at = kRecordingFileHeaderBytes; at + kRecordHeaderBytes <= t.bytes.size();) {
    uint32_t n = 0;
    std::memcpy(&n, t.bytes.data() + at + 4, 4);
    t.records.emplace_back(at, n);
    at += kRecordHeaderBytes + n;
  }
  return t;
}

void fix_crcs(std::vector<uint8_t>& b, const Template& t) {
  for (const auto& [at, n] : t.records) {
    if (at + kRecordHeaderBytes + n > b.size()) break;
    const uint32_t payload = crc32_of(std::span(b).subspan(at + kRecordHeaderBytes, n));
    std::memcpy(b.data() + at + 8, &payload, 4);
    const uint32_t header = crc32_of(std::span(b).subspan(at, 12));
    std::memcpy(b.data() + at + 12, &header, 4);
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  static const Template kTemplate = make_template();
  if (size == 0) return 0;
  std::vector<uint8_t> file;
  const std::span<const uint8_t> in(data + 1, size - 1);
  if (data[0] % 3 == 0) {
    file.assign(in.begin(), in.end());
  } else {
    file = kTemplate.bytes;
    size_t i = 0;
    if (in.size() >= 2) {  // a cut: the first two bytes, as a length from the end
      const size_t cut = (in[0] | in[1] << 8) % (file.size() + 1);
      if (cut < 512) file.resize(file.size() - cut);
      i = 2;
    }
    for (; i + 3 <= in.size(); i += 3) {
      const size_t at = (in[i] | in[i + 1] << 8) % (file.empty() ? 1 : file.size());
      if (!file.empty()) file[at] ^= in[i + 2];
    }
    if (data[0] % 3 == 2) fix_crcs(file, kTemplate);
  }
  const int fd = memfd_create("recording", 0);
  if (fd < 0) return 0;
  if (!file.empty() && write(fd, file.data(), file.size()) != static_cast<ssize_t>(file.size())) {
    close(fd);
    return 0;
  }
  const std::string path = "/proc/self/fd/" + std::to_string(fd);
  try {
    RecordingReader reader(path);
    try {
      reader.verify();
    } catch (const Error&) {
    }
    std::vector<uint8_t> payload;
    for (const RecordedDrawing& d : reader.info().drawings) {
      try {
        reader.read_drawing(d, payload);
      } catch (const Error&) {
      }
    }
    RecordingDecoder decoder(reader);
    FrameSet frames;
    for (size_t k = 0; k < reader.info().frame_sets.size(); ++k) {
      try {
        decoder.decode(k, frames);
      } catch (const Error&) {
      }
    }
  } catch (const Error&) {
  }
  close(fd);
  return 0;
}
