// The camera pass's options (camera_renderer.hpp): the surfaces' names, and the ranges draw_cameras
// checks before it draws.
#include <fmt/format.h>

#include "volcast/core/error.hpp"
#include "volcast/render/camera_renderer.hpp"

namespace volcast {

const char* to_string(Surface surface) {
  return surface == Surface::kMesh ? "mesh" : "splats";
}

Surface parse_surface(const std::string& name) {
  if (name == "splats" || name == "splat") return Surface::kSplats;
  if (name == "mesh") return Surface::kMesh;
  throw Error("unknown surface '" + name + "' (splats or mesh)");
}

void check_pass_options(const CameraPassOptions& o) {
  if (!(o.fixed_point_px >= 1 && o.fixed_point_px <= 64))
    throw Error(fmt::format("{}: fixed_point_px {} is outside 1..64 pixels", "camera renderer",
                            o.fixed_point_px));
  if (!(o.splat_scale > 0 && o.splat_scale <= 16))
    throw Error(
        fmt::format("{}: splat_scale {} is outside (0, 16]", "camera renderer", o.splat_scale));
  if (!(o.max_edge_ratio > 0))
    throw Error(
        fmt::format("{}: max_edge_ratio {} must be positive", "camera renderer", o.max_edge_ratio));
  if (!(o.blend_depth_m > 0 && o.blend_depth_m <= 1))
    throw Error(fmt::format("{}: blend_depth_m {} is outside (0, 1] metres", "camera renderer",
                            o.blend_depth_m));
  if (!(o.edge_px >= 1 && o.edge_px <= 16))
    throw Error(
        fmt::format("{}: edge_px {} is outside 1..16 pixels", "camera renderer", o.edge_px));
  if (!(o.erode_depth_m >= 0 && o.erode_depth_m <= 1))
    throw Error(fmt::format("{}: erode_depth_m {} is outside [0, 1] metres", "camera renderer",
                            o.erode_depth_m));
}

}  // namespace volcast
