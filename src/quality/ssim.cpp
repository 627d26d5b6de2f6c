// SSIM through FFmpeg's ssim filter (libavfilter), for view_quality.hpp's score.
#include <cstdint>  // INT64_C for libavutil in C++

extern "C" {
#include <libavfilter/avfilter.h>
#include <libavfilter/buffersink.h>
#include <libavfilter/buffersrc.h>
#include <libavutil/dict.h>
#include <libavutil/frame.h>
#include <libavutil/log.h>
#include <libavutil/pixfmt.h>
}

#include <fmt/format.h>

#include <cstdlib>
#include <memory>

#include "volcast/core/error.hpp"
#include "volcast/quality/view_quality.hpp"

namespace volcast {
namespace {

struct GraphDeleter {
  void operator()(AVFilterGraph* g) const { avfilter_graph_free(&g); }
};
struct FrameDeleter {
  void operator()(AVFrame* f) const { av_frame_free(&f); }
};
using Frame = std::unique_ptr<AVFrame, FrameDeleter>;

void check(int rc, const char* step) {
  if (rc < 0) {
    char text[AV_ERROR_MAX_STRING_SIZE] = {};
    av_strerror(rc, text, sizeof text);
    throw Error(fmt::format("ssim (libavfilter): {} failed: {}", step, text));
  }
}

// The BT.601 luma of a BGRA image as a GRAY8 frame.
Frame luma_frame(const ColorImage& image) {
  Frame f(av_frame_alloc());
  if (!f) throw Error("ssim (libavfilter): out of memory for a frame");
  f->format = AV_PIX_FMT_GRAY8;
  f->width = image.width;
  f->height = image.height;
  check(av_frame_get_buffer(f.get(), 0), "allocating a frame");
  for (int y = 0; y < image.height; ++y) {
    uint8_t* row = f->data[0] + static_cast<std::ptrdiff_t>(y) * f->linesize[0];
    for (int x = 0; x < image.width; ++x) {
      const uint8_t* p = image.pixel(x, y);
      row[x] = static_cast<uint8_t>((29 * p[0] + 150 * p[1] + 77 * p[2] + 128) >> 8);
    }
  }
  f->pts = 0;
  return f;
}

}  // namespace

double ssim_luma(const ColorImage& a, const ColorImage& b) {
  if (a.width != b.width || a.height != b.height || a.empty())
    throw Error(fmt::format("ssim: the images are {}x{} and {}x{} (one non-empty size needed)",
                            a.width, a.height, b.width, b.height));
  av_log_set_level(AV_LOG_ERROR);  // the filter logs each frame's SSIM at info
  std::unique_ptr<AVFilterGraph, GraphDeleter> graph(avfilter_graph_alloc());
  if (!graph) throw Error("ssim (libavfilter): out of memory for a filter graph");
  const std::string args =
      fmt::format("video_size={}x{}:pix_fmt={}:time_base=1/30:pixel_aspect=1/1", a.width, a.height,
                  static_cast<int>(AV_PIX_FMT_GRAY8));
  AVFilterContext *main_in = nullptr, *ref_in = nullptr, *ssim = nullptr, *out = nullptr;
  const AVFilter* buffer = avfilter_get_by_name("buffer");
  check(avfilter_graph_create_filter(&main_in, buffer, "main", args.c_str(), nullptr, graph.get()),
        "making the first input");
  check(avfilter_graph_create_filter(&ref_in, buffer, "reference", args.c_str(), nullptr,
                                     graph.get()),
        "making the second input");
  check(avfilter_graph_create_filter(&ssim, avfilter_get_by_name("ssim"), "ssim", nullptr, nullptr,
                                     graph.get()),
        "making the ssim filter");
  check(avfilter_graph_create_filter(&out, avfilter_get_by_name("buffersink"), "out", nullptr,
                                     nullptr, graph.get()),
        "making the sink");
  check(avfilter_link(main_in, 0, ssim, 0), "linking the first input");
  check(avfilter_link(ref_in, 0, ssim, 1), "linking the second input");
  check(avfilter_link(ssim, 0, out, 0), "linking the sink");
  check(avfilter_graph_config(graph.get(), nullptr), "configuring the graph");
  Frame fa = luma_frame(a), fb = luma_frame(b);
  check(av_buffersrc_add_frame(main_in, fa.get()), "sending the first image");
  check(av_buffersrc_add_frame(ref_in, fb.get()), "sending the second image");
  check(av_buffersrc_add_frame(main_in, nullptr), "ending the first input");
  check(av_buffersrc_add_frame(ref_in, nullptr), "ending the second input");
  Frame result(av_frame_alloc());
  if (!result) throw Error("ssim (libavfilter): out of memory for a frame");
  check(av_buffersink_get_frame(out, result.get()), "taking the result");
  const AVDictionaryEntry* all = av_dict_get(result->metadata, "lavfi.ssim.All", nullptr, 0);
  if (!all) throw Error("ssim (libavfilter): the filter gave no lavfi.ssim.All");
  return std::strtod(all->value, nullptr);
}

}  // namespace volcast
