#include "volcast/net/frame_set_decoder.hpp"

#include "volcast/codec/registry.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

FrameSetDecoder::FrameSetDecoder(const std::string& depth_codec, const std::string& color_codec,
                                 std::vector<protocol::CameraInfo> cameras)
    : cameras_(std::move(cameras)) {
  for (size_t i = 0; i < cameras_.size(); ++i) {
    depth_.push_back(make_depth_decoder(depth_codec));
    color_.push_back(make_color_decoder(color_codec));
  }
  const DepthCodecInfo* d = find_depth_codec(depth_codec);
  const ColorCodecInfo* c = find_color_codec(color_codec);
  stateless_ = d && c && !d->temporal && !c->temporal;
}

void FrameSetDecoder::decode(std::span<const uint8_t> message, FrameSet& out) {
  protocol::parse_frame_set(message, view_);
  if (view_.cameras.size() != cameras_.size())
    throw Error(std::to_string(view_.cameras.size()) + " cameras, the tier has " +
                std::to_string(cameras_.size()));
  out.sequence = view_.sequence;
  out.capture_time_us = view_.times.capture_us;
  out.cameras.resize(cameras_.size());
  for (size_t i = 0; i < cameras_.size(); ++i) {
    const Intrinsics& K = cameras_[i].calibration.depth;
    const auto& e = view_.cameras[i];
    const auto fail = [&](const std::string& why) {
      throw Error("camera " + std::to_string(i) + ": " + why);
    };
    const auto check = [&](const char* what, const std::optional<DeclaredSize>& size) {
      if (size && (size->width != K.width || size->height != K.height))
        fail(std::string("its ") + what + " stream declares " + std::to_string(size->width) + "x" +
             std::to_string(size->height) + ", its calibration is " + std::to_string(K.width) +
             "x" + std::to_string(K.height));
    };
    check("depth", declared_depth_size(e.depth));
    check("color", declared_color_size(e.color));
    CameraFrame& f = out.cameras[i];
    f.device_timestamp_us = e.device_timestamp_us;
    try {
      depth_[i]->decode(e.depth, f.depth);
      if (e.color.empty())
        f.color = ColorImage{};
      else
        color_[i]->decode(e.color, f.color);
    } catch (const Error& err) {
      fail(err.what());
    }
  }
}

}  // namespace volcast
