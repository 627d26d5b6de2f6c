#include "volcast/session/rate_limit.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace volcast::session {
namespace {

constexpr int64_t kBurstEndsUs = 1'000'000;     // a second without a drop
constexpr int64_t kReportEveryUs = 10'000'000;  // while a burst lasts

std::string number(double v) {
  if (v >= 1 && std::abs(v - std::round(v)) < 1e-9) return std::to_string(std::lround(v));
  char s[32];
  std::snprintf(s, sizeof s, "%.3g", v);
  return s;
}

}  // namespace

std::string to_string(const RateLimit& limit) {
  const std::string per = limit.per_second >= 1
                              ? number(limit.per_second) + " a second"
                              : "one every " + number(1 / limit.per_second) + " s";
  return std::string(limit.what) + ": " + number(limit.burst) + " at once, then " + per;
}

std::string RateLimiter::burst_count(const Bucket& b, int64_t now_us) {
  const double seconds = static_cast<double>(now_us - b.burst_since_us) * 1e-6;
  char s[32];
  std::snprintf(s, sizeof s, "%.1f", seconds);
  return std::to_string(b.drops) + " " + b.limit.what + " dropped in " + s + " s over the limit (" +
         to_string(b.limit) + ")";
}

Admission RateLimiter::take(Bucket& b, const RateLimit& limit, int64_t now_us) {
  b.limit = limit;
  if (b.tokens < 0) {
    b.tokens = limit.burst;
    b.last_us = now_us;
  }
  const double elapsed = static_cast<double>(std::max<int64_t>(0, now_us - b.last_us)) * 1e-6;
  b.tokens = std::min(limit.burst, b.tokens + elapsed * limit.per_second);
  b.last_us = now_us;
  Admission a;
  if (b.drops && now_us - b.last_drop_us >= kBurstEndsUs) {  // the burst before has ended
    a.report = burst_count(b, b.last_drop_us);
    b.drops = 0;
  }
  if (b.tokens >= 1) {
    b.tokens -= 1;
    return a;
  }
  a.admitted = false;
  ++dropped_;
  b.last_drop_us = now_us;
  if (b.drops++ == 0) {
    b.burst_since_us = b.last_report_us = now_us;
    a.started = true;
    a.report =
        std::string(limit.what) + " over the limit (" + to_string(limit) + "): dropping them";
  } else if (now_us - b.last_report_us >= kReportEveryUs) {
    b.last_report_us = now_us;
    a.report = burst_count(b, now_us) + ", still going on";
  }
  return a;
}

Admission RateLimiter::admit(uint64_t who, uint8_t type, int64_t now_us) {
  const RateLimit limit = limit_of(type);
  if (type >= kSlots - 1 || limit.burst <= 0) return {};  // not a participant's: the hub refuses it
  std::lock_guard lock(mutex_);
  return take(buckets_[who][type], limit, now_us);
}

Admission RateLimiter::admit_creation(uint64_t who, int64_t now_us) {
  std::lock_guard lock(mutex_);
  return take(buckets_[who][kSlots - 1], kSessionCreation, now_us);
}

std::string RateLimiter::forget(uint64_t who, int64_t now_us) {
  std::lock_guard lock(mutex_);
  const auto it = buckets_.find(who);
  if (it == buckets_.end()) return {};
  std::string report;
  for (const Bucket& b : it->second)
    if (b.drops) report += (report.empty() ? "" : "; ") + burst_count(b, now_us);
  buckets_.erase(it);
  return report;
}

uint64_t RateLimiter::dropped() const {
  std::lock_guard lock(mutex_);
  return dropped_;
}

}  // namespace volcast::session
