#include "k4a_mkv_writer.hpp"

#include <ebml/EbmlHead.h>
#include <ebml/EbmlSubHead.h>
#include <ebml/EbmlVoid.h>
#include <ebml/IOCallback.h>
#include <matroska/KaxAttached.h>
#include <matroska/KaxAttachments.h>
#include <matroska/KaxBlock.h>
#include <matroska/KaxCluster.h>
#include <matroska/KaxCues.h>
#include <matroska/KaxCuesData.h>
#include <matroska/KaxInfo.h>
#include <matroska/KaxInfoData.h>
#include <matroska/KaxSeekHead.h>
#include <matroska/KaxSegment.h>
#include <matroska/KaxSemantic.h>
#include <matroska/KaxTag.h>
#include <matroska/KaxTags.h>
#include <matroska/KaxTrackEntryData.h>
#include <matroska/KaxTrackVideo.h>
#include <matroska/KaxTracks.h>
#include <unistd.h>

#include <array>
#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <random>
#include <string>
#include <utility>
#include <vector>

#include "volcast/core/error.hpp"
#include "volcast/core/jpeg.hpp"
#include "volcast/core/private_file.hpp"

namespace volcast {
using namespace libebml;
using namespace libmatroska;

namespace {

constexpr uint64_t kTimestampScaleNs = 1000;  // block and cluster times in microseconds

// A 40-byte BITMAPINFOHEADER, little-endian (what V_MS/VFW/FOURCC's CodecPrivate holds).
std::array<uint8_t, 40> bitmap_info_header(uint32_t width, uint32_t height, uint16_t bits,
                                           const char (&fourcc)[5], uint32_t image_bytes) {
  std::array<uint8_t, 40> h{};
  const auto put32 = [&](size_t at, uint32_t v) {
    for (int i = 0; i < 4; ++i) h[at + i] = static_cast<uint8_t>(v >> (8 * i));
  };
  put32(0, 40);
  put32(4, width);
  put32(8, height);
  h[12] = 1;  // planes
  h[14] = static_cast<uint8_t>(bits);
  for (int i = 0; i < 4; ++i) h[16 + i] = static_cast<uint8_t>(fourcc[i]);
  put32(20, image_bytes);
  return h;
}

// The Azure Kinect rate (5, 15 or 30 fps) nearest to one frame every `frame_us`: the SDK's
// playback accepts no other.
uint64_t k4a_fps(int64_t frame_us) {
  const double fps = frame_us > 0 ? 1e6 / static_cast<double>(frame_us) : 30.0;
  double best = 30;
  for (double f : {5.0, 15.0, 30.0})
    if (std::abs(std::log(fps / f)) < std::abs(std::log(fps / best))) best = f;
  return static_cast<uint64_t>(best);
}

// The file libmatroska renders into; unlike libebml's StdIOCallback, a short write (a full disk)
// throws, naming the file and the reason.
class CheckedFile final : public IOCallback {
 public:
  explicit CheckedFile(const std::filesystem::path& path) : path_(path) {
    // Mode 0600: an export of the OR is its owner's only (volcast/core/private_file.hpp).
    const int fd = open_private_file(path, false);
    f_ = ::fdopen(fd, "wb");
    if (!f_) {
      ::close(fd);
      fail("cannot create");
    }
  }
  ~CheckedFile() override {
    if (f_) std::fclose(f_);
  }
  uint32 read(void*, size_t) override { return 0; }  // written only
  void setFilePointer(int64 offset, seek_mode mode) override {
    const int whence = mode == seek_current ? SEEK_CUR : mode == seek_end ? SEEK_END : SEEK_SET;
    if (fseeko(f_, offset, whence) != 0) fail("cannot seek");
  }
  size_t write(const void* buffer, size_t size) override {
    if (std::fwrite(buffer, 1, size, f_) != size) fail("cannot write");
    return size;
  }
  uint64 getFilePointer() override { return static_cast<uint64>(ftello(f_)); }
  void close() override {
    FILE* f = std::exchange(f_, nullptr);
    if (f && (std::fflush(f) != 0 || std::fclose(f) != 0)) fail("cannot finish writing");
  }

