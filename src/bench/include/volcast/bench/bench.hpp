#pragma once
// `volcast bench`: the benchmarks on the real recordings (../shared/data), each printing a table
// and, with BenchArgs::json, writing its figures as JSON. Times in the tables as they say (µs or
// ms); one run at a time (they take every core they are given).
#include <string>
#include <vector>

namespace volcast {

struct BenchArgs {
  std::vector<std::string> datasets;  ///< extra recordings or folders
  std::string json;                   ///< write the figures here as JSON ("": do not)
  std::string data;                   ///< the shared recordings ("": ../shared/data)
  int repeats = 50;
  int frames = 0;             ///< frames of each sequence at most (0: all; the filters take 60)
  bool server = false;        ///< the server benchmark instead of the codec/filter tables
  double server_seconds = 4;  ///< measured per configuration
  int server_repeats = 3;     ///< TCP/TLS pairs per configuration, interleaved (medians reported)
  std::vector<int> viewers;   ///< viewer counts (default 1, 4, 8, 16)
  bool render = false;        ///< the render benchmark instead
  double render_seconds = 1;  ///< drawn per configuration (at least 3 frames)
  bool session = false;       ///< the session benchmark instead (uses server_seconds)
  bool record = false;        ///< the recording benchmark instead (server_seconds, server_repeats)
  bool low_latency = false;   ///< --session: the CLI holds the CPU wake-up latency at 0 meanwhile
  bool nats = false;          ///< the NATS cluster benchmark instead (server_seconds, viewers)
  int relays = 2;             ///< --nats: relays the viewers are spread over
  bool nats_tls = false;      ///< --nats: TLS on the links to the nodes (self-signed, verified)
  bool voice = false;         ///< the voice benchmark instead (server_seconds)
  /// --voice: ServerConfig::stream_coalesce_us in ms, how long a listener's voice packets may
  /// wait for the other talkers' (-1: the server's default)
  double voice_hold_ms = -1;
  bool drawing = false;  ///< the pointing and drawing benchmark instead (server_seconds)
  bool paths = false;    ///< the impaired-paths benchmark instead (server_seconds; root)
  bool quality = false;  ///< the view-synthesis quality benchmark instead
  std::string site;      ///< --quality: the registered site config ("": the four Kinects)
  std::string pictures = "out/quality";  ///< --quality: where its pictures go ("": none)
};
/// Times each filter stage on real frames and every codec (codec_bench.hpp), one thread; prints
/// the tables and writes {"filters", "depth_codecs", "color_codecs"} to args.json if set.
int run_bench(const BenchArgs& args);
/// Runs a server on loopback with the real sets as 2 and 4 cameras and 1..16 receive-only viewers
/// per tier, each over plain TCP and over TLS, `server_repeats` times interleaved; prints a table
/// of medians and writes {"server": [{cameras, viewers, tier, transport, fps_min, latency_ms_p50,
/// latency_ms_p99, server_cpu_percent, server_cpu_percent_runs, send_cpu_percent (the threads
/// serving viewers), send_cpu_percent_runs, tls_over_tcp, tls_over_tcp_runs, send_tls_over_tcp,
/// send_tls_over_tcp_runs}]} to args.json if set (ratios on TLS rows: the median of each pair's).
int run_server_bench(const BenchArgs& args);
/// The stream through a 3-node nats-server cluster (started here, loopback) and `relays` relays to
/// receive-only TLS viewers (args.viewers, default 50), against the same viewers on the site's
/// own server: the real two-camera site at 30 fps, tier volcast/jpeg, then one node killed (relay
/// 0's); with args.nats_tls the site and relays reach the nodes over TLS (a self-signed node
/// certificate, checked by CA and name). Prints a table and writes {"nats": [{viewers, relays,
/// nats_nodes, nats_tls, fps_min,
/// latency_ms_p50, latency_ms_p99, direct_fps_min, direct_latency_ms_p50, direct_latency_ms_p99,
/// node_kill_max_gap_ms, node_kill_viewers_lost}]} to args.json if set. Latency: the site's
/// capture to the viewer's read, one clock.
int run_nats_bench(const BenchArgs& args);
/// Draws the real four-camera set with CameraRenderer, headless: splats and mesh, blended or not,
/// 1/2/4 cameras, 1280x720 mono and 2x2160x2160 stereo; prints a table and writes {"render":
/// [{renderer, blend, cameras, width, height (per eye), eyes, ms_per_frame (median, both eyes),
/// frames_timed, upload_ms, first_draw_after_upload_ms, ms_sum_of_cameras_alone (each camera drawn
/// alone, summed: the linear baseline), gpu}]} to args.json if set.
int run_render_bench(const BenchArgs& args);
/// The virtual OR's sessions on loopback over TLS: 2 participants with the site idle (the session
/// alone), then with the real two-camera site streaming at 30 fps 2 and 8 participants with mesh
/// avatars (idle script, poses at 60 Hz) and 4 participants uploading the hands sequence as camera
/// avatars; prints a table and writes {"session": [{configuration, participants, site_cameras,
/// site_streaming, camera_avatars, session_round_trip_ms_p50, _p99,
/// round_trip_samples, pose_rate_hz_min, pose_age_ms_p50, _p99, avatar_fps_min,
/// avatar_latency_ms_p50, _p99, serving_cpu_percent, serving_cpu_percent_per_participant,
/// site_encode_cpu_percent}]} to args.json if set.
int run_session_bench(const BenchArgs& args);
/// What recording costs a live server: the real two-camera site at 30 fps with one TLS viewer,
/// without a recorder, recording the viewer's tier (shared encoding: only the disk write is new)
/// and recording another tier (one more encoding), `server_repeats` times interleaved; prints
/// viewer latency p50/p99, server CPU, the latency and CPU added against the run without (median
/// of per-repeat differences), MB per minute per camera and frame sets dropped; writes {"record":
/// [{configuration, latency_ms_p50, latency_ms_p99, server_cpu_percent, added_latency_ms_p50,
/// added_server_cpu_percent, recorded_mb_per_minute_per_camera, recorded_frame_sets,
/// recorder_dropped, *_runs}]} to args.json if set.
int run_record_bench(const BenchArgs& args);
/// Voices on loopback over TLS (voice_bench.cpp): real recorded speech from microphone files, one
/// talker to one listener, then 16 participants with 4 talking (the site idle); prints a table and
/// writes {"voice": [{configuration, participants, talkers, mouth_to_ear_ms_p50, _p99,
/// concealed_percent, bytes_per_second_per_speaker, packets_forwarded,
/// server_cpu_percent_of_one_core, server_writes_per_second, voice_hold_ms}]} to args.json if set.
int run_voice_bench(const BenchArgs& args);
/// Pointing and drawing on loopback over TLS (drawing_bench.cpp): a pointer moved at 60 Hz seen by
/// 1 and 3 observers (site idle, then streaming), then a busy drawing session (a stroke every
/// 0.5 s, a label every 2 s); then the OR display of the Kinect recording against its backdrop
/// alone. Prints tables and writes {"drawing": [{configuration, observers, pointers_received,
/// pointer_ms_p50, pointer_ms_p99, bytes_per_second_per_receiver, annotations}], "or_display":
/// {or_display_ms, backdrop_ms, ratio, frames}} to args.json if set.
int run_drawing_bench(const BenchArgs& args);
/// The real two-camera site at 30 fps to one receive-only TLS viewer over impaired paths (network
/// namespaces and the userspace relay of impaired_link.hpp; needs root): unlimited, 20 Mbit/s +
/// 50 ms RTT, 50 ms RTT + 2 % loss, and a step from 100 to 20 Mbit/s; each with a viewer pinned to
/// volcast/jpeg/90 (the old default) and one adapting along the server's ladder. Prints a table
/// and writes {"paths": [{path, viewer ("pinned" | "adaptive"), fps, latency_ms_p50, _p99 (the
/// site's capture to the viewer's read, one clock), recovery_s (step path: from the step to the
/// last frame set over 250 ms; else -1), kib_per_s_per_camera, tiers (in the order used),
/// switches: [{t_s, from, to, reason}]}]} to args.json if set. Throws Error where the link cannot
/// be made (not root, no /dev/net/tun).
int run_paths_bench(const BenchArgs& args);

/// Scores the camera renderer's settings (quality_settings) by leave-one-camera-out view
/// synthesis on args.site, or on the four real Azure Kinects registered from depth (cached in
/// out/site-4cam.json): PSNR, SSIM, depth error, coverage, seam energy and ms per view for each;
/// prints the table, writes the worst camera's side-by-side pictures into args.pictures and
/// {"quality": [...]} (quality_report.hpp) to args.json if set.
int run_quality_bench(const BenchArgs& args);

}  // namespace volcast
