#pragma once
// Internal to volcast_pipeline: the state a FrameFeed shares between the receiving thread
// (receiver.cpp, which writes it) and the render thread (frame_feed.cpp, which reads it).
#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <utility>
#include <vector>

#include "volcast/pipeline/frame_feed.hpp"

namespace volcast {

// Hands the newest decoded images from the receiving thread to the render thread (the
// presenter), which uploads them and reconstructs the points on the GPU. Frames are shared,
// immutable once handed over: a camera that repeats its frame keeps its frame (and the renderer
// skips its upload).
struct FrameFeed::State {
  std::vector<CameraCalibration> cameras;
  mutable std::mutex mutex;
  std::condition_variable changed;
  std::vector<std::shared_ptr<const CameraFrame>> frames;
  uint64_t version = 0, taken = 0;
  bool done = false;                // the receiving side is finished
  std::atomic<bool> closed{false};  // the presenter asked to end
  LiveStats live;
  // The "presented" stage: when the newest frame set was captured and handed over, when the one
  // the presenter took was, and whether a picture of it was presented yet; the samples the
  // receiving thread has not yet moved into its StageRecorder (ready -> presented, capture ->
  // presented, ms).
  int64_t handed_capture_us = 0, handed_ready_us = 0, taken_capture_us = 0, taken_ready_us = 0;
  bool taken_presented = true;
  std::vector<std::pair<double, double>> presented_ms;
};

}  // namespace volcast
