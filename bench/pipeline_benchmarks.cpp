// Per-frame costs of the streaming pipeline on real frames, one thread:
//   build/release/bench/volcast_benchmarks
#include <benchmark/benchmark.h>

#include <filesystem>

#include "bench_data.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/filter/chain.hpp"
#include "volcast/reconstruct/point_cloud.hpp"

namespace volcast {
namespace {

const std::filesystem::path kData = bench::data_dir();

const CameraFrame& kinect_frame() {
  static const CameraFrame f = open_source(kData / "k4a-recording" / "recording.mkv")->next();
  return f;
}

void BM_DepthEncode(benchmark::State& state, const char* codec) {
  const CameraFrame& f = kinect_frame();
  auto enc = make_depth_encoder(codec);
  std::vector<uint8_t> out;
  for (auto _ : state) {
    enc->encode(f.depth, true, out);
    benchmark::DoNotOptimize(out.data());
  }
  state.counters["ratio"] =
      static_cast<double>(f.depth.size() * 2) / static_cast<double>(out.size());
}

void BM_DepthDecode(benchmark::State& state, const char* codec) {
  const CameraFrame& f = kinect_frame();
  std::vector<uint8_t> bytes;
  make_depth_encoder(codec)->encode(f.depth, true, bytes);
  auto dec = make_depth_decoder(codec);
  DepthImage out;
  for (auto _ : state) {
    dec->decode(bytes, out);
    benchmark::DoNotOptimize(out.pixels.data());
  }
}

void BM_JpegEncode640x576(benchmark::State& state) {
  const CameraFrame& f = kinect_frame();
  auto enc = make_color_encoder("jpeg");
  std::vector<uint8_t> out;
  for (auto _ : state) enc->encode(f.color, true, out);
  state.counters["bytes"] = static_cast<double>(out.size());
}

void BM_JpegDecode640x576(benchmark::State& state) {
  const CameraFrame& f = kinect_frame();
  std::vector<uint8_t> bytes;
  make_color_encoder("jpeg")->encode(f.color, true, bytes);
  auto dec = make_color_decoder("jpeg");
  ColorImage out;
  for (auto _ : state) dec->decode(bytes, out);
}

void BM_PointCloud640x576(benchmark::State& state) {
  auto src = open_source(kData / "k4a-recording" / "recording.mkv");
  const CameraFrame f = src->next();
  CloudBuilder builder(src->calibration());
  PointCloud cloud;
  for (auto _ : state) builder.build(f.depth, f.color, cloud);
  state.counters["points"] = static_cast<double>(cloud.points.size());
}

void BM_ReadKinectRecordingFrame(benchmark::State& state) {
  // Demux + MJPG decode + color-to-depth registration (the source caches single-capture files,
  // so this opens the recording anew each time: an upper bound).
  for (auto _ : state)
    benchmark::DoNotOptimize(open_source(kData / "k4a-recording" / "recording.mkv"));
}

// Issue goal: the paper's chain (lens correction + crop + threshold + 3 hole-filling iterations +
// Kalman) <= 1.0 ms per 640x576 frame on one core (paper: 1.34 ms on an RTX 2070).
void BM_FilterChain640x576(benchmark::State& state) {
  auto src = open_source(kData / "k4a-recording" / "recording.mkv");
  const CameraFrame frame = src->next();
  CameraFrame in;
  in.depth = frame.depth;  // depth chain only: color is gathered separately
  FilterChain chain(src->calibration().depth, paper_chain_config(640, 576));
  CameraFrame out;
  for (auto _ : state) chain.apply(in, out);
}

BENCHMARK(BM_FilterChain640x576)->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DepthEncode, rvl, "rvl")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DepthDecode, rvl, "rvl")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DepthEncode, trvl_key, "trvl")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DepthDecode, trvl_key, "trvl")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DepthEncode, zstd, "zstd")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DepthDecode, zstd, "zstd")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DepthEncode, volcast, "volcast")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DepthDecode, volcast, "volcast")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DepthEncode, volcast_n2, "volcast-n2")->Unit(benchmark::kMillisecond);
BENCHMARK_CAPTURE(BM_DepthDecode, volcast_n2, "volcast-n2")->Unit(benchmark::kMillisecond);
BENCHMARK(BM_JpegEncode640x576)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_JpegDecode640x576)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_PointCloud640x576)->Unit(benchmark::kMillisecond);
BENCHMARK(BM_ReadKinectRecordingFrame)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace volcast

BENCHMARK_MAIN();
