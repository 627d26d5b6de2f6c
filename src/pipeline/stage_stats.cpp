#include "volcast/pipeline/stage_stats.hpp"

#include <algorithm>
#include <numeric>

#include "volcast/net/stream/client.hpp"

namespace volcast {

double percentile(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const size_t i =
      std::min(v.size() - 1, static_cast<size_t>(p * static_cast<double>(v.size() - 1) + 0.5));
  return v[i];
}

void StageRecorder::add(const StageTimes& t, int64_t ready_us) {
  const int64_t ends[] = {t.filter_done_us, t.encode_done_us, t.send_us,
                          t.received_us,    t.decoded_us,     ready_us};
  int64_t start = t.capture_us;
  for (size_t i = 0; i < 6; ++i) {
    samples_[i].push_back(static_cast<double>(ends[i] - start) / 1000.0);
    start = ends[i];
  }
  samples_[7].push_back(static_cast<double>(ready_us - t.capture_us) / 1000.0);
}

void StageRecorder::add_presented(double presented_ms, double photon_ms) {
  samples_[6].push_back(presented_ms);
  samples_[8].push_back(photon_ms);
}

std::vector<StageLatency> StageRecorder::summary() const {
  std::vector<StageLatency> out;
  for (size_t i = 0; i < kStageNames.size(); ++i) {
    const auto& s = samples_[i];
    StageLatency l;
    l.stage = kStageNames[i];
    l.p50_ms = percentile(s, 0.5);
    l.p99_ms = percentile(s, 0.99);
    l.mean_ms = s.empty() ? 0 : std::accumulate(s.begin(), s.end(), 0.0) / double(s.size());
    out.push_back(l);
  }
  return out;
}

}  // namespace volcast
