// volcast case: load a patient case and describe it.
#include <fmt/format.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>

#include "cli.hpp"
#include "commands.hpp"
#include "volcast/assets/case.hpp"
#include "volcast/assets/shared_case.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/render/case_renderer.hpp"
#include "volcast/render/headless_target.hpp"

namespace volcast {

namespace {

// The case's objects at rest, from the front (across the table, +z) and from above, side by side.
void render_case(const Case& c, const std::string& png) {
  const SharedCase shared = to_shared_case(c);
  if (shared.objects.empty()) throw Error("case --render: the case has no meshes to draw");
  constexpr int kSide = 720;
  HeadlessTarget target(2 * kSide, kSide);
  CaseRenderer renderer;
  std::vector<PlacedObject> placed;
  Eigen::Vector3f lo = Eigen::Vector3f::Constant(1e9f), hi = -lo;
  for (const SharedObject& o : shared.objects) {
    placed.push_back({o.rest, 0});
    for (const SharedPart& p : o.parts)
      for (const Eigen::Vector3f& v : p.positions) {
        lo = lo.cwiseMin(o.rest.position + v);
        hi = hi.cwiseMax(o.rest.position + v);
      }
  }
  const Eigen::Vector3f center = (lo + hi) / 2;
  const float radius = std::max(0.05f, (hi - lo).norm() / 2);
  const float distance = radius / std::sin(20.0f * static_cast<float>(M_PI) / 180);
  RenderTarget whole = target.target();
  renderer.clear(whole);
  Lighting light;
  light.point_position = center + Eigen::Vector3f(0, 2 * radius, 2 * radius);
  light.point_range_m = 8 * distance;
  const struct {
    Eigen::Vector3f from, up;
  } views[2] = {{{0, 0, 1}, {0, 1, 0}}, {{0, 1, 0}, {0, 0, -1}}};
  for (int i = 0; i < 2; ++i) {
    ViewCamera camera;
    camera.eye = center + distance * views[i].from;
    camera.target = center;
    camera.up = views[i].up;
    camera.vertical_fov_deg = 40;
    camera.near_m = distance / 20;
    camera.far_m = distance * 4;
    RenderTarget half = whole;
    half.x = i * kSide;
    half.width = kSide;
    renderer.draw(to_view(camera, half.aspect()), half, shared, placed, light);
  }
  ColorImage image;
  target.read_image(image);
  write_color_png(png, image);
  spdlog::info("wrote {} (front, and from above)", png);
}

}  // namespace

int run_case(const CaseArgs& args) {
  CaseLoadOptions options;
  options.max_triangles = args.max_triangles;
  if (!args.json)
    options.progress = [](const std::string& what) { spdlog::info("loading {}", what); };
  const Case c = load_case(args.folder, options);
  if (args.json) {
    std::printf("%s\n", case_json(c).c_str());
  } else {
    std::printf("case '%s': %zu parts, loaded in %.0f ms\n", c.name.c_str(), c.parts.size(),
                c.load_ms);
    if (!c.parts.empty())
      std::printf("  %-22s %-12s %10s %11s %7s  %s\n", "part", "group", "triangles", "volume_ml",
                  "closed", "bbox_mm (size x y z)");
    for (const CasePart& p : c.parts) {
      const Eigen::Vector3f size = p.bbox_mm.size();
      std::printf(
          "  %-22s %-12s %10zu %11.2f %7s  %.0f x %.0f x %.0f%s\n", p.name.c_str(), p.group.c_str(),
          p.mesh.triangles(), p.volume_ml, p.closed ? "yes" : "no", size.x(), size.y(), size.z(),
          p.voxels ? fmt::format("  ({} voxels = {:.2f} ml)", p.voxels, p.voxel_volume_ml).c_str()
                   : "");
    }
    if (c.dicom)
      std::printf(
          "  DICOM: %d slices of %dx%d, spacing %.3f x %.3f x %.3f mm%s\n", c.dicom->slices,
          c.dicom->width, c.dicom->height, c.dicom->spacing_mm.x(), c.dicom->spacing_mm.y(),
          c.dicom->spacing_mm.z(),
          c.dicom->overlay.empty() ? "" : (", overlay '" + c.dicom->overlay_label + "'").c_str());
  }
  if (!args.render.empty()) render_case(c, args.render);
  return 0;
}

void register_case(CLI::App& app, Commands& commands) {
  auto [ca, case_args] = add_command<CaseArgs>(
      app, commands, run_case, "case",
      "Load a patient case (organ meshes, label volumes made into meshes, a DICOM series) and "
      "print its parts and series; the folder serve --case shows in the virtual OR");
  ca->add_option("folder", case_args.folder, "Case folder (case.json optional)")->required();
  ca->add_flag("--json", case_args.json, "Print JSON");
  ca->add_option("--render", case_args.render, "PNG of the case: front and top views");
  ca->add_option("--max-triangles", case_args.max_triangles,
                 "Triangle budget per part made from a label volume")
      ->check(CLI::Range(1000, 5000000))
      ->capture_default_str();
}

}  // namespace volcast
