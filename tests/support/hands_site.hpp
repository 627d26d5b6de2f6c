#pragma once
// A test site: the real hands sequence (one camera, nominal intrinsics -- the set has none)
// streamed by a SitePlayer to a Server on a free loopback port. Frame set n carries hands frame
// (n - 1) % 207.
#include <fmt/format.h>

#include <memory>
#include <vector>

#include "support/test_data.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/pipeline/sender.hpp"

namespace volcast::test {

/// The source frame of frame set `sequence` of a HandsSite: hands frame (sequence - 1) % 207.
inline DepthImage hands_source_frame(uint64_t sequence) {
  return read_depth_png(hands_dir() / "depth" / fmt::format("{:05d}.png", (sequence - 1) % 207));
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
