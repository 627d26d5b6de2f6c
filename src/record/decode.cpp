#include "volcast/record/decode.hpp"

#include "volcast/codec/registry.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

RecordingDecoder::RecordingDecoder(RecordingReader& reader) : reader_(reader) {
  const RecordingStream& s = reader.info().stream;
  for (size_t i = 0; i < s.welcome.cameras.size(); ++i) {
    depth_.push_back(make_depth_decoder(s.depth_codec));
    color_.push_back(make_color_decoder(s.color_codec));
  }
  const DepthCodecInfo* d = find_depth_codec(s.depth_codec);
  const ColorCodecInfo* c = find_color_codec(s.color_codec);
  stateless_ = d && c && !d->temporal && !c->temporal;
}

void RecordingDecoder::decode(size_t k, FrameSet& out) {
  const auto& sets = reader_.info().frame_sets;
  if (k >= sets.size())
    throw Error("recording: no frame set " + std::to_string(k) + " (it has " +
                std::to_string(sets.size()) + ")");
  if (!stateless_ && !sets[k].key && (last_ == static_cast<size_t>(-1) || k != last_ + 1)) {
    size_t from = k;
    while (from > 0 && !sets[from].key) --from;
    if (!sets[from].key)
      throw Error("recording: frame set " + std::to_string(k) +
                  " is a delta with no key frame set before it");
    for (size_t j = from; j < k; ++j) decode_one(j, scratch_);
  }
  decode_one(k, out);
}

void RecordingDecoder::decode_one(size_t k, FrameSet& out) {
  last_ = static_cast<size_t>(-1);  // until this one has decoded
  // parse_frame_set expects a send time first: the body goes after 8 bytes of room for it.
  reader_.read(k, message_, 8);
  const auto& cams = reader_.info().stream.welcome.cameras;
  const auto fail = [&](const std::string& why) {
    throw Error("recording: frame set " + std::to_string(k) + ": " + why);
  };
  try {
    protocol::parse_frame_set(message_, view_);
  } catch (const Error& e) {
    fail(e.what());
  }
  if (view_.cameras.size() != cams.size())
    fail(std::to_string(view_.cameras.size()) + " cameras, the recording has " +
         std::to_string(cams.size()));
  out.sequence = view_.sequence;
  out.capture_time_us = view_.times.capture_us;
  out.cameras.resize(cams.size());
  for (size_t i = 0; i < cams.size(); ++i) {
    const Intrinsics& K = cams[i].calibration.depth;
    const auto& e = view_.cameras[i];
    const auto check = [&](const char* what, const std::optional<DeclaredSize>& size) {
      if (size && (size->width != K.width || size->height != K.height))
        fail("camera " + std::to_string(i) + ": its " + what + " stream declares " +
             std::to_string(size->width) + "x" + std::to_string(size->height) +
             ", its calibration is " + std::to_string(K.width) + "x" + std::to_string(K.height));
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
      fail("camera " + std::to_string(i) + ": " + err.what());
    }
  }
  last_ = k;
}

}  // namespace volcast
