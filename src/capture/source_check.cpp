#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

FrameCheck check_frames(FrameSource& source, const std::function<void(int, int)>& progress) {
  FrameCheck out;
  const int total = source.frame_count();
  for (int i = 0; i < total; ++i) {
    try {
      const CameraFrame f = source.next();
      out.frames_without_color += f.color.empty();
    } catch (const Error& e) {
      out.bad.push_back({i, e.what()});
    }
    ++out.frames;
    if (progress) progress(i + 1, total);
  }
  return out;
}

}  // namespace volcast
