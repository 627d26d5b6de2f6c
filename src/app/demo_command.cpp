// volcast demo: its flags (volcast/demo/demo.hpp runs it).
#include "cli.hpp"
#include "commands.hpp"
#include "volcast/codec/color_codec.hpp"
#include "volcast/codec/depth_codec.hpp"
#include "volcast/codec/registry.hpp"
#include "volcast/demo/demo.hpp"

namespace volcast {
namespace {

// --low-latency holds the CPU wake-up latency at 0 for the whole demo.
int run_demo_with_flags(const DemoArgs& a) {
  const auto low_latency = hold_low_latency(a.low_latency);
  return run_demo(a);
}

}  // namespace

void register_demo(CLI::App& app, Commands& commands) {
  auto [d, demo] =
      add_command<DemoArgs>(app, commands, run_demo_with_flags, "demo",
                            "Stream the shared real recordings on loopback, render and report");
  d->add_option("--seconds", demo.seconds, "How long the viewer receives")->capture_default_str();
  d->add_option("--out", demo.out, "Folder for stats.json and PNG renders")->capture_default_str();
  d->add_option("--data", demo.data, "Folder with the real recordings (default: ../shared/data)");
  DemoArgs* const pinned = &demo;  // a lambda may not capture a structured binding (clang 14)
  const auto pin = [pinned](const std::string&) { pinned->tier_pinned = true; };
  d->add_option("--depth-codec", demo.tier.depth_codec,
                "Depth codec, pinning the viewer's tier (without it, the server moves the viewer "
                "along its tier ladder as the path allows): " +
                    depth_codec_help())
      ->each(pin);
  d->add_option("--color-codec", demo.tier.color_codec,
                "Color codec, pinning the viewer's tier: " + color_codec_help())
      ->each(pin);
  d->add_flag("--no-session", demo.no_session,
              "Skip the virtual-OR session (the registered OR cameras, two scripted participants)");
  d->add_option("--session-seconds", demo.session_seconds,
                "How long the session part runs at least (then until it settled, a minute more "
                "at most)")
      ->capture_default_str();
  d->add_option("--session-fps", demo.session_fps,
                "Frame sets a second of the session part's OR site (its cameras' one capture each)")
      ->check(CLI::Range(1.0, 60.0))
      ->capture_default_str();
  d->add_option("--cameras", demo.cameras,
                "2: the hands sequence and the Azure Kinect recording; 4: the four Azure Kinects")
      ->check(CLI::IsMember({2, 4}))
      ->capture_default_str();
  d->add_flag("--no-render", demo.no_render,
              "Render the PNGs only at the end, not while streaming (latency without a GPU)");
  d->add_flag("--low-latency", demo.low_latency, kLowLatencyHelp);
  demo.stop = &g_interrupted;
}

}  // namespace volcast
