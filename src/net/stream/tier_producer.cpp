#include "tier_producer.hpp"

#include <algorithm>

namespace volcast::detail {

bool TierProducer::note_encoded(const EncodedFrames& encoded, double wall_ms, int64_t now_us) {
  if (encoded.key) ++report.key_frames;
  ++report.frames_encoded;
  encode_ms_total += wall_ms;
  const double weight = 1.0 / double(std::min<uint64_t>(report.frames_encoded, 30));
  cpu_ms_mean += (encoder.last_cpu_ms() - cpu_ms_mean) * weight;
  // Its rate over the last second (the mean gap times the count, so that a second of N frame
  // sets spans N gaps).
  produced.emplace_back(now_us, encoded.body.size());
  while (produced.front().first < now_us - 1'000'000) produced.pop_front();
  if (now_us - produced.front().first < 500'000 && produced.size() < 8) return false;
  size_t bytes = 0;
  for (const auto& p : produced) bytes += p.second;
  const double span_us = std::max<double>(double(now_us - produced.front().first), 1) *
                         double(produced.size()) / double(std::max<size_t>(produced.size() - 1, 1));
  report.mbit_s = double(bytes) * 8 / span_us;
  return true;
}

TierReport TierProducer::report_now(double cores_per_ns) const {
  TierReport r = report;
  r.viewers = static_cast<int>(subscribers.size());
  if (r.frames_encoded > 0) r.encode_ms_mean = encode_ms_total / double(r.frames_encoded);
  r.cpu_ms_mean = cpu_ms_mean;
  r.cost_cores = encode_ns * cores_per_ns;
  return r;
}

}  // namespace volcast::detail
