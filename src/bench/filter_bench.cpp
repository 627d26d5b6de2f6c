// volcast bench (no flag): the filter chain, stage by stage, and the codecs (codec_bench.hpp) on
// the real recordings, one thread.
#include <fmt/format.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <nlohmann/json.hpp>

#include "codec_bench.hpp"
#include "volcast/bench/bench.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/filter/chain.hpp"

namespace volcast {
namespace fs = std::filesystem;

namespace {

struct BenchSet {
  std::string name;
  Intrinsics intrinsics;
  std::vector<DepthImage> frames;
  FilterConfig config;
};

}  // namespace

int run_bench(const BenchArgs& a) {
  const fs::path data = a.data.empty() ? fs::path("../shared/data") : fs::path(a.data);
  std::vector<BenchSet> sets;
  // The paper's full chain: lens correction + crop + threshold + 3 hole-filling iterations +
  // Kalman.
  FilterConfig full;
  full.undistort = true;
  full.near_mm = 200;
  full.far_mm = 5000;
  full.hole_filling = HoleFiller{};
  full.kalman = KalmanFilter{};
  auto add_source = [&](const fs::path& path, const std::string& name, int max_frames) {
    SourceOptions o;
    o.intrinsics =
        Intrinsics{0, 0, 460, 460, 320, 180};  // used only where a folder has no intrinsics
    auto src = open_source(path, o);
    const Intrinsics& k = src->calibration().depth;
    BenchSet s{name, k, {}, paper_chain_config(k.width, k.height)};
    if (a.frames > 0) max_frames = std::min(max_frames, a.frames);
    for (int i = 0; i < std::min(max_frames, src->frame_count()); ++i)
      s.frames.push_back(src->next().depth);
    sets.push_back(std::move(s));
  };
  if (fs::exists(data / "k4a-recording" / "recording.mkv")) {
    add_source(data / "k4a-recording" / "recording.mkv", "k4a-recording", 1);
    // The four-camera frames: genuine NFOV depth, no calibration recorded; timed with the
    // recording's lens model (the same camera type).
    BenchSet s{"k4a-4cam-nfov", sets.back().intrinsics, {}, sets.back().config};
    for (const auto& e : fs::directory_iterator(data / "k4a-4cam-nfov"))
      if (e.path().filename().string().rfind("depth", 0) == 0)
        s.frames.push_back(read_depth_png(e.path()));
    if (!s.frames.empty()) sets.push_back(std::move(s));
  }
  if (fs::exists(data / "rgbd-hands-640x360"))
    add_source(data / "rgbd-hands-640x360", "rgbd-hands-640x360", 60);
  for (const auto& d : a.datasets) add_source(d, fs::path(d).filename().string(), 60);
  if (sets.empty())
    throw Error("bench: no data found in " + data.string() + " (use --data DIR or --dataset PATH)");

  nlohmann::json j;
  j["filters"] = nlohmann::json::array();
  std::printf(
      "Filter chain, one thread, median over %d passes of each set (microseconds per frame)\n",
      a.repeats);
  std::printf("%-20s %-17s", "dataset", "frame");
  for (const char* name : FilterTimings::kNames) std::printf(" %12.12s", name);
  std::printf(" %10s\n", "total");
  for (BenchSet& s : sets) {
    FilterChain chain(s.intrinsics, s.config);
    std::array<std::vector<double>, FilterTimings::kStages> samples;
    std::vector<double> totals;
    CameraFrame in, out;
    for (int r = 0; r < a.repeats; ++r)
      for (const DepthImage& d : s.frames) {
        in.depth = d;
        chain.apply(in, out);
        for (int st = 0; st < FilterTimings::kStages; ++st)
          samples[st].push_back(chain.last_timings().us[st]);
        totals.push_back(chain.last_timings().total_us());
      }
    auto median = [](std::vector<double> v) {
      std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
      return v[v.size() / 2];
    };
    const std::string frame =
        fmt::format("{}x{}->{}x{}", s.intrinsics.width, s.intrinsics.height,
                    chain.output_intrinsics().width, chain.output_intrinsics().height);
    std::printf("%-20s %-17s", s.name.c_str(), frame.c_str());
    nlohmann::json stages;
    for (int st = 0; st < FilterTimings::kStages; ++st) {
      const double m = median(samples[st]);
      std::printf(" %12.1f", m);
      stages[FilterTimings::kNames[st]] = m / 1000.0;
    }
    const double total = median(totals);
    std::printf(" %10.1f\n", total);
    j["filters"].push_back({{"dataset", s.name},
                            {"frame", frame},
                            {"frames", s.frames.size()},
                            {"stages_ms", stages},
                            {"total_ms", total / 1000.0}});
  }
  std::printf("(paper, CUDA on an RTX 2070: 1340 us for the chain, 590 us of it hole filling)\n");
  bench_codecs(data, a.datasets, std::max(1, a.repeats / 10), a.frames, j);
  if (!a.json.empty()) {
    std::ofstream(a.json) << j.dump(2) << "\n";
    std::printf("wrote %s\n", a.json.c_str());
  }
  return 0;
}

}  // namespace volcast
