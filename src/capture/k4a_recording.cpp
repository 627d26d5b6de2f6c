#include "volcast/capture/k4a_recording.hpp"

extern "C" {
#include <libavformat/avformat.h>
#include <libavutil/avutil.h>
#include <libavutil/error.h>
}

#include <spdlog/spdlog.h>

#include <algorithm>
#include <climits>
#include <cmath>
#include <cstdlib>
#include <optional>
#include <span>

#include "volcast/capture/registration.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/jpeg.hpp"

namespace volcast {
namespace {

std::string av_error(int code) {
  char buf[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(code, buf, sizeof buf);
  return buf;
}

std::string tag(AVDictionary* dict, const char* key) {
  const AVDictionaryEntry* e = av_dict_get(dict, key, nullptr, 0);
  return e ? e->value : "";
}

struct FormatCloser {
  void operator()(AVFormatContext* f) const { avformat_close_input(&f); }
};
struct PacketFreer {
  void operator()(AVPacket* p) const { av_packet_free(&p); }
};

// An opened recording with its tracks identified.
struct Demuxer {
  std::unique_ptr<AVFormatContext, FormatCloser> fmt;
  int depth = -1, color = -1;
  /// The color track is a COLOR_ON_DEPTH custom track (volcast export): JPEG already registered
  /// to depth, at depth size; used only where there is no COLOR track.
  bool color_on_depth = false;
  std::string calibration_json;
  std::string path;

  explicit Demuxer(const std::filesystem::path& p) : path(p.string()) {
    if (!std::filesystem::exists(p)) throw Error("recording '" + path + "' does not exist");
    av_log_set_level(AV_LOG_FATAL);
    AVFormatContext* raw = nullptr;
    if (int rc = avformat_open_input(&raw, path.c_str(), nullptr, nullptr); rc < 0)
      throw Error("cannot open recording '" + path + "': " + av_error(rc) +
                  " (not a readable Matroska file?)");
    fmt.reset(raw);
    if (std::string(fmt->iformat->name).find("matroska") == std::string::npos)
      throw Error("'" + path + "' is not a Matroska (.mkv) recording");
    int on_depth = -1;
    for (unsigned i = 0; i < fmt->nb_streams; ++i) {
      AVStream* st = fmt->streams[i];
      const std::string title = tag(st->metadata, "title");
      if (st->codecpar->codec_type == AVMEDIA_TYPE_ATTACHMENT) {
        if (tag(st->metadata, "filename") == "calibration.json" && st->codecpar->extradata)
          calibration_json.assign(reinterpret_cast<const char*>(st->codecpar->extradata),
                                  static_cast<size_t>(st->codecpar->extradata_size));
      } else if (title == "DEPTH") {
        depth = static_cast<int>(i);
      } else if (title == "COLOR") {
        color = static_cast<int>(i);
      } else if (title == "COLOR_ON_DEPTH") {
        on_depth = static_cast<int>(i);
      }
    }
    // k4arecorder writes block times after the first capture's device time, kept in this tag.
    const std::string offset = tag(fmt->metadata, "K4A_START_OFFSET_NS");
    if (!offset.empty()) {
      char* end = nullptr;
      const long long ns = std::strtoll(offset.c_str(), &end, 10);
      if (end != offset.c_str() + offset.size() || ns < 0 || ns > INT64_MAX / 2)
        throw Error("recording '" + path + "': K4A_START_OFFSET_NS is not a time: " + offset);
      start_offset_us = ns / 1000;
    }
    if (color < 0 && on_depth >= 0) {
      color = on_depth;
      color_on_depth = true;
    }
    if (depth < 0) throw Error("recording '" + path + "' has no DEPTH track");
    const AVCodecParameters* d = fmt->streams[depth]->codecpar;
    if (d->codec_tag != MKTAG('b', '1', '6', 'g'))
      throw Error("recording '" + path + "': DEPTH track is not fourcc b16g");
    if (d->width <= 0 || d->height <= 0 || d->width > 4096 || d->height > 4096)
      throw Error("recording '" + path + "': DEPTH track has an implausible size");
    if (calibration_json.empty())
      throw Error("recording '" + path + "' has no calibration.json attachment");
    for (unsigned i = 0; i < fmt->nb_streams; ++i)
      if (static_cast<int>(i) != depth && static_cast<int>(i) != color)
        fmt->streams[i]->discard = AVDISCARD_ALL;
  }

  AVStream* stream(int i) const { return fmt->streams[i]; }
  /// The packet's device time: its block time plus K4A_START_OFFSET_NS, as the SDK's playback
  /// reports it.
  int64_t to_us(const AVPacket& p) const {
    const int64_t ts = p.pts != AV_NOPTS_VALUE ? p.pts : p.dts;
    return av_rescale_q(ts, stream(p.stream_index)->time_base, AVRational{1, 1000000}) +
           start_offset_us;
  }
  int64_t start_offset_us = 0;
};

std::string depth_mode_name(const Demuxer& dm) {
  std::string mode = tag(dm.stream(dm.depth)->metadata, "K4A_DEPTH_MODE");
  if (!mode.empty()) return mode;
  const AVCodecParameters* d = dm.stream(dm.depth)->codecpar;
  if (const auto m = k4a_depth_mode_of_size(d->width, d->height)) return k4a_depth_mode_name(*m);
  throw Error("recording '" + dm.path + "': cannot tell the depth mode");
}

// The recording's rate: k4arecorder writes each track's frame duration (5, 15 or 30 fps); 30 if
// the file does not say.
double recorded_fps(const Demuxer& dm) {
  const AVStream* st = dm.stream(dm.depth);
  const AVRational rate = st->avg_frame_rate.num > 0 ? st->avg_frame_rate : st->r_frame_rate;
  const double fps = rate.num > 0 && rate.den > 0 ? av_q2d(rate) : 0.0;
  return fps >= 1 && fps <= 120 ? fps : 30.0;
}

using Packet = std::unique_ptr<AVPacket, PacketFreer>;

// The bytes of a packet (none for no packet). The packet owns a reference to its buffer, so they
// stay valid for as long as the packet lives, whatever the demuxer reads next.
std::span<const uint8_t> bytes_of(const Packet& p) {
  if (!p || !p->data) return {};
  return {p->data, static_cast<size_t>(p->size)};
}

// A raw capture: one depth packet and the color packet taken at the same moment, if any. The
// packets are the demuxer's, moved out rather than copied.
struct RawCapture {
  Packet depth;
  Packet color;
  int64_t timestamp_us = 0;
  std::span<const uint8_t> depth_bytes() const { return bytes_of(depth); }
  std::span<const uint8_t> color_bytes() const { return bytes_of(color); }
};

// Pairs depth and color packets by timestamp. k4arecorder writes the packets of a capture next
// to each other; a color packet within half a frame period of a depth packet belongs to it.
class CaptureReader {
 public:
  explicit CaptureReader(const std::filesystem::path& path)
      : dm_(path), packet_(av_packet_alloc()) {}
  Demuxer& demuxer() { return dm_; }

  // Next capture, or nullopt at the end of the file.
  std::optional<RawCapture> next() {
    constexpr int64_t kTolerance = 16'000;  // half a frame at 30 fps, microseconds
    while (true) {
      const int rc = av_read_frame(dm_.fmt.get(), packet_.get());
      if (rc == AVERROR_EOF) return take_pending();
      if (rc < 0)
        throw Error("recording '" + dm_.path + "' is corrupt or truncated: " + av_error(rc));
      const int64_t ts = dm_.to_us(*packet_);
      const int index = packet_->stream_index;
      if (index != dm_.depth && index != dm_.color) {
        av_packet_unref(packet_.get());
        continue;
      }
      Packet bytes = take_packet();
      if (index == dm_.depth) {
        std::optional<RawCapture> done = take_pending();
        pending_ = RawCapture{std::move(bytes), nullptr, ts};
        if (last_color_ && std::llabs(last_color_ts_ - ts) <= kTolerance) {
          pending_->color = std::move(last_color_);
        }
        if (done) return done;
      } else {
        if (pending_ && pending_->color_bytes().empty() &&
            std::llabs(ts - pending_->timestamp_us) <= kTolerance) {
          pending_->color = std::move(bytes);
          return take_pending();
        }
        last_color_ = std::move(bytes);
        last_color_ts_ = ts;
        if (pending_ && ts > pending_->timestamp_us + kTolerance) return take_pending();
      }
    }
  }

 private:
  std::optional<RawCapture> take_pending() {
    std::optional<RawCapture> out = std::move(pending_);
    pending_.reset();
    return out;
  }
  // The packet just read, moved out of packet_ (no copy of its data) into one of its own. The
  // demuxer's packets are reference-counted; one that is not is made so (a copy, then only).
  Packet take_packet() {
    if (!packet_->buf && av_packet_make_refcounted(packet_.get()) < 0)
      throw Error("recording '" + dm_.path + "': out of memory");
    Packet p(av_packet_alloc());
    if (!p) throw Error("recording '" + dm_.path + "': out of memory");
    av_packet_move_ref(p.get(), packet_.get());
    return p;
  }
  Demuxer dm_;
  Packet packet_;
  std::optional<RawCapture> pending_;
  Packet last_color_;  // a color packet not yet paired with a depth packet, or null
  int64_t last_color_ts_ = 0;
};

class K4aRecordingSource final : public FrameSource {
 public:
  K4aRecordingSource(const std::filesystem::path& path, const SourceOptions& options)
      : path_(path), reader_(std::make_unique<CaptureReader>(path)) {
    Demuxer& dm = reader_->demuxer();
    const K4aCalibration cal = parse_k4a_calibration(dm.calibration_json);
    calibration_.depth =
        k4a_depth_mode_intrinsics(cal.depth, parse_k4a_depth_mode(depth_mode_name(dm)));
    calibration_.world_from_camera = options.world_from_camera.value_or(RigidTransform::identity());
    const AVCodecParameters* d = dm.stream(dm.depth)->codecpar;
    if (d->width != calibration_.depth.width || d->height != calibration_.depth.height)
      throw Error("recording '" + dm.path + "': DEPTH track size does not match its depth mode");
    if (dm.color >= 0 && dm.color_on_depth) {
      const AVCodecParameters* c = dm.stream(dm.color)->codecpar;
      if (c->codec_id != AV_CODEC_ID_MJPEG || c->width != d->width || c->height != d->height)
        spdlog::warn("{}: COLOR_ON_DEPTH track is not MJPG of the depth size; streaming depth only",
                     dm.path);
      else
        color_is_jpeg_ = color_on_depth_ = true;
    } else if (dm.color >= 0) {
      const AVCodecParameters* c = dm.stream(dm.color)->codecpar;
      color_is_jpeg_ = c->codec_id == AV_CODEC_ID_MJPEG;
      color_is_bgra_ = c->codec_id == AV_CODEC_ID_RAWVIDEO && c->format == AV_PIX_FMT_BGRA;
      if (!color_is_jpeg_ && !color_is_bgra_) {
        spdlog::warn("{}: color format {} not supported (MJPG and BGRA are); streaming depth only",
                     dm.path, avcodec_get_name(c->codec_id));
      } else {
        color_intrinsics_ = k4a_color_mode_intrinsics(cal.color, c->width, c->height);
        registration_.emplace(calibration_.depth, color_intrinsics_, cal.color.camera_from_depth);
      }
    }
    if (options.fps && !(std::isfinite(*options.fps) && *options.fps > 0 && *options.fps <= 1000))
      throw Error("recording '" + dm.path + "': fps must be a number in (0, 1000], got " +
                  std::to_string(*options.fps));
    fps_ = options.fps.value_or(recorded_fps(dm));
    // Count the frames of one pass (and those with color) and check that the first decodes.
    CaptureReader counter(path);
    while (auto cap = counter.next()) {
      if (frame_count_ == 0) decode(*cap, first_);
      ++frame_count_;
      color_frame_count_ += (registration_ || color_on_depth_) && !cap->color_bytes().empty();
    }
    if (frame_count_ == 0) throw Error("recording '" + dm.path + "' holds no depth frames");
  }

  const CameraCalibration& calibration() const override { return calibration_; }
  double fps() const override { return fps_; }
  int frame_count() const override { return frame_count_; }
  int color_frame_count() const override { return color_frame_count_; }
  std::string description() const override { return "Azure Kinect recording " + path_.string(); }

  void next(CameraFrame& out) override {
    if (frame_count_ == 1) {  // a single capture: decode once, replay it
      out = first_;           // copy assignment keeps a recycled frame's capacity
      out.device_timestamp_us += loops_++ * static_cast<int64_t>(1e6 / fps_);
      return;
    }
    std::optional<RawCapture> cap = reader_->next();
    if (!cap) {
      reader_ = std::make_unique<CaptureReader>(path_);
      ++loops_;
      loop_offset_us_ = last_timestamp_us_ + static_cast<int64_t>(1e6 / fps_);
      cap = reader_->next();
      if (!cap) throw Error("recording '" + path_.string() + "' holds no depth frames");
    }
    decode(*cap, out);
    out.device_timestamp_us += loop_offset_us_;
    last_timestamp_us_ = out.device_timestamp_us;
  }

 private:
  void decode(const RawCapture& cap, CameraFrame& out) {
    const Intrinsics& k = calibration_.depth;
    const size_t n = static_cast<size_t>(k.width) * k.height;
    const std::span<const uint8_t> depth = cap.depth_bytes(), color = cap.color_bytes();
    if (depth.size() != n * 2)
      throw Error("recording '" + path_.string() + "': depth frame at " +
                  std::to_string(cap.timestamp_us) + " us has " + std::to_string(depth.size()) +
                  " bytes, expected " + std::to_string(n * 2) + " (truncated?)");
    out.depth.width = k.width;  // a recycled frame's buffer is reused
    out.depth.height = k.height;
    out.depth.pixels.resize(n);
    for (size_t i = 0; i < n; ++i)  // b16g: big-endian
      out.depth.pixels[i] = static_cast<uint16_t>((depth[2 * i] << 8) | depth[2 * i + 1]);
    out.device_timestamp_us = cap.timestamp_us;
    if ((!registration_ && !color_on_depth_) || color.empty()) {  // none we read, or none now
      out.color = ColorImage();
      return;
    }
    if (color_on_depth_) {  // already registered to depth
      try {
        decode_jpeg(color, out.color);
      } catch (const Error& e) {
        throw Error("recording '" + path_.string() + "': color frame at " +
                    std::to_string(cap.timestamp_us) + " us: " + e.what());
      }
      if (out.color.width != k.width || out.color.height != k.height)
        throw Error("recording '" + path_.string() + "': color frame size differs from its track");
      return;
    }
    if (color_is_jpeg_) {
      try {
        decode_jpeg(color, color_scratch_);
      } catch (const Error& e) {
        throw Error("recording '" + path_.string() + "': color frame at " +
                    std::to_string(cap.timestamp_us) + " us: " + e.what());
      }
    } else {
      const size_t bytes =
          static_cast<size_t>(color_intrinsics_.width) * color_intrinsics_.height * 4;
      if (color.size() != bytes)
        throw Error("recording '" + path_.string() + "': truncated BGRA frame");
      color_scratch_ = ColorImage(color_intrinsics_.width, color_intrinsics_.height);
      std::copy(color.begin(), color.end(), color_scratch_.bgra.begin());
    }
    if (color_scratch_.width != color_intrinsics_.width ||
        color_scratch_.height != color_intrinsics_.height)
      throw Error("recording '" + path_.string() + "': color frame size differs from its track");
    registration_->apply(out.depth, color_scratch_, out.color);  // sizes out.color
  }

  std::filesystem::path path_;
  std::unique_ptr<CaptureReader> reader_;
  CameraCalibration calibration_;
  Intrinsics color_intrinsics_;
  std::optional<ColorToDepthRegistration> registration_;
  bool color_is_jpeg_ = false, color_is_bgra_ = false, color_on_depth_ = false;
  double fps_ = 30;
  int frame_count_ = 0, color_frame_count_ = 0;
  int64_t loops_ = 0, loop_offset_us_ = 0, last_timestamp_us_ = 0;
  CameraFrame first_;
  ColorImage color_scratch_;
};

}  // namespace

K4aRecordingInfo probe_k4a_recording(const std::filesystem::path& path) {
  CaptureReader reader(path);
  Demuxer& dm = reader.demuxer();
  K4aRecordingInfo info;
  for (unsigned i = 0; i < dm.fmt->nb_streams; ++i) {
    const AVStream* st = dm.fmt->streams[i];
    K4aRecordingInfo::Stream s;
    s.index = static_cast<int>(i);
    s.title = tag(st->metadata,
                  st->codecpar->codec_type == AVMEDIA_TYPE_ATTACHMENT ? "filename" : "title");
    const uint32_t fourcc = st->codecpar->codec_tag;
    if (st->codecpar->codec_id == AV_CODEC_ID_RAWVIDEO && fourcc != 0) {
      for (int b = 0; b < 4; ++b) s.codec += static_cast<char>((fourcc >> (8 * b)) & 0xff);
    } else if (st->codecpar->codec_type == AVMEDIA_TYPE_ATTACHMENT) {
      s.codec = "attachment";
    } else {
      s.codec = avcodec_get_name(st->codecpar->codec_id);
    }
    s.width = st->codecpar->width;
    s.height = st->codecpar->height;
    info.streams.push_back(s);
  }
  if (dm.fmt->duration != AV_NOPTS_VALUE)
    info.duration_s = static_cast<double>(dm.fmt->duration) / AV_TIME_BASE;
  info.depth_mode = depth_mode_name(dm);
  info.fps = recorded_fps(dm);
  const K4aCalibration cal = parse_k4a_calibration(dm.calibration_json);
  info.depth_intrinsics =
      k4a_depth_mode_intrinsics(cal.depth, parse_k4a_depth_mode(info.depth_mode));
  info.color_from_depth = cal.color.camera_from_depth;
  if (dm.color >= 0 && dm.color_on_depth) {
    info.color_mode = "COLOR_ON_DEPTH";
    info.color_intrinsics = info.depth_intrinsics;
    info.color_from_depth = RigidTransform::identity();
  } else if (dm.color >= 0) {
    const AVCodecParameters* c = dm.stream(dm.color)->codecpar;
    info.color_mode = tag(dm.stream(dm.color)->metadata, "K4A_COLOR_MODE");
    info.color_intrinsics = k4a_color_mode_intrinsics(cal.color, c->width, c->height);
  }
  while (auto cap = reader.next()) {  // a frame of the wrong size counts: check_frames names it
    ++info.depth_frames;
    if (!cap->color_bytes().empty()) ++info.color_frames;
  }
  if (info.depth_frames == 0)
    throw Error("recording '" + path.string() + "' holds no depth frames");
  return info;
}

std::unique_ptr<FrameSource> open_k4a_recording(const std::filesystem::path& path,
                                                const SourceOptions& options) {
  return std::make_unique<K4aRecordingSource>(path, options);
}

}  // namespace volcast
