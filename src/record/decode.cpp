#include "volcast/record/decode.hpp"

#include "volcast/core/error.hpp"

namespace volcast {

RecordingDecoder::RecordingDecoder(RecordingReader& reader)
    : reader_(reader),
      frames_(reader.info().stream.tier.depth_codec, reader.info().stream.tier.color_codec,
              reader.info().stream.welcome.cameras) {}

void RecordingDecoder::decode(size_t k, FrameSet& out) {
  const auto& sets = reader_.info().frame_sets;
  if (k >= sets.size())
    throw Error("recording: no frame set " + std::to_string(k) + " (it has " +
                std::to_string(sets.size()) + ")");
  if (!frames_.stateless() && !sets[k].key &&
      (last_ == static_cast<size_t>(-1) || k != last_ + 1)) {
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
  try {
    frames_.decode(message_, out);
  } catch (const Error& e) {
    throw Error("recording: frame set " + std::to_string(k) + ": " + e.what());
  }
  last_ = k;
}

}  // namespace volcast
