#include "volcast/room/patient_case.hpp"

#include <algorithm>
#include <cmath>

#include "volcast/core/error.hpp"

namespace volcast {

const std::vector<WindowPreset>& window_presets() {
  static const std::vector<WindowPreset> presets{
      {"abdomen", 40, 400}, {"liver", 90, 150}, {"bone", 480, 2500}};
  return presets;
}

WindowPreset window_preset(const std::string& name) {
  std::string names;
  for (const WindowPreset& p : window_presets()) {
    if (name == p.name) return p;
    names += std::string(names.empty() ? "" : ", ") + p.name;
  }
  throw Error("no window preset '" + name + "' (there are " + names + ")");
}

uint8_t window_gray(float hu, float center, float width) {
  const double c = center, w = std::max(1.0f, width);
  if (hu <= c - 0.5 - (w - 1) / 2) return 0;
  if (hu > c - 0.5 + (w - 1) / 2 || w <= 1) return 255;
  return static_cast<uint8_t>(
      std::clamp(std::lround(((hu - (c - 0.5)) / (w - 1) + 0.5) * 255), 0L, 255L));
}

std::vector<uint8_t> monitor_image(const MonitorSeries& series, const MonitorState& state) {
  if (state.slice >= series.slices)
    throw Error("monitor: slice " + std::to_string(state.slice) + " of " +
                std::to_string(series.slices));
  const size_t pixels = static_cast<size_t>(series.width) * series.height;
  const int16_t* hu = series.hu.data() + pixels * state.slice;
  const uint8_t* mask = state.overlay && !series.overlay.empty()
                            ? series.overlay.data() + pixels * state.slice
                            : nullptr;
  std::vector<uint8_t> rgba(pixels * 4);
  for (size_t i = 0; i < pixels; ++i) {
    const uint8_t g = window_gray(hu[i], state.center, state.width);
    uint8_t* px = &rgba[i * 4];
    if (mask && mask[i]) {
      px[0] = static_cast<uint8_t>((g * 3 + 255 * 2) / 5);
      px[1] = static_cast<uint8_t>((g * 3 + 140 * 2) / 5);
      px[2] = static_cast<uint8_t>((g * 3 + 25 * 2) / 5);
    } else {
      px[0] = px[1] = px[2] = g;
    }
    px[3] = 255;
  }
  return rgba;
}

}  // namespace volcast
