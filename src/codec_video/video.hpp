#pragma once
// Internal: one video stream through libavcodec (FFmpeg), for the lossy depth codecs and H.264
// color (video_codecs.cpp). Low-latency settings throughout: x264/x265 preset ultrafast, tune
// zerolatency, no B-frames, one thread, so every frame comes out as one packet at once and the
// decoder returns it without delay; key frames only on request.
#include <cstdint>
#include <span>
#include <string>
#include <vector>

extern "C" {
#include <libavcodec/avcodec.h>
}

namespace volcast::detail {

/// Encoder of one stream. `encoder`: an FFmpeg encoder name (libx264, libx265); `label`: for
/// errors; `crf`: the constant rate factor (lower = better).
class VideoEncoder {
 public:
  VideoEncoder(const char* encoder, const char* label, AVPixelFormat format, int crf);
  ~VideoEncoder();
  VideoEncoder(const VideoEncoder&) = delete;
  VideoEncoder& operator=(const VideoEncoder&) = delete;

  /// The frame to fill next, w x h in the stream's pixel format; (re)opens the encoder when the
  /// size changes (the next frame is then a key frame). Throws Error if FFmpeg lacks the encoder.
  AVFrame* frame(int w, int h);
  /// Constant rate factor (0..51) from the next (re)open on.
  void set_crf(int crf) { crf_ = crf; }
  /// Encodes the filled frame and appends its packet to `out`; returns true for a key frame.
  bool encode(bool key_frame, std::vector<uint8_t>& out);

 private:
  void close();
  const char* encoder_;
  const char* label_;
  AVPixelFormat format_;
  int crf_;
  AVCodecContext* ctx_ = nullptr;
  AVFrame* frame_ = nullptr;
  AVPacket* packet_ = nullptr;
  int64_t pts_ = 0;
};

/// Decoder of one stream (codec: AV_CODEC_ID_H264 or AV_CODEC_ID_HEVC).
class VideoDecoder {
 public:
  VideoDecoder(AVCodecID codec, const char* label);
  ~VideoDecoder();
  VideoDecoder(const VideoDecoder&) = delete;
  VideoDecoder& operator=(const VideoDecoder&) = delete;

  /// Decodes one packet (one frame). Throws Error naming the problem for a delta frame without
  /// its key frame, a corrupt packet, or one that yields no picture. The frame stays valid until
  /// the next call.
  const AVFrame* decode(std::span<const uint8_t> packet, bool key_frame);

 private:
  void open();
  AVCodecID codec_;
  const char* label_;
  AVCodecContext* ctx_ = nullptr;
  AVFrame* frame_ = nullptr;
  AVPacket* packet_ = nullptr;
  std::vector<uint8_t> padded_;
  bool have_key_ = false;
};

}  // namespace volcast::detail
