#include "volcast/filter/chain.hpp"

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

using nlohmann::json;

template <typename T>
void set_if(const json& j, const char* key, T& value) {
  if (j.contains(key)) value = j.at(key).get<T>();
}

}  // namespace

FilterConfig paper_chain_config(int width, int height) {
  FilterConfig c;
  c.undistort = true;
  if (width == 640 && height == 576) c.crop = kNfovCrop;
  c.near_mm = 200;
  c.far_mm = 5000;
  c.hole_filling = HoleFiller{};
  c.kalman = KalmanFilter{};
  return c;
}

CropRect parse_crop(const std::string& text) {
  if (text == "nfov") return kNfovCrop;
  CropRect r;
  char tail = 0;
  if (std::sscanf(text.c_str(), "%d,%d,%d,%d%c", &r.x, &r.y, &r.width, &r.height, &tail) != 4)
    throw Error("crop must be 'nfov' or x,y,width,height in pixels, got '" + text + "'");
  return r;
}

void apply_filter_json(const std::string& json_text, FilterConfig& c) {
  const json j = json::parse(json_text, nullptr, false);
  if (j.is_discarded() || !j.is_object()) throw Error("filters: not a JSON object");
  try {
    for (const auto& item : j.items()) {
      const std::string& key = item.key();  // a name, not a binding: Clang 14 cannot capture one
      static const char* known[] = {"undistort",     "crop",       "near_mm",
                                    "far_mm",        "background", "background_margin_mm",
                                    "flying_pixels", "hole_fill",  "kalman"};
      if (std::find_if(std::begin(known), std::end(known),
                       [&](const char* k) { return key == k; }) == std::end(known))
        throw Error("filters: unknown field '" + key + "'");
    }
    set_if(j, "undistort", c.undistort);
    if (j.contains("crop")) {
      const json& v = j.at("crop");
      if (v.is_boolean()) {
        c.crop = v.get<bool>() ? std::optional(kNfovCrop) : std::nullopt;
      } else if (v.is_string()) {
        c.crop = parse_crop(v.get<std::string>());
      } else {
        const auto a = v.get<std::vector<int>>();
        if (a.size() != 4) throw Error("filters: crop needs [x, y, width, height]");
        c.crop = CropRect{a[0], a[1], a[2], a[3]};
      }
    }
    set_if(j, "near_mm", c.near_mm);
    set_if(j, "far_mm", c.far_mm);
    if (j.contains("background")) c.background_file = j.at("background").get<std::string>();
    set_if(j, "background_margin_mm", c.background_margin_mm);
    if (j.contains("flying_pixels")) {
      const json& v = j.at("flying_pixels");
      if (v.is_boolean()) {
        c.flying_pixels = v.get<bool>() ? std::optional(FlyingPixelFilter{}) : std::nullopt;
      } else {
        FlyingPixelFilter f;
        set_if(v, "abs_mm", f.abs_mm);
        set_if(v, "rel", f.rel);
        set_if(v, "min_support", f.min_support);
        c.flying_pixels = f;
      }
    }
    if (j.contains("hole_fill")) {
      const json& v = j.at("hole_fill");
      if (v.is_boolean() || v.is_number()) {
        const int n = v.is_boolean() ? (v.get<bool>() ? 3 : 0) : v.get<int>();
        if (n > 0) {
          HoleFiller h;
          h.iterations = n;
          c.hole_filling = h;
        } else {
          c.hole_filling.reset();
        }
      } else {
        HoleFiller h;
        set_if(v, "iterations", h.iterations);
        set_if(v, "min_neighbours", h.min_neighbours);
        set_if(v, "max_spread_mm", h.max_spread_mm);
        c.hole_filling = h;
      }
    }
    if (j.contains("kalman")) {
      const json& v = j.at("kalman");
      if (v.is_boolean()) {
        c.kalman = v.get<bool>() ? std::optional(KalmanFilter{}) : std::nullopt;
      } else {
        KalmanFilter k;
        set_if(v, "noise_mm_at_1m", k.noise_mm_at_1m);
        set_if(v, "process_mm", k.process_mm);
        set_if(v, "gate_sigmas", k.gate_sigmas);
        set_if(v, "gate_min_mm", k.gate_min_mm);
        set_if(v, "gate_max_mm", k.gate_max_mm);
        c.kalman = k;
      }
    }
  } catch (const json::exception& e) {
    throw Error(std::string("filters: malformed field: ") + e.what());
  }
}

FilterChain::FilterChain(const Intrinsics& source, FilterConfig config)
    : config_(std::move(config)) {
  map_ = make_pixel_map(source, config_.undistort, config_.crop);
  if (!config_.background_file.empty()) {
    background_ = BackgroundModel::load(config_.background_file);
    const DepthImage& m = background_->min_depth;
    if (m.width != map_.output.width || m.height != map_.output.height)
      throw Error("background model '" + config_.background_file.string() + "' is " +
                  std::to_string(m.width) + "x" + std::to_string(m.height) +
                  ", the filtered image is " + std::to_string(map_.output.width) + "x" +
                  std::to_string(map_.output.height) +
                  " (learn it with the same lens/crop settings)");
  }
}

void FilterChain::apply(const CameraFrame& in, CameraFrame& out, const StageObserver& observer) {
  using clock = std::chrono::steady_clock;
  auto t = clock::now();
  auto lap = [&](int stage) {
    const auto now = clock::now();
    timings_.us[static_cast<size_t>(stage)] =
        std::chrono::duration<double, std::micro>(now - t).count();
    if (observer) observer(stage, out.depth);
    t = clock::now();
  };
  timings_ = {};
  out.device_timestamp_us = in.device_timestamp_us;
  apply_pixel_map(map_, in.depth, out.depth);
  lap(0);
  if (config_.near_mm || config_.far_mm) {
    threshold_depth(out.depth, config_.near_mm, config_.far_mm);
    lap(1);
  }
  if (background_) {
    background_->subtract(out.depth, config_.background_margin_mm);
    lap(2);
  }
  if (config_.flying_pixels) {
    config_.flying_pixels->apply(out.depth);
    lap(3);
  }
  if (config_.hole_filling) {
    config_.hole_filling->apply(out.depth);
    lap(4);
  }
  if (config_.kalman) {
    config_.kalman->apply(out.depth);
    lap(5);
  }
  apply_pixel_map(map_, in.color, out.color);  // color is not part of the timed depth chain
}

}  // namespace volcast
