#pragma once
// The same per-pixel work on the two paths a GPU offers, timed: a fragment shader (the
// rasteriser's path, which every camera pass takes) and a compute shader. A GPU built for compute
// runs pixel shaders on a few of its multiprocessors only -- NVIDIA's H100 and H200 (GH100): "only
// two TPCs [of 66] are graphics-capable (that is, they can run vertex, geometry, and pixel
// shaders)" (NVIDIA, "NVIDIA Hopper Architecture In-Depth", 2022) -- so a draw pass timed there
// says little of a graphics card, and the ratio of the two says how little.
//
//   HeadlessTarget target(16, 16);  // any current OpenGL 4.5 context
//   const ShaderThroughput t = measure_shader_throughput(2160, 2160, 128, 5);
//   // t.fragment_ms / t.compute_ms: how much slower the rasteriser's path runs the same work
#include <cstdint>
#include <vector>

namespace volcast {

/// One measurement (measure_shader_throughput()).
struct ShaderThroughput {
  double fragment_ms = 0;     ///< GPU time of the fragment pass, ms (median; timestamp queries)
  double compute_ms = 0;      ///< GPU time of the compute pass, ms (median)
  bool same_picture = false;  ///< both passes wrote the same RGBA8 picture, byte for byte
};

/// Draws a width x height RGBA8 picture twice: by a fragment shader over one full-screen triangle
/// and by a compute shader in 8 x 8 work groups. Each pixel (x, y) runs `rounds` rounds of the same
/// 32-bit integer hash of its coordinates and stores the hash's four bytes, so both pictures must
/// be equal bit for bit (same_picture says whether they are). Each pass runs `repeats` times; the
/// medians are returned. Rounds set how much arithmetic a pixel costs against writing it: 0 times
/// the fill alone. Needs an OpenGL 4.5 context current on this thread (HeadlessTarget); throws
/// Error starting "shader throughput:" without one, for a side outside 1..8192, rounds outside
/// 0..100000 or repeats outside 1..1000. `picture`, if given, receives the fragment pass's
/// picture: width x height RGBA8, row 0 at y = 0 (the bottom), 4 bytes a pixel.
ShaderThroughput measure_shader_throughput(int width, int height, int rounds, int repeats,
                                           std::vector<uint8_t>* picture = nullptr);

}  // namespace volcast
