#pragma once
// Depth codecs, picked by name (the table of names, their guarantees and factories is in
// registry.hpp). This comment is the wire format, complete enough to write a decoder from.
//
// ## Frame header (12 bytes; every multi-byte field of every format here is little-endian)
//   byte 0-1  'V' 'D'
//   byte 2    format version, 2; decoders refuse any other
//   byte 3    codec id: 0 raw, 1 rvl, 2 trvl, 3 zstd, 4 lz4, 5 volcast (all volcast-* names),
//             6 h264, 7 hevc; a decoder refuses a frame of another codec id
//   byte 4    flags: bit 0 = key frame (decodes on its own); other bits written 0, ignored
//   byte 5    volcast: near-lossless bound N in mm (0 = lossless; decoders refuse N > 16);
//             h264 / hevc: the video's bit depth (10 / 12; checked); others write 0, unread
//   byte 6    volcast: stream kind, 0 = spatial (key frames only), 1 = temporal (delta frames
//             may follow; volcast-t); decoders refuse > 1. Others write 0, unread
//   byte 7    volcast: frame number mod 256, +1 on every frame the encoder emits (key or delta,
//             spatial streams too); a delta frame must carry the number of the last frame
//             decoded + 1, so a lost frame is detected. Others write 0, unread
//   byte 8-9  width u16, byte 10-11 height u16: each 1..8192 (decoders refuse others)
// followed by the body. Pixels are in raster order (row by row, left to right), n = w * h;
// depth is uint16 mm, 0 = invalid.
//
// ## Shared pieces
// zigzag(d) = (d << 1) ^ (d >> 31) on int32 (0, -1, 1, -2 -> 0, 1, 2, 3); unzigzag(u) =
// (u >> 1) ^ -(u & 1).
// Nibble code (rvl, trvl): a value is written 3 bits at a time, least significant group first,
// each group in a 4-bit nibble with bit 3 set while more groups follow (at most 11 nibbles).
// Nibbles fill 32-bit words from the most significant end (first nibble = bits 31-28); words are
// stored little-endian; the last word is padded with zero nibbles. The body is a whole number of
// words (decoders refuse others); words after the last pixel are ignored.
//
// ## raw (id 0; lossless; always a key frame)
// n uint16 samples. The body must be exactly 2n bytes.
//
// ## rvl (id 1; lossless; always a key frame) - A. D. Wilson, "Fast Lossless Depth Image
// Compression", ISS 2017, with 32-bit deltas so every uint16 value round-trips.
// Nibble-coded values, repeated until n pixels are filled: Z (a run of Z invalid pixels), V (a run
// of V valid pixels), then V values zigzag(v - previous), previous being the last valid value
// decoded (0 at the start of the frame, carried across runs and rows); every decoded v must be
// 1..65535. Z = V = 0 before the last pixel is corrupt. The encoder always writes the pair, so a
// frame ending in invalid pixels ends with (Z, 0).
//
// ## trvl (id 2; lossless; temporal) - H. Jun, J. Bailenson, "Temporal RVL", ISMAR 2020.
// Key frames: an rvl body. Delta frames (refused without a key frame before them, or at another
// size): against the frame the decoder holds (the last decoded), repeated until n pixels:
// S (S pixels keep their held value), C (C changed pixels), then C nibble-coded
// zigzag(new - held) of those pixels, each result 0..65535 (0: the pixel became invalid).
// make_trvl_encoder() with thresholds above 0 writes the same format (lossy: what the decoder holds
// is what it gets).
//
// ## zstd (id 3), lz4 (id 4) (lossless; always key frames)
// The body decompresses to exactly 2n bytes: zstd, one Zstandard frame (level 1); lz4, one LZ4
// block (LZ4_compress_default: the raw block format, no LZ4 frame header). The 2n bytes are two
// planes L[0..n) then H[0..n); pixel i = (ref + unzigzag16(L[i] | H[i] << 8)) mod 2^16, where ref
// = 0 for pixel 0, the pixel above for the first pixel of a row (x = 0, y > 0), else the pixel to
// the left; unzigzag16(z) = (z >> 1) ^ (0 - (z & 1)) in 16 bits.
//
// ## volcast (id 5): volcast (lossless), volcast-t (lossless, temporal), volcast-n1/n2/n4
// (every valid pixel within 1, 2 or 4 mm; which pixels are valid is exact)
// One decoder decodes every variant (bytes 5-7 say which). The body codes an "exact image" E
// losslessly: the depth itself when N = 0; else q = ceil(d / (2N + 1)) per pixel (0 stays 0), and
// the decoder outputs d' = (q == 0 ? 0 : min(q * (2N + 1) - N, 65535)), within N of d.
// Body:
//   delta frames only: block modes, 1 bit per 16x16 block (B = ceil(w/16) * ceil(h/16) blocks,
//     row-major; block b is bit b % 8 of byte b / 8), ceil(B / 8) bytes; 1 = temporal block
//   u32 T, then T bytes of tables: for each context c = 0..C-1 (C = 11 in key frames, 19 in delta
//     frames): a u64 mask of the symbols 0..63 present; then, for each present symbol in
//     increasing order, its frequency f >= 1 as a varint (7 bits per byte, low bits first, bit 7 =
//     more; at most 3 bytes). A context's frequencies sum to exactly 2048; start(s) = sum of the
//     frequencies of the present symbols below s. An encoder gives every context it uses a
//     non-empty mask (this decoder refuses a symbol in an empty context 8, 9 or 10). In pixel
//     contexts (all but 9 and 10) symbols above 41 are refused.
//   u32 R (even, >= 16), then R bytes of rANS data: four u32 initial states (lanes 0..3), each in
//     [2^15, 2^31), then 16-bit words, read forward. Reading past the R bytes is corrupt.
//   the rest: the raw bit stream, read from the first byte on, least significant bit first.
// Symbols: the k-th symbol of a frame (run lengths and pixels alike, in the scan order below)
// is decoded on lane k % 4, with that lane's state x: slot = x & 2047; s = the symbol with
// start(s) <= slot < start(s) + f(s) in the symbol's context; x = f(s) * (x >> 11) + slot -
// start(s); if x < 2^15, x = (x << 16) | the next word. Symbol -> value u: s < 16: u = s; else
// k = (s - 16) / 2 + 4, u = 2^k | ((s - 16) & 1) << (k - 1) | (the next k - 1 raw bits, the
// first bit read the least significant).
// Contexts: 0-7 spatial activity levels, 8 border, 9 invalid-run lengths, 10 valid-run lengths,
// 11-18 temporal activity levels 0-7 (delta frames only).
// Scan, repeated until n pixels are filled: Z = value in context 9 (Z invalid pixels), V = value
// in context 10 (Z = V = 0 before the last pixel is corrupt); then the V valid pixels in raster
// order, split into row segments at row ends. `last` = the last valid value decoded in this frame
// (0 at its start). Decoded values must stay 0..65535.
//  - The first pixel of a segment, (x0, y): context 8; prediction = in a delta frame, if its block
//    is temporal and the previous frame's E at (x0, y) is valid, that value; else N if valid, else
//    NW if valid (x0 > 0), else NE if valid (x0 + 1 < w), else `last`.
//  - Every other pixel x (its left neighbour W is valid): value = pred(x) + unzigzag(u), u read in
//    context ctx(x). With N, NW, NE the row above in E (all 0 for row 0; out of the image = 0):
//      pred(x) = min(max(N, W - down), W + up), where N valid and NW valid: down = max(NW - N, 0),
//        up = max(N - NW, 0) (LOCO-I's median edge detector, median(W, N, W + N - NW)); N valid
//        and NW invalid: pred = N; N invalid: pred = W.
//      ctx(x) = 8 for x = 0, x = w - 1, or if any of N, NW, NE is 0; else the level of
//        a = min(|N - NW|, 65) + min(|NE - N|, 65): the number of thresholds 1, 3, 5, 9, 17, 33,
//        65 that a reaches (0-7).
//    In delta frames, where the block is temporal and P = the previous frame's E at (x, y) is
//    valid: pred(x) = P, ctx(x) = 11 + the level of min(|N - PN|, 65) + min(|NE - PNE|, 65) (PN,
//    PNE: the previous frame's E above; at x = w - 1, NE = N and PNE = PN), or 11 + 7 if any of
//    N, PN, NE, PNE is 0 (at x = w - 1 too, in place of the border context).
// Delta frames (byte 4 bit 0 clear) need byte 6 = 1, the previous frame of the stream decoded
// (its E is the reference), the same size and N, and byte 7 = that frame's byte 7 + 1 mod 256;
// a decoder refuses them otherwise, and after any failed frame until the next key frame.
//
// ## h264 (id 6), hevc (id 7): lossy, temporal; in volcast_codec_video (libavcodec), whose
// header volcast/codec_video/video_codecs.hpp documents their body.
//
// All codecs but volcast-n*, h264 and hevc are bit-exact on every 16-bit value. Encoders are
// stateful (temporal codecs keep the last frame they emitted); one encoder per receiver, so a
// receiver that misses frames the encoder never produced still decodes the next delta frame.
#include <cstdint>
#include <memory>
#include <span>
#include <string>
#include <string_view>
#include <vector>

