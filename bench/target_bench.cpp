// Lattice target detection, one thread, on SYNTHETIC noisy Azure Kinect NFOV images (the genuine
// recording's lens model) with the target 1, 2 and 3 m away -- Muehlenbrock et al. report about
// 20 ms per detection on one core. Measured (Release, 2-core VM): ~7 ms at 1 m, ~3.5 ms at 2 m,
// ~2.5 ms at 3 m.
//   build/release/bench/volcast_benchmarks --benchmark_filter=Target
#include <benchmark/benchmark.h>

#include <Eigen/Geometry>
#include <cmath>
#include <filesystem>

#include "bench_data.hpp"
#include "volcast/calibrate/target.hpp"
#include "volcast/calibrate/target_sim.hpp"
#include "volcast/capture/source.hpp"

namespace volcast {
namespace {

void BM_TargetDetect640x576(benchmark::State& state) {
  const double distance = static_cast<double>(state.range(0)) / 1000;
  const Intrinsics k =
      open_source(std::filesystem::path(bench::data_dir()) / "k4a-recording" / "recording.mkv")
          ->calibration()
          .depth;
  const RayTable rays = make_ray_table(k);
  SimScene scene;
  scene.target = lattice_target();
  // Looking down 25 degrees at the middle of the balls from `distance`.
  const Eigen::Vector3d middle(0, 1.2, 0);
  const Eigen::Vector3d eye =
      middle + distance * Eigen::Vector3d(0.3, std::sin(0.44), 0.9).normalized();
  const RigidTransform world_from_camera = camera_looking_at(eye, middle);
  const DepthImage depth = render_sim_depth(k, world_from_camera, scene, DepthNoise{});
  int found = 0, runs = 0;
  for (auto _ : state) {
    const TargetDetection d = detect_target(depth, rays, scene.target);
    found += d.found;
    ++runs;
    benchmark::DoNotOptimize(d.camera_from_target.translation.data());
  }
  state.counters["found"] = static_cast<double>(found) / std::max(runs, 1);
}
BENCHMARK(BM_TargetDetect640x576)->Arg(1000)->Arg(2000)->Arg(3000)->Unit(benchmark::kMillisecond);

}  // namespace
}  // namespace volcast
