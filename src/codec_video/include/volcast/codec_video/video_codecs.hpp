#pragma once
// Lossy video codecs through libavcodec (FFmpeg), apart from the pure codecs of volcast_codec so
// that those build without FFmpeg (WASM). Link volcast_codec_video and call
// register_video_codecs() once at start-up; from then on these are in the codec table
// (volcast/codec/registry.hpp) like any other:
//   depth h264 - x264, 10-bit 4:2:0 (profile High 10), CRF 12     (lossy, temporal)
//   depth hevc - x265, 12-bit 4:2:0 (Main 12, a RExt profile), CRF 12  (lossy, temporal)
//   color h264 - x264, 8-bit 4:2:0 (Constrained Baseline), CRF 23  (lossy, temporal)
// All with preset ultrafast, tune zerolatency, no B-frames, one thread: every frame is one packet
// at once and decodes at once. Key frames come only on request or at a size change: an intra
// random-access picture (H.264: IDR; HEVC: IDR for the first, CRA without leading pictures
// after), preceded by the parameter sets (SPS, PPS, and VPS for HEVC), so a fresh decoder starts
// at any key frame. A decoder refuses a delta frame until it has decoded a key frame, and again
// after a corrupt frame; it opens a fresh libavcodec decoder at every key frame.
//
// ## Depth h264 (codec id 6) and hevc (id 7)
// The 12-byte depth header (volcast/codec/depth_codec.hpp), with byte 4 bit 0 = the packet is a
// key frame and byte 5 = the video's bit depth B (10 for h264, 12 for hevc; decoders check it);
// bytes 6-7 are 0. Body:
//   near u16 | far u16 | M u32 | P u32 | M bytes: valid mask | P bytes: video packet
// with 1 <= near < far and P exactly the bytes after the mask (decoders refuse otherwise).
//  - Valid mask: one Zstandard frame (level 1) that decompresses to at most 2n + 16 bytes (n = w *
//    h) of LEB128 varints (7 bits per byte, low first, bit 7 = more; at most 5 bytes): pairs (Z,
//    V), a run of Z invalid pixels then V valid ones in raster order, until n pixels; Z = V = 0
//    before the end is corrupt; the last pair may have V = 0. The mask decodes exactly.
//  - Video packet: the Annex B byte stream of one picture in the luma plane: width max(16, w
//    rounded up to even), height max(16, h rounded up to even), chroma planes constant 2^(B-1).
//    The picture is at least w x h (decoders refuse a smaller one); only its top-left w x h is
//    used. Depth maps linearly onto the codes 0..2^B - 1 over [near, far], the range of the last
//    key frame (near = max(1, min valid depth - 100), far = min(65535, max(max valid depth + 100,
//    near + 1)); 1 and 65535 when no pixel is valid), sent with every frame:
//      encoder: code = round((clamp(d, near, far) - near) * (2^B - 1) / (far - near)); an invalid
//        pixel takes its left neighbour's code (0 at a row start), the padding columns and rows
//        repeat the last column and row
//      decoder: a valid pixel d' = clamp(near + round(min(code, 2^B - 1) * (far - near) /
//        (2^B - 1)), 1, 65535) (rounding half away from zero); an invalid pixel 0.
//    Error on valid pixels: the video's error times (far - near) / (2^B - 1) mm, plus the
//    clamping of depth outside the key frame's range; no bound is guaranteed.
//
// ## Color h264
// An empty (0 x 0) image is sent as 0 bytes and decodes to an empty image. Otherwise the 12-byte
// color header: 'V' 'C' | version 1 | codec id 2 | flags (bit 0: key frame) | 3 zero bytes |
// width u16 | height u16 (little-endian; even sides only), then the Annex B packet of one w x h
// 8-bit 4:2:0 picture. Encoder: BGRA -> YUV 4:2:0 by swscale (bilinear; swscale's default
// BT.601 limited-range matrix); the decoder converts back to BGRA the same way (alpha 255) and
// refuses a picture whose size differs from the header.
namespace volcast {

/// Adds depth h264 and hevc and color h264 to the codec table (after the pure codecs). Safe to
/// call more than once and from several threads: the first call registers, later ones do nothing.
void register_video_codecs();

}  // namespace volcast
