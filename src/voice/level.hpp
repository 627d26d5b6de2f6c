#pragma once
// Private to src/voice: what the voice loops measure and where voices play from.
#include <algorithm>
#include <array>
#include <cmath>
#include <span>
#include <vector>

#include "volcast/audio/voice_format.hpp"
#include "volcast/session/participant.hpp"

namespace volcast::voice {

/// Whether a voice is speaking: its loudest 20 ms of the last 300 ms above -45 dBFS (RMS).
class Loudness {
 public:
  void add(std::span<const float> block) {
    double sum = 0;
    for (float x : block) sum += double(x) * x;
    rms_[next_++ % rms_.size()] = std::sqrt(sum / double(std::max<size_t>(block.size(), 1)));
  }
  bool speaking() const { return *std::max_element(rms_.begin(), rms_.end()) > 0.0056; }

 private:
  std::array<double, 15> rms_{};
  size_t next_ = 0;
};

/// Latency samples (ms), the first 2^16 kept.
class Latencies {
 public:
  void add(double ms) {
    if (samples_.size() < (1u << 16)) samples_.push_back(ms);
  }
  double percentile(double p) const {
    if (samples_.empty()) return 0;
    std::vector<double> v = samples_;
    const size_t k = std::min(v.size() - 1, static_cast<size_t>(p * double(v.size() - 1) + 0.5));
    std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
    return v[k];
  }
  size_t size() const { return samples_.size(); }

 private:
  std::vector<double> samples_;
};

/// Limits a mix to [-1, 1] without a hard edge (tanh above 0.5).
inline float soft_clip(float x) {
  const float a = std::abs(x);
  if (a <= 0.5f) return x;
  return std::copysign(0.5f + 0.5f * std::tanh((a - 0.5f) / 0.5f), x);
}

/// Height of a standing person's head above the floor, metres (before a pose arrives).
inline constexpr float kStandingHeadM = 1.6f;

/// room_from_head of this participant: its published head, else standing at its play area's
/// origin facing the play area's -z.
inline Pose listener_head(const VoiceScene& s) {
  if (s.has_own_body) return s.own_head;
  const RigidTransform room_from_playarea = session::room_from_playarea(s.spot);
  Pose head;
  head.position = (room_from_playarea * Eigen::Vector3d(0, kStandingHeadM, 0)).cast<float>();
  head.orientation = Eigen::Quaternionf(room_from_playarea.rotation.cast<float>());
  return head;
}

/// Where participant `id`'s voice comes from (room frame, metres): its head, else standing at
/// its spot; the OR site (1) at `site_position`.
inline Eigen::Vector3f speaker_position(const VoiceScene& s, uint32_t id,
                                        const Eigen::Vector3f& site_position) {
  if (id == 1) return site_position;
  for (const VoiceScene::Speaker& r : s.others)
    if (r.id == id) {
      if (r.has_pose) return r.head.position;
      return {r.spot.x, kStandingHeadM, r.spot.z};
    }
  return site_position;
}

}  // namespace volcast::voice
