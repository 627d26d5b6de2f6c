#pragma once
// Internal: factories of the pure codecs, each defined in its own file; registry.cpp lists them
// in the codec table.
#include <memory>

#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/codec/detail/frame_header.hpp"

namespace volcast::detail {

/// raw, rvl, trvl (depth_codecs.cpp); make_trvl_encoder() is public (depth_codec.hpp).
std::unique_ptr<DepthEncoder> make_raw_depth_encoder();
std::unique_ptr<DepthDecoder> make_raw_depth_decoder();
std::unique_ptr<DepthEncoder> make_rvl_encoder();
std::unique_ptr<DepthDecoder> make_rvl_decoder();
std::unique_ptr<DepthDecoder> make_trvl_decoder();
/// Zstd or LZ4 after a left-delta and byte-plane transform (byte_plane_codecs.cpp); id is kZstd
/// or kLz4.
std::unique_ptr<DepthEncoder> make_byte_plane_encoder(CodecId id);
std::unique_ptr<DepthDecoder> make_byte_plane_decoder(CodecId id);
/// Volcast's own codec (volcast_codec.cpp): lossless, or near-lossless within `near_mm` mm;
/// `temporal`: delta frames between key frames predict blocks from the last frame. One decoder
/// for every variant (the header says which).
std::unique_ptr<DepthEncoder> make_volcast_encoder(int near_mm, bool temporal = false);
std::unique_ptr<DepthDecoder> make_volcast_decoder();
/// jpeg, raw and none (color_codecs.cpp).
std::unique_ptr<ColorEncoder> make_jpeg_color_encoder();
std::unique_ptr<ColorDecoder> make_jpeg_color_decoder();
std::unique_ptr<ColorEncoder> make_raw_color_encoder();
std::unique_ptr<ColorDecoder> make_raw_color_decoder();
std::unique_ptr<ColorEncoder> make_none_color_encoder();
std::unique_ptr<ColorDecoder> make_none_color_decoder();

}  // namespace volcast::detail
