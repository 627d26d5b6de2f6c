// The render thread's side of a viewer: the FrameFeed a presenter reads, the headless presenter
// and the default viewpoint.
#include "volcast/pipeline/frame_feed.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <optional>

#include "frame_feed_state.hpp"
#include "volcast/codec/tier.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/pipeline/receiver.hpp"
#include "volcast/render/camera_renderer.hpp"
#include "volcast/render/headless_target.hpp"

namespace volcast {

const std::vector<CameraCalibration>& FrameFeed::cameras() const {
  return state_.cameras;
}

bool FrameFeed::next(std::vector<std::shared_ptr<const CameraFrame>>& frames,
                     std::chrono::microseconds wait) {
  std::unique_lock lock(state_.mutex);
  state_.changed.wait_for(lock, wait,
                          [&] { return state_.done || state_.version != state_.taken; });
  if (state_.version == state_.taken) return false;
  state_.taken = state_.version;
  frames = state_.frames;
  state_.taken_capture_us = state_.handed_capture_us;
  state_.taken_ready_us = state_.handed_ready_us;
  state_.taken_presented = false;
  return true;
}

void FrameFeed::presented() {
  const int64_t now = wall_clock_us();
  std::lock_guard lock(state_.mutex);
  if (state_.taken_presented || state_.taken_ready_us == 0) return;
  state_.taken_presented = true;
  if (state_.presented_ms.size() < 4096)  // the receiving thread takes them twice a second
    state_.presented_ms.emplace_back(double(now - state_.taken_ready_us) / 1000.0,
                                     double(now - state_.taken_capture_us) / 1000.0);
}

bool FrameFeed::finished() const {
  std::lock_guard lock(state_.mutex);
  return (state_.done && state_.version == state_.taken) || state_.closed;
}

void FrameFeed::close() {
  state_.closed = true;
  state_.changed.notify_all();
}

LiveStats FrameFeed::live() const {
  std::lock_guard lock(state_.mutex);
  return state_.live;
}

Presenter headless_presenter(const ViewerOptions& opt) {
  return [opt](FrameFeed& feed, ViewerResult& result) {
    HeadlessTarget target(opt.width, opt.height);  // before the renderer: it owns the context
    CameraRenderer renderer;
    result.renderer = renderer.gl_description();
    // A software rasteriser (no GPU) takes the cores the stream needs: draw it less often.
    const bool software = result.renderer.find("llvmpipe") != std::string::npos ||
                          result.renderer.find("softpipe") != std::string::npos;
    const bool throttle = software && opt.software_render_fps > 0;
    if (throttle)
      spdlog::info("software renderer ({}): drawing at most {} frames per second", result.renderer,
                   opt.software_render_fps);
    const std::vector<CameraCalibration>& calibrations = feed.cameras();
    renderer.set_cameras(calibrations);
    renderer.set_avatar_filter(opt.avatar_filter);
    std::vector<std::shared_ptr<const CameraFrame>> frames, uploaded(calibrations.size());
    std::optional<ViewCamera> view = opt.view;
    auto last_draw = std::chrono::steady_clock::now() - std::chrono::hours(1);
    while (!feed.finished()) {
      if (!feed.next(frames, std::chrono::milliseconds(100))) continue;
      if (throttle) {  // draw the newest frames at most software_render_fps times a second
        const auto due =
            last_draw + std::chrono::duration_cast<std::chrono::steady_clock::duration>(
                            std::chrono::duration<double>(1.0 / opt.software_render_fps));
        while (std::chrono::steady_clock::now() < due && !feed.finished())
          feed.next(frames, std::chrono::duration_cast<std::chrono::microseconds>(
                                due - std::chrono::steady_clock::now()));
      }
      upload_changed(renderer, frames, uploaded);
      if (!view) view = default_view(calibrations, frames);
      renderer.draw_cameras(to_view(*view, target.target().aspect()), target.target(), opt.pass);
      target.finish();  // headless: "presented" once the picture is finished
      feed.presented();
      last_draw = std::chrono::steady_clock::now();
      ++result.frames_rendered;
    }
    if (!opt.screenshot.empty() && result.frames_rendered > 0) {
      ColorImage image;  // the only read-back: the last frame, for the screenshot
      target.read_image(image);
      write_color_png(opt.screenshot, image);
      spdlog::info("wrote {}", opt.screenshot.string());
    }
  };
}

ViewCamera default_view(std::span<const CameraCalibration> cameras,
                        std::span<const std::shared_ptr<const CameraFrame>> frames) {
  // The default viewpoint needs the points once: built on the CPU this once.
  std::vector<PointCloud> clouds(frames.size());
  std::vector<const PointCloud*> views;
  for (size_t i = 0; i < frames.size() && i < cameras.size(); ++i) {
    if (frames[i]) CloudBuilder(cameras[i]).build(frames[i]->depth, frames[i]->color, clouds[i]);
    views.push_back(&clouds[i]);
  }
  if (cameras.empty()) return ViewCamera{};
  return orbit_view(cameras.front().world_from_camera, views);
}

DrawPace::DrawPace(double fps)
    : period_(std::chrono::duration_cast<std::chrono::steady_clock::duration>(
          std::chrono::duration<double>(1.0 / std::max(fps, 0.5)))),
      next_(std::chrono::steady_clock::now()) {}

bool DrawPace::take(FrameFeed& feed, std::vector<std::shared_ptr<const CameraFrame>>& frames) {
  const auto now = std::chrono::steady_clock::now();
  feed.next(frames, std::chrono::duration_cast<std::chrono::microseconds>(
                        std::max(next_ - now, std::chrono::steady_clock::duration::zero())));
  const auto after = std::chrono::steady_clock::now();
  if (after < next_) return false;
  next_ += period_;
  if (next_ < after) next_ = after + period_;
  return true;
}

}  // namespace volcast
