#pragma once
// A test site: the real hands sequence (one camera, nominal intrinsics -- the set has none)
// streamed by a SitePlayer to a Server on a free loopback port. Frame set n carries hands frame
// (n - 1) % 207.
#include <fmt/format.h>

#include <memory>
#include <utility>
#include <vector>

#include "support/test_data.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/pipeline/sender.hpp"

namespace volcast::test {

/// The source frame of frame set `sequence` of a HandsSite: hands frame (sequence - 1) % 207.
inline DepthImage hands_source_frame(uint64_t sequence) {
  return read_depth_png(hands_dir() / "depth" / fmt::format("{:05d}.png", (sequence - 1) % 207));
}

/// How many of the 207 hands frames have invalid depth (0) at a pixel within `radius` (a square)
/// of one of `pixels` ((x, y), 0,0 = top left). A ray through such a pixel rightly meets nothing
/// in that frame (ray_hit.hpp; a mesh leaves a hole there), so a test that aims through a pixel
/// in whichever frame set happens to be drawn first checks that none does.
inline int hands_frames_with_holes_near(const std::vector<std::pair<int, int>>& pixels,
                                        int radius) {
  int frames = 0;
  for (uint64_t sequence = 1; sequence <= 207; ++sequence) {
    const DepthImage depth = hands_source_frame(sequence);
    bool hole = false;
    for (const auto& [x0, y0] : pixels)
      for (int y = y0 - radius; y <= y0 + radius && !hole; ++y)
        for (int x = x0 - radius; x <= x0 + radius && !hole; ++x)
          hole = x < 0 || y < 0 || x >= depth.width || y >= depth.height || depth.at(x, y) == 0;
    frames += hole ? 1 : 0;
  }
  return frames;
}

struct HandsSite {
  SitePlayer player;
  Server server;
  explicit HandsSite(double fps, ServerConfig config = {})
      : player(sources(), fps), server(player.cameras(), with_free_port(config)) {
    player.start(server);
  }
  ~HandsSite() {
    player.stop();
    server.stop();
  }
  static std::vector<std::unique_ptr<FrameSource>> sources() {
    SourceOptions opt;
    opt.intrinsics = Intrinsics{0, 0, 460, 460, 320, 180};
    std::vector<std::unique_ptr<FrameSource>> v;
    v.push_back(open_source(hands_dir(), opt));
    return v;
  }
  static ServerConfig with_free_port(ServerConfig c) {
    c.port = 0;
    return c;
  }
};

}  // namespace volcast::test
