#include "volcast/render/shader_throughput.hpp"

#include <algorithm>
#include <string>
#include <utility>
#include <vector>

#include "gl_util.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

constexpr const char* kPass = "shader throughput";

// Both passes' work: `rounds` rounds of a 32-bit integer hash (xor-shift-multiply) of the pixel's
// coordinates, its four bytes as colour (k / 255 stores k exactly in RGBA8).
constexpr const char* kHash = R"(
uniform int rounds;
vec4 pixel_colour(uvec2 p) {
  uint h = p.x * 1973u + p.y * 9277u + 26699u;
  for (int i = 0; i < rounds; ++i) {
    h ^= h >> 15;
    h *= 0x2c1b3c6du;
    h ^= h >> 12;
    h += 0x297a2d39u;
  }
  return vec4(uvec4(h, h >> 8, h >> 16, h >> 24) & 255u) / 255.0;
}
)";

constexpr const char* kVertex = R"(
void main() {  // one triangle over the viewport
  gl_Position = vec4(gl_VertexID == 1 ? 3.0 : -1.0, gl_VertexID == 2 ? 3.0 : -1.0, 0.0, 1.0);
}
)";

constexpr const char* kFragment = R"(
out vec4 colour;
void main() { colour = pixel_colour(uvec2(gl_FragCoord.xy)); }
)";

constexpr const char* kCompute = R"(
layout(local_size_x = 8, local_size_y = 8) in;
layout(rgba8, binding = 0) writeonly uniform image2D picture;
void main() {
  const uvec2 p = gl_GlobalInvocationID.xy;
  if (any(greaterThanEqual(p, uvec2(imageSize(picture))))) return;
  imageStore(picture, ivec2(p), pixel_colour(p));
}
)";

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

// The GL objects of one measurement, deleted however it ends.
struct Objects {
  GLuint draw = 0, compute = 0, vao = 0, fbo = 0, query = 0, textures[2] = {};
  ~Objects() {
    glDeleteProgram(draw);
    glDeleteProgram(compute);
    glDeleteVertexArrays(1, &vao);
    glDeleteFramebuffers(1, &fbo);
    glDeleteQueries(1, &query);
    glDeleteTextures(2, textures);
  }
};

}  // namespace

ShaderThroughput measure_shader_throughput(int width, int height, int rounds, int repeats,
                                           std::vector<uint8_t>* picture) {
  if (width < 1 || width > 8192 || height < 1 || height > 8192)
    throw Error(std::string(kPass) + ": the picture must be 1..8192 pixels a side, not " +
                std::to_string(width) + "x" + std::to_string(height));
  if (rounds < 0 || rounds > 100'000)
    throw Error(std::string(kPass) + ": rounds must be 0..100000, not " + std::to_string(rounds));
  if (repeats < 1 || repeats > 1000)
    throw Error(std::string(kPass) + ": repeats must be 1..1000, not " + std::to_string(repeats));
  gl::require_gl45(kPass);
  Objects o;
  o.draw = gl::link_program(kPass, gl::glsl450(kVertex).c_str(), nullptr,
                            gl::glsl450(std::string(kHash) + kFragment).c_str());
  o.compute = gl::link_compute(kPass, gl::glsl450(std::string(kHash) + kCompute).c_str());
  for (GLuint& t : o.textures) t = gl::make_texture(GL_RGBA8, width, height);
  glCreateVertexArrays(1, &o.vao);
  glCreateFramebuffers(1, &o.fbo);
  glNamedFramebufferTexture(o.fbo, GL_COLOR_ATTACHMENT0, o.textures[0], 0);
  if (glCheckNamedFramebufferStatus(o.fbo, GL_FRAMEBUFFER) != GL_FRAMEBUFFER_COMPLETE)
    throw Error(std::string(kPass) + ": the RGBA8 framebuffer is incomplete");
  glCreateQueries(GL_TIME_ELAPSED, 1, &o.query);
  glProgramUniform1i(o.draw, glGetUniformLocation(o.draw, "rounds"), rounds);
  glProgramUniform1i(o.compute, glGetUniformLocation(o.compute, "rounds"), rounds);

  // Each pass once untimed (the driver compiles on first use), then `repeats` times timed.
  const auto timed = [&](auto&& pass) {
    pass();
    std::vector<double> ms;
    for (int i = 0; i < repeats; ++i) {
      glBeginQuery(GL_TIME_ELAPSED, o.query);
      pass();
      glEndQuery(GL_TIME_ELAPSED);
      GLuint64 ns = 0;
      glGetQueryObjectui64v(o.query, GL_QUERY_RESULT, &ns);  // waits for the pass
      ms.push_back(static_cast<double>(ns) / 1e6);
    }
    return median(std::move(ms));
  };
  ShaderThroughput out;
  glBindFramebuffer(GL_FRAMEBUFFER, o.fbo);
  glViewport(0, 0, width, height);
  glDisable(GL_DEPTH_TEST);
  glDisable(GL_BLEND);
  glDisable(GL_SCISSOR_TEST);
  glUseProgram(o.draw);
  glBindVertexArray(o.vao);
  out.fragment_ms = timed([] { glDrawArrays(GL_TRIANGLES, 0, 3); });
  glUseProgram(o.compute);
  glBindImageTexture(0, o.textures[1], 0, GL_FALSE, 0, GL_WRITE_ONLY, GL_RGBA8);
  const auto groups = [](int n) { return static_cast<GLuint>((n + 7) / 8); };
  out.compute_ms = timed([&] { glDispatchCompute(groups(width), groups(height), 1); });
  glMemoryBarrier(GL_TEXTURE_UPDATE_BARRIER_BIT);
  glBindFramebuffer(GL_FRAMEBUFFER, 0);
  glUseProgram(0);
  glBindVertexArray(0);
  gl::check(kPass, "drawing");

  const size_t bytes = static_cast<size_t>(width) * static_cast<size_t>(height) * 4;
  std::vector<uint8_t> pictures[2];
  for (int k = 0; k < 2; ++k) {
    pictures[k].resize(bytes);
    glGetTextureImage(o.textures[k], 0, GL_RGBA, GL_UNSIGNED_BYTE, static_cast<GLsizei>(bytes),
                      pictures[k].data());
  }
  gl::check(kPass, "reading the pictures back");
  out.same_picture = pictures[0] == pictures[1];
  if (picture) *picture = std::move(pictures[0]);
  return out;
}

}  // namespace volcast
