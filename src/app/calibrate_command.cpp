// volcast calibrate: its flags into CalibrationOptions, then the procedure and its report
// (volcast/calibrate/site_calibration.hpp).
#include "cli.hpp"
#include "commands.hpp"

namespace volcast {

int run_calibrate(const CalibrateArgs& a) {
  return report_calibration(calibrate_site(a.options), a.out, a.preview);
}

void register_calibrate(CLI::App& app, Commands& commands) {
  auto [c, args] = add_command<CalibrateArgs>(
      app, commands, run_calibrate, "calibrate",
      "Place the cameras to each other and to the room from depth alone (lattice target where "
      "seen, else ICP over their overlap); print residuals, write a site config");
  CalibrationOptions& calibrate = args.options;
  c->add_option("--source", calibrate.sources,
                "Camera: Azure Kinect .mkv, image-sequence folder, or depth.<serial>-*.png; a "
                "folder of depth.<serial>-*.png files is one camera per serial (repeat)")
      ->required();
  c->add_option("--out", args.out, "Site config to write (serve --config, view --site-config)")
      ->capture_default_str();
  c->add_option("--preview", args.preview,
                "PNG of the registered cameras from above and from the side, one tint each");
  c->add_option("--intrinsics-from", calibrate.intrinsics_from,
                "Intrinsics for a camera folder's PNGs: an Azure Kinect .mkv (factory "
                "calibration) or image-sequence folder (default: the shared Azure Kinect "
                "recording's, as NOMINAL intrinsics)");
  c->add_option("--start", calibrate.start,
                "Site config with rough poses (within ~20 cm / 10 deg, e.g. saved from the "
                "viewer's sliders): ICP starts there instead of searching features");
  c->add_option("--reference", calibrate.reference,
                "Camera whose frame is the site's before the floor is found")
      ->capture_default_str();
  c->add_flag("--reference-target", calibrate.reference_target,
              "The target's first placement defines the world instead of a camera");
  c->add_option("--frames", calibrate.frames, "Frame sets to scan for the target")
      ->check(CLI::Range(1, 100000))
      ->capture_default_str();
  c->add_flag("--no-target", calibrate.no_target, "Do not look for the lattice target");
  c->add_flag("--refine", calibrate.refine,
              "Also refine target-placed cameras by ICP over the overlap");
  c->add_flag("--no-floor", calibrate.no_floor,
              "Keep the reference camera's frame; do not put the floor at y = 0");
}

}  // namespace volcast
