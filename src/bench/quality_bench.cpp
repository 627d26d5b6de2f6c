// `volcast bench --quality`: the renderer's settings scored by leave-one-camera-out view
// synthesis on a registered site, by default the four real Azure Kinects (issue 38).
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cstdio>
#include <filesystem>

#include "volcast/bench/bench.hpp"
#include "volcast/calibrate/site_calibration.hpp"
#include "volcast/capture/real_sites.hpp"
#include "volcast/core/error.hpp"
#include "volcast/quality/quality_report.hpp"

namespace volcast {
namespace fs = std::filesystem;
namespace {

// The site to score: --site, else the four Azure Kinects registered from depth (as the demo
// does, cached in out/site-4cam.json; the demo's out/demo/site-4cam.json is taken if present).
fs::path site_config(const BenchArgs& a) {
  if (!a.site.empty()) return a.site;
  for (const fs::path p : {"out/site-4cam.json", "out/demo/site-4cam.json"})
    if (fs::exists(p)) {
      spdlog::info("bench --quality: the four cameras' registration from {}", p.string());
      return p;
    }
  const auto data = find_data(a.data);
  if (!data)
    throw Error("bench --quality: no --site and the real recordings were not found (--data DIR)");
  spdlog::info(
      "bench --quality: registering the four Azure Kinects from depth alone (once; about "
      "a minute) into out/site-4cam.json");
  fs::create_directories("out");
  CalibrationOptions c;
  c.sources = {(*data / kFourKinectSet).string()};
  const fs::path config = "out/site-4cam.json";
  if (report_calibration(calibrate_site(c), config, "") != 0 || !fs::exists(config))
    throw Error("bench --quality: the four cameras could not be registered");
  return config;
}

}  // namespace

int run_quality_bench(const BenchArgs& a) {
  const fs::path config = site_config(a);
  // The four Azure Kinects recorded no color calibration: the recording's, as a nominal one.
  std::optional<ColorCalibration> nominal;
  if (const auto data = find_data(a.data)) nominal = nominal_kinect_color(*data);
  const QualitySite site = load_quality_site(config, nominal);
  const std::vector<QualityRow> rows = score_settings(site, quality_settings(), a.pictures);
  std::printf(
      "\nLeave-one-camera-out view synthesis on %s (%zu cameras, each held out in turn; "
      "figures are means over them; ratios against the first row)\n\n%s\n",
      config.string().c_str(), site.cameras.size(), quality_table(rows).c_str());
  if (!a.json.empty()) write_quality_json(rows, a.json);
  return 0;
}

}  // namespace volcast
