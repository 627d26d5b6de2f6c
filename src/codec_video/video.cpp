#include "video.hpp"

#include <algorithm>
#include <cstring>

#include "volcast/core/error.hpp"

extern "C" {
#include <libavutil/error.h>
#include <libavutil/log.h>
#include <libavutil/opt.h>
#include <libavutil/pixdesc.h>
}

namespace volcast::detail {
namespace {

std::string av_message(int code) {
  char buf[AV_ERROR_MAX_STRING_SIZE] = {};
  av_strerror(code, buf, sizeof buf);
  return buf;
}

void quiet_ffmpeg() {
  static const bool once = [] {
    av_log_set_level(AV_LOG_FATAL);
    return true;
  }();
  (void)once;
}

}  // namespace

VideoEncoder::VideoEncoder(const char* encoder, const char* label, AVPixelFormat format, int crf)
    : encoder_(encoder), label_(label), format_(format), crf_(crf) {
  quiet_ffmpeg();
  packet_ = av_packet_alloc();
  if (!packet_) throw Error(std::string(label_) + ": out of memory");
}

VideoEncoder::~VideoEncoder() {
  close();
  av_packet_free(&packet_);
}

void VideoEncoder::close() {
  av_frame_free(&frame_);
  avcodec_free_context(&ctx_);
}

AVFrame* VideoEncoder::frame(int w, int h) {
  if (!ctx_ || ctx_->width != w || ctx_->height != h) {
    close();
    const AVCodec* codec = avcodec_find_encoder_by_name(encoder_);
    if (!codec)
      throw Error(std::string(label_) + ": this FFmpeg build has no " + encoder_ + " encoder");
    ctx_ = avcodec_alloc_context3(codec);
    if (!ctx_) throw Error(std::string(label_) + ": out of memory");
    ctx_->width = w;
    ctx_->height = h;
    ctx_->pix_fmt = format_;
    ctx_->time_base = {1, 30};
    ctx_->framerate = {30, 1};
    ctx_->gop_size = 600;  // key frames come on request (the server's key-frame interval)
    ctx_->max_b_frames = 0;
    ctx_->thread_count = 1;
    av_opt_set(ctx_->priv_data, "preset", "ultrafast", 0);
    av_opt_set(ctx_->priv_data, "tune", "zerolatency", 0);
    av_opt_set_double(ctx_->priv_data, "crf", crf_, 0);
    av_opt_set(ctx_->priv_data, "forced-idr", "1", 0);  // a requested key frame is an IDR
    if (std::strcmp(encoder_, "libx265") == 0)
      av_opt_set(ctx_->priv_data, "x265-params", "log-level=error:bframes=0:pools=none", 0);
    if (const int rc = avcodec_open2(ctx_, codec, nullptr); rc < 0) {
      close();
      throw Error(std::string(label_) + ": cannot open " + encoder_ + " for " + std::to_string(w) +
                  "x" + std::to_string(h) + " " + av_get_pix_fmt_name(format_) + ": " +
                  av_message(rc));
    }
    frame_ = av_frame_alloc();
    if (!frame_) throw Error(std::string(label_) + ": out of memory");
    frame_->format = format_;
    frame_->width = w;
    frame_->height = h;
    if (av_frame_get_buffer(frame_, 0) < 0) throw Error(std::string(label_) + ": out of memory");
    pts_ = 0;
  }
  if (av_frame_make_writable(frame_) < 0) throw Error(std::string(label_) + ": out of memory");
  return frame_;
}

bool VideoEncoder::encode(bool key_frame, std::vector<uint8_t>& out) {
  frame_->pts = pts_++;
  frame_->pict_type = key_frame || frame_->pts == 0 ? AV_PICTURE_TYPE_I : AV_PICTURE_TYPE_NONE;
  if (const int rc = avcodec_send_frame(ctx_, frame_); rc < 0)
    throw Error(std::string(label_) + ": encoding failed: " + av_message(rc));
  bool key = false, got = false;
  while (avcodec_receive_packet(ctx_, packet_) == 0) {
    out.insert(out.end(), packet_->data, packet_->data + packet_->size);
    key = key || (packet_->flags & AV_PKT_FLAG_KEY);
    got = true;
    av_packet_unref(packet_);
  }
  if (!got) throw Error(std::string(label_) + ": the encoder held a frame back (latency)");
  return key;
}

VideoDecoder::VideoDecoder(AVCodecID codec, const char* label) : codec_(codec), label_(label) {
  quiet_ffmpeg();
  packet_ = av_packet_alloc();
  frame_ = av_frame_alloc();
  if (!packet_ || !frame_) throw Error(std::string(label_) + ": out of memory");
}

VideoDecoder::~VideoDecoder() {
  avcodec_free_context(&ctx_);
  av_frame_free(&frame_);
  av_packet_free(&packet_);
}

void VideoDecoder::open() {
  avcodec_free_context(&ctx_);
  const AVCodec* codec = avcodec_find_decoder(codec_);
  if (!codec) throw Error(std::string(label_) + ": this FFmpeg build has no decoder for it");
  ctx_ = avcodec_alloc_context3(codec);
  if (!ctx_) throw Error(std::string(label_) + ": out of memory");
  ctx_->thread_count = 1;  // frame threads would delay every picture by a frame per thread
  ctx_->flags |= AV_CODEC_FLAG_LOW_DELAY;
  if (const int rc = avcodec_open2(ctx_, codec, nullptr); rc < 0)
    throw Error(std::string(label_) + ": cannot open the decoder: " + av_message(rc));
}

const AVFrame* VideoDecoder::decode(std::span<const uint8_t> packet, bool key_frame) {
  if (key_frame) {
    open();  // a key frame starts a fresh decoder: no state survives a corrupt frame
    have_key_ = true;
  }
  if (!have_key_) throw Error(std::string(label_) + ": delta frame without its key frame");
  if (packet.empty()) throw Error(std::string(label_) + ": empty packet");
  // FFmpeg reads up to AV_INPUT_BUFFER_PADDING_SIZE bytes past a packet; they must be zero.
  padded_.assign(packet.begin(), packet.end());
  padded_.resize(packet.size() + AV_INPUT_BUFFER_PADDING_SIZE, 0);
  packet_->data = padded_.data();
  packet_->size = static_cast<int>(packet.size());
  const int sent = avcodec_send_packet(ctx_, packet_);
  int rc = sent;
  if (sent >= 0) rc = avcodec_receive_frame(ctx_, frame_);
  if (rc < 0) {
    have_key_ = false;  // resynchronise at the next key frame
    throw Error(std::string(label_) + ": corrupt packet (" +
                (rc == AVERROR(EAGAIN) ? std::string("no picture in it") : av_message(rc)) + ")");
  }
  if (frame_->decode_error_flags || (frame_->flags & AV_FRAME_FLAG_CORRUPT)) {
    have_key_ = false;
    throw Error(std::string(label_) + ": corrupt packet (decoding errors)");
  }
  return frame_;
}

}  // namespace volcast::detail
