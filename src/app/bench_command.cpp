// volcast bench: its flags, and which benchmark (volcast/bench/bench.hpp) they pick.
#include "cli.hpp"
#include "commands.hpp"
#include "volcast/bench/bench.hpp"
#include "volcast/core/error.hpp"

namespace volcast {
namespace {

// The benchmark the flags pick (one per run); bench --session --low-latency holds the CPU wake-up
// latency at 0 while it runs.
int run_selected_bench(const BenchArgs& a) {
  if (int(a.server) + int(a.render) + int(a.session) + int(a.record) + int(a.nats) + int(a.voice) +
          int(a.drawing) + int(a.paths) + int(a.quality) >
      1)
    throw Error(
        "bench: --server, --render, --session, --record, --nats, --voice, --drawing, --paths and "
        "--quality are separate runs");
  const auto low_latency = hold_low_latency(a.session && a.low_latency);
  return a.nats      ? run_nats_bench(a)
         : a.server  ? run_server_bench(a)
         : a.render  ? run_render_bench(a)
         : a.session ? run_session_bench(a)
         : a.record  ? run_record_bench(a)
         : a.voice   ? run_voice_bench(a)
         : a.drawing ? run_drawing_bench(a)
         : a.paths   ? run_paths_bench(a)
         : a.quality ? run_quality_bench(a)
                     : run_bench(a);
}

}  // namespace

void register_bench(CLI::App& app, Commands& commands) {
  auto [bn, bench] = add_command<BenchArgs>(
      app, commands, run_selected_bench, "bench",
      "Time the filter chain and the codecs on real recordings (one thread)");
  bn->add_option("--dataset", bench.datasets, "Extra recording or folder (repeat)");
  bn->add_option("--data", bench.data,
                 "Folder with the shared recordings (default ../shared/data)");
  bn->add_option("--json", bench.json, "Write the figures as JSON");
  bn->add_option("--repeats", bench.repeats, "Passes over each set (codecs: a tenth of it)")
      ->capture_default_str();
  bn->add_option("--frames", bench.frames,
                 "Frames of each sequence at most, for a quick look (default: all; the filter "
                 "chain takes 60)")
      ->check(CLI::NonNegativeNumber);
  bn->add_flag("--server", bench.server,
               "Server benchmark instead: 2 and 4 real cameras, 1/4/8/16 receive-only viewers");
  bn->add_option("--server-seconds", bench.server_seconds,
                 "With --server: seconds measured per configuration")
      ->capture_default_str();
  bn->add_option("--server-repeats", bench.server_repeats,
                 "With --server: TCP/TLS pairs run per configuration, interleaved; medians shown")
      ->capture_default_str();
  bn->add_option("--viewers", bench.viewers,
                 "With --server or --nats: viewer counts to run (repeat)");
  bn->add_flag("--nats", bench.nats,
               "Benchmark the stream through a 3-node NATS cluster (nats-server, started here) "
               "and relays to --viewers viewers (default 50), against the site's own server "
               "(--server-seconds each)");
  bn->add_flag("--nats-tls", bench.nats_tls,
               "With --nats: TLS on the links to the cluster's nodes (self-signed, verified)");
  bn->add_option("--relays", bench.relays, "With --nats: relays the viewers are spread over")
      ->capture_default_str();
  bn->add_flag("--session", bench.session,
               "Session benchmark instead: pose round trip, pose rates, camera avatars, server CPU "
               "per participant (--server-seconds each)");
  bn->add_flag("--low-latency", bench.low_latency, "With --session: " + kLowLatencyHelp);
  bn->add_flag("--record", bench.record,
               "Recording benchmark instead: latency and CPU a server-side recorder adds to a "
               "live viewer, MB per minute per camera (--server-seconds, --server-repeats)");
  bn->add_flag("--drawing", bench.drawing,
               "Pointing and drawing on loopback (pointer seen p50/p99, bytes a second of a busy "
               "drawing session) and the OR display's ms a frame against its backdrop alone");
  bn->add_flag("--paths", bench.paths,
               "Impaired paths instead (root: network namespaces): 2 real cameras to a viewer "
               "pinned to the old default tier and one adapting, over 20 Mbit/s, loss and a rate "
               "step (--server-seconds each)");
  bn->add_flag("--voice", bench.voice,
               "Voice benchmark instead: mouth-to-ear latency, concealment, bytes per speaker, "
               "server CPU forwarding 4 talkers to 16 participants (--server-seconds each)");
  bn->add_option("--voice-hold-ms", bench.voice_hold_ms,
                 "With --voice: how long a listener's voice packets may wait for the other "
                 "talkers' to go out in one write (ms; default: the server's, 20)");
  bn->add_flag("--render", bench.render,
               "Render benchmark instead: splats and mesh, 1/2/4 real cameras, mono and stereo");
  bn->add_flag("--quality", bench.quality,
               "View-synthesis quality instead: each camera of a registered site held out in turn "
               "and drawn from the others (splats, mesh, blending); PSNR, SSIM, depth error, "
               "coverage, seam energy, ms per view; side-by-side pictures of the worst camera");
  bn->add_option("--site", bench.site,
                 "With --quality: the registered site config (default: the four real Azure "
                 "Kinects, registered once into out/site-4cam.json)");
  bn->add_option("--pictures", bench.pictures,
                 "With --quality: folder for the pictures (rendered | real | colour error | "
                 "depth error)")
      ->capture_default_str();
  bn->add_option("--render-seconds", bench.render_seconds,
                 "With --render: seconds drawn per configuration (at least 3 frames)")
      ->capture_default_str();
}

}  // namespace volcast