#include "volcast/core/image.hpp"

namespace volcast {

inline constexpr size_t kDepthHeaderBytes = 12;

class DepthEncoder {
 public:
  virtual ~DepthEncoder() = default;
  /// Encodes `depth` into `out` (resized; capacity reused across calls). `key_frame` forces a
  /// frame that decodes on its own; stateful codecs also emit one on their first frame or when the
  /// size changes. Returns true if the emitted frame is a key frame.
  virtual bool encode(const DepthImage& depth, bool key_frame, std::vector<uint8_t>& out) = 0;
  virtual std::string_view name() const = 0;
};

class DepthDecoder {
 public:
  virtual ~DepthDecoder() = default;
  /// Decodes one frame into `out` (resized, reused). Throws Error naming the problem for a
  /// truncated or corrupt stream, a stream of another codec, or a delta frame without its key
  /// frame; never reads or writes out of bounds.
  virtual void decode(std::span<const uint8_t> data, DepthImage& out) = 0;
};

/// Parameters of temporal RVL; the defaults are lossless. The paper's lossy setting is
/// change_threshold_mm = 10, invalidation_frames = 2.
struct TrvlParams {
  int change_threshold_mm = 0;  ///< changes of at most this many mm keep the previous value
  int invalidation_frames = 0;  ///< a pixel turning invalid keeps its value for this many frames
};

/// Names of the registered depth codecs (registry.hpp), in registration order: raw, rvl, trvl,
/// zstd, lz4, volcast, volcast-t, volcast-n1, volcast-n2, volcast-n4, then h264 and hevc once
/// volcast_codec_video's register_video_codecs() has run.
std::vector<std::string> depth_codec_names();
/// A registered codec's encoder / decoder; throws Error("unknown depth codec 'x' (available:
/// ...)").
std::unique_ptr<DepthEncoder> make_depth_encoder(std::string_view name);
std::unique_ptr<DepthDecoder> make_depth_decoder(std::string_view name);

/// Temporal RVL with the given thresholds (the registry's "trvl" is the lossless default).
std::unique_ptr<DepthEncoder> make_trvl_encoder(const TrvlParams& params);

/// Reads the header: true if `data` is a key frame. Throws Error if the header is malformed.
bool depth_frame_is_key(std::span<const uint8_t> data);

}  // namespace volcast
