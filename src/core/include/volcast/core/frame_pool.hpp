#pragma once
// Camera frames reused once nobody holds them: a published frame set lets go of its frames when
// every tier and viewer is done with them, and the next decode into such a frame reuses its image
// buffers (no allocation per frame set once warm).
#include <memory>
#include <vector>

#include "volcast/core/frame.hpp"

namespace volcast {

class FramePool {
 public:
  /// `cameras` cameras, at most `keep` frames kept per camera.
  explicit FramePool(size_t cameras, size_t keep = 16) : frames_(cameras), keep_(keep) {}
  /// A frame of camera `i` (< cameras) that nobody else holds, or a new one (kept for later if
  /// fewer than `keep` are). Not thread-safe.
  std::shared_ptr<CameraFrame> take(size_t i) {
    for (auto& f : frames_[i])
      if (f.use_count() == 1) return f;
    auto f = std::make_shared<CameraFrame>();
    if (frames_[i].size() < keep_) frames_[i].push_back(f);
    return f;
  }

 private:
  std::vector<std::vector<std::shared_ptr<CameraFrame>>> frames_;
  size_t keep_;
};

}  // namespace volcast