 private:
  [[noreturn]] void fail(const char* what) {
    throw Error("export: " + path_.string() + ": " + what + ": " + std::strerror(errno));
  }
  std::filesystem::path path_;
  FILE* f_ = nullptr;
};

}  // namespace

struct K4aMkvWriter::State {
  std::filesystem::path path;
  int width = 0, height = 0;
  uint64_t fps = 30;
  std::mt19937_64 uids{std::random_device{}()};
  std::unique_ptr<CheckedFile> file;
  KaxSegment segment;
  EbmlVoid seek_void, info_void;
  KaxTrackEntry* depth_track = nullptr;
  KaxTrackEntry* color_track = nullptr;
  KaxAttached* calibration = nullptr;
  std::vector<uint8_t> depth_bytes, jpeg;
  int64_t first_device_us = -1, last_device_us = 0, last_us = -1;
  bool header_written = false, closed = false;
  std::string calibration_json;

  [[noreturn]] void fail(const std::string& what) const {
    throw Error("export: " + path.string() + ": " + what);
  }
  uint64_t uid() {
    uint64_t u = 0;
    while (u == 0) u = uids() >> 4;  // 60 bits, non-zero, as k4arecorder draws them
    return u;
  }

  KaxTrackEntry& add_track(uint64_t number, const char* name, const std::array<uint8_t, 40>& bih) {
    auto& tracks = GetChild<KaxTracks>(segment);
    auto& t = AddNewChild<KaxTrackEntry>(tracks);
    t.SetGlobalTimecodeScale(kTimestampScaleNs);
    GetChild<KaxTrackNumber>(t).SetValue(number);
    GetChild<KaxTrackUID>(t).SetValue(uid());
    GetChild<KaxTrackType>(t).SetValue(MATROSKA_TRACK_TYPE_VIDEO);
    GetChild<KaxTrackName>(t).SetValueUTF8(name);
    GetChild<KaxCodecID>(t).SetValue("V_MS/VFW/FOURCC");
    GetChild<KaxCodecPrivate>(t).CopyBuffer(bih.data(), static_cast<uint32>(bih.size()));
    GetChild<KaxTrackDefaultDuration>(t).SetValue(1'000'000'000ull / fps);
    auto& video = GetChild<KaxTrackVideo>(t);
    GetChild<KaxVideoPixelWidth>(video).SetValue(static_cast<uint64>(width));
    GetChild<KaxVideoPixelHeight>(video).SetValue(static_cast<uint64>(height));
    return t;
  }

  // A SimpleTag `name` = `value`, targeted at a track or attachment UID (or at the whole file).
  enum class Target { file, track, attachment };
  void add_tag(const std::string& name, const std::string& value, Target target = Target::file,
               uint64_t target_uid = 0) {
    auto& tag = AddNewChild<KaxTag>(GetChild<KaxTags>(segment));
    auto& targets = GetChild<KaxTagTargets>(tag);
    if (target == Target::track) {
      GetChild<KaxTagTargetType>(targets).SetValue("TRACK");
      GetChild<KaxTagTrackUID>(targets).SetValue(target_uid);
    } else if (target == Target::attachment) {
      GetChild<KaxTagTargetType>(targets).SetValue("ATTACHMENT");
      GetChild<KaxTagAttachmentUID>(targets).SetValue(target_uid);
    }
    auto& simple = GetChild<KaxTagSimple>(tag);
    GetChild<KaxTagName>(simple).SetValueUTF8(name);
    GetChild<KaxTagString>(simple).SetValueUTF8(value);
  }

  static uint64_t uid_of(KaxTrackEntry& t) { return GetChild<KaxTrackUID>(t).GetValue(); }

  // EBML head, segment head, reserved space, tracks, attachments, tags: written at the first
  // capture, whose device time is the start offset.
  void write_header(int64_t start_offset_us) {
    add_tag("K4A_START_OFFSET_NS", std::to_string(start_offset_us * 1000));
    EbmlHead head;
    GetChild<EDocType>(head).SetValue("matroska");
    GetChild<EDocTypeVersion>(head).SetValue(2);
    GetChild<EDocTypeReadVersion>(head).SetValue(2);
    head.Render(*file, true);
    segment.WriteHead(*file, 8);  // 8-byte size, rewritten at close
    seek_void.SetSize(1024);
    seek_void.Render(*file);
    info_void.SetSize(256);
    info_void.Render(*file);
    GetChild<KaxTracks>(segment).Render(*file);
    GetChild<KaxAttachments>(segment).Render(*file);
    GetChild<KaxTags>(segment).Render(*file);
    header_written = true;
  }
};

K4aMkvWriter::K4aMkvWriter(const std::filesystem::path& path, const Intrinsics& depth,
                           K4aDepthMode mode, int64_t frame_us, bool with_color)
    : s_(std::make_unique<State>()) {
  State& s = *s_;
  s.path = path;
  s.width = depth.width;
  s.height = depth.height;
  s.fps = k4a_fps(frame_us);
  s.calibration_json = k4a_calibration_json(depth, mode);  // throws for a size not of `mode`
  s.file = std::make_unique<CheckedFile>(path);
  const auto w = static_cast<uint32_t>(s.width), h = static_cast<uint32_t>(s.height);
  auto& info = GetChild<KaxInfo>(s.segment);
  GetChild<KaxTimecodeScale>(info).SetValue(kTimestampScaleNs);
  GetChild<KaxMuxingApp>(info).SetValueUTF8("libmatroska-1.7.1");
  GetChild<KaxWritingApp>(info).SetValueUTF8("volcast export");
  GetChild<KaxDateUTC>(info).SetEpochDate(std::time(nullptr));
  GetChild<KaxTitle>(info).SetValueUTF8("Azure Kinect");

  s.depth_track = &s.add_track(1, "DEPTH", bitmap_info_header(w, h, 16, "b16g", w * h * 2));
  const uint64_t depth_uid = State::uid_of(*s.depth_track);
  s.add_tag("K4A_DEPTH_TRACK", std::to_string(depth_uid), State::Target::track, depth_uid);
  s.add_tag("K4A_DEPTH_MODE", k4a_depth_mode_name(mode), State::Target::track, depth_uid);
  if (with_color) {
    s.color_track = &s.add_track(2, "COLOR_ON_DEPTH", bitmap_info_header(w, h, 24, "MJPG", 0));
    const uint64_t color_uid = State::uid_of(*s.color_track);
    s.add_tag("K4A_CUSTOM_TRACK_COLOR_ON_DEPTH", std::to_string(color_uid), State::Target::track,
              color_uid);
  }
  s.add_tag("K4A_WIRED_SYNC_MODE", "STANDALONE");

  auto& attached = AddNewChild<KaxAttached>(GetChild<KaxAttachments>(s.segment));
  GetChild<KaxFileName>(attached).SetValueUTF8("calibration.json");
  GetChild<KaxMimeType>(attached).SetValue("application/octet-stream");
  GetChild<KaxFileData>(attached).CopyBuffer(
      reinterpret_cast<const binary*>(s.calibration_json.data()),
      static_cast<uint32>(s.calibration_json.size()));
  const uint64_t file_uid = s.uid();
  GetChild<KaxFileUID>(attached).SetValue(file_uid);
  s.add_tag("K4A_CALIBRATION_FILE", "calibration.json", State::Target::attachment, file_uid);
}

K4aMkvWriter::~K4aMkvWriter() = default;

void K4aMkvWriter::write(const CameraFrame& frame) {
  State& s = *s_;
  if (s.closed) s.fail("written after close");
  if (s.first_device_us >= 0 && frame.device_timestamp_us == s.last_device_us) return;
  if (frame.depth.width != s.width || frame.depth.height != s.height)
    s.fail("a depth frame of " + std::to_string(frame.depth.width) + "x" +
           std::to_string(frame.depth.height) + " in a " + std::to_string(s.width) + "x" +
           std::to_string(s.height) + " track");
  try {
    if (!s.header_written) {
      s.first_device_us = frame.device_timestamp_us;
      s.write_header(s.first_device_us);
    }
    s.last_device_us = frame.device_timestamp_us;
    const int64_t t = std::max(frame.device_timestamp_us - s.first_device_us, s.last_us + 1);
    s.last_us = t;
    const size_t n = frame.depth.pixels.size();
    s.depth_bytes.resize(n * 2);
    for (size_t i = 0; i < n; ++i) {  // b16g: big-endian
      s.depth_bytes[2 * i] = static_cast<uint8_t>(frame.depth.pixels[i] >> 8);
      s.depth_bytes[2 * i + 1] = static_cast<uint8_t>(frame.depth.pixels[i] & 0xff);
    }
    const bool color = s.color_track && !frame.color.empty();
    if (color) encode_jpeg(frame.color, 95, s.jpeg);

    KaxCluster cluster;  // owns its blocks, which own their DataBuffers (not the bytes)
    cluster.SetParent(s.segment);
    cluster.InitTimecode(static_cast<uint64>(t), kTimestampScaleNs);
    const uint64 t_ns = static_cast<uint64>(t) * kTimestampScaleNs;
    const auto add = [&](KaxTrackEntry& track, std::vector<uint8_t>& bytes) {
      auto* block = new KaxSimpleBlock;
      cluster.PushElement(*block);
      block->SetParent(cluster);
      block->SetKeyframe(true);
      block->AddFrame(track, t_ns, *new DataBuffer(bytes.data(), static_cast<uint32>(bytes.size())),
                      LACING_NONE);
    };
    add(*s.depth_track, s.depth_bytes);
    if (color) add(*s.color_track, s.jpeg);
    auto& cues = GetChild<KaxCues>(s.segment);
    cluster.Render(*s.file, cues);
    auto& point = AddNewChild<KaxCuePoint>(cues);
    GetChild<KaxCueTime>(point).SetValue(static_cast<uint64>(t));
    auto& position = GetChild<KaxCueTrackPositions>(point);
    GetChild<KaxCueTrack>(position).SetValue(1);
    GetChild<KaxCueClusterPosition>(position).SetValue(s.segment.GetRelativePosition(cluster));
  } catch (const std::ios_base::failure& e) {
    s.fail(std::string("cannot write a capture: ") + e.what());
  }
}

void K4aMkvWriter::close() {
  State& s = *s_;
  if (s.closed) return;
  s.closed = true;
  try {
    if (!s.header_written) s.write_header(0);
    auto& cues = GetChild<KaxCues>(s.segment);
    if (cues.ListSize() > 0) cues.Render(*s.file);
    auto& info = GetChild<KaxInfo>(s.segment);
    const double frame_us = 1e6 / static_cast<double>(s.fps);
    GetChild<KaxDuration>(info).SetValue(s.last_us >= 0 ? static_cast<double>(s.last_us) + frame_us
                                                        : 0.0);
    const uint64 end = s.file->getFilePointer();
    s.info_void.ReplaceWith(info, *s.file, true);
    KaxSeekHead seek;
    seek.IndexThis(info, s.segment);
    seek.IndexThis(GetChild<KaxTracks>(s.segment), s.segment);
    seek.IndexThis(GetChild<KaxAttachments>(s.segment), s.segment);
    seek.IndexThis(GetChild<KaxTags>(s.segment), s.segment);
    if (cues.ListSize() > 0) seek.IndexThis(cues, s.segment);
    s.seek_void.ReplaceWith(seek, *s.file, true);
    s.segment.ForceSize(end - s.segment.GetElementPosition() - s.segment.HeadSize());
    s.segment.OverwriteHead(*s.file);
    s.file->close();
  } catch (const std::ios_base::failure& e) {
    s.fail(std::string("cannot finish: ") + e.what());
  }
}

}  // namespace volcast
