#pragma once
// The volcast subcommands. Each returns the process exit code; errors are thrown as volcast::Error
// and reported by main.
#include <atomic>
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <tuple>
#include <vector>

#include "volcast/calibrate/site_calibration.hpp"
#include "volcast/cluster/nats.hpp"
#include "volcast/codec/tier.hpp"
#include "volcast/core/cpu_latency.hpp"
#include "volcast/filter/chain.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/net/stream/server.hpp"

namespace volcast {

/// With `on`, asks the kernel to keep idle cores awake while the returned request lives (see
/// volcast/core/cpu_latency.hpp) and logs whether it could; null without `on`.
std::unique_ptr<CpuLatencyRequest> hold_low_latency(bool on);

/// Set by SIGINT/SIGTERM; long-running commands stop cleanly when it becomes true.
extern std::atomic<bool> g_interrupted;

/// Filter flags shared by serve, filter, background and bench; they apply to every camera (a site
/// config file can override them per camera).
struct FilterFlags {
  bool undistort = false;
  std::string crop;  ///< "", "nfov" or "x,y,w,h"
  int near_mm = 0, far_mm = 0;
  std::vector<std::string> backgrounds;  ///< learned background per camera, in camera order
  int background_margin_mm = 30;
  bool flying_pixels = false;
  int hole_fill = 0;  ///< iterations, 0 = off
  bool kalman = false;
  /// The configuration for camera `index` (which background file it gets).
  FilterConfig to_config(size_t index) const;
};

struct ServeArgs {
  std::vector<std::string> sources;
  std::string config;  ///< site config JSON: {"cameras": [{"source", "intrinsics", "filters",
                       ///< "name", "world_from_camera"}]} (volcast/io/site_config.hpp)
  FilterFlags filters;
  std::string bind = "127.0.0.1";
  uint16_t port = 7300;
  double fps = 0;          ///< 0 = the recordings' own rate (the fastest source's)
  std::string intrinsics;  ///< "fx,fy,cx,cy" for image sequences without intrinsics.json
  int key_frame_interval = 60;
  int max_viewers = 16;
  int max_window = 8;
  int latency_budget_ms = 150;
  int min_key_interval_ms = 250;
  int max_read_failures = 30;  ///< failed reads in a row that mark a camera failed
  double seconds = 0;          ///< 0 = until interrupted
  bool low_latency = false;    ///< hold the CPU wake-up latency at 0 (cpu_latency.hpp)
  // Security and policy (volcast/net/stream/server.hpp).
  bool insecure = false;           ///< plain TCP, loopback only
  std::string cert, key;           ///< PEM files; default: user_config_dir()/server/*.pem
  std::string token_file;          ///< 32 hex digits; default: a random token per session
  std::string link_host;           ///< host written into the join link; default: found
  std::string link_file;           ///< also write the join link here (mode 0600); "" = no
  std::vector<std::string> tiers;  ///< offered tiers DEPTH/COLOR[/QUALITY]; empty: any
  std::vector<std::string> ladder = default_ladder();  ///< adaptive viewers' tiers, best first
  double tier_cpu_budget = 0;     ///< cores the tiers' encoders may use; 0: half the cores
  int max_tiers_per_address = 4;  ///< tiers one address's viewers may hold alone
  int handshake_timeout_ms = 5000;
  int max_pending = 64;
  int max_pending_per_address = 8;
  // The virtual OR's sessions (volcast/session/hub.hpp).
  std::vector<std::string> sessions{"OR"};  ///< sessions made at start (participants make more)
  std::string room_from_site;               ///< "x,y,z,yaw_deg": the site in the room
  std::string site_name = "OR site";        ///< the OR site participant's display name
  int presence_timeout_ms = 3000;
  std::string case_folder;  ///< the patient case shown in every session (reloaded on change)
  size_t case_max_triangles = 60000;
  // The OR's own voice (volcast/voice/site_voice.hpp).
  std::string mic, speaker;           ///< a .wav file or a sound device; empty: none
  bool no_echo_cancellation = false;  ///< keep the loudspeaker's echo in the microphone
  // Browsers (ServerConfig::web_root).
  bool web = false;      ///< serve the browser viewer and print its https:// link
  std::string web_root;  ///< its folder; default: web_root_default()

  std::string record;                        ///< also record this tier to this .vcr file
  std::string record_tier = "volcast/jpeg";  ///< DEPTH/COLOR[/QUALITY]
  // The stream on a NATS cluster (volcast/cluster/tier_publisher.hpp).
  std::string nats;                                         ///< URL[,URL...]; empty: none
  std::vector<std::string> nats_tiers{"volcast/jpeg"};      ///< DEPTH/COLOR[/QUALITY] each
  std::string nats_site = "or";                             ///< the site's subject token
  std::string nats_user, nats_password_file;                ///< NATS user/password authentication
  std::string nats_ca, nats_tls_name, nats_cert, nats_key;  ///< TLS to the cluster (NatsOptions)
  std::vector<std::string> nats_cameras;          ///< capture nodes whose cameras join this site
  std::string nats_camera_tier = "volcast/jpeg";  ///< the tier capture nodes publish
  int nats_state_replicas = 1;  ///< serve --nats: JetStream replicas of the session state (0: off)
  bool camera_only = false;     ///< a capture node: publish on NATS, no viewers
  std::string relay_tier = "volcast/jpeg";  ///< relay: the published tier taken from NATS
  int welcome_timeout_ms = 10000;           ///< relay: wait this long for the site's Welcome
  std::string relay_name;         ///< relay: its session subject token (empty: a random one)
  bool relay_no_session = false;  ///< relay: no session forwarding
  double from_s = 0, to_s = -1;   ///< a .vcr source: the part replayed (seconds in)
  bool no_loop = false;           ///< a .vcr source: play it once, then stop
};
int run_serve(const ServeArgs& args);
/// `volcast relay`: a site's stream from NATS (--nats, --site, --tier) served to viewers with
/// serve's server flags (cluster/relay.hpp).
int run_relay(const ServeArgs& args);
/// The server's configuration from the flags serve, replay and relay share: address, pacing,
/// TLS identity (made on first run), join token, policy limits, the browser page; warns when
/// bound beyond loopback. Throws Error for --cert without --key or unreadable files.
ServerConfig server_config(const ServeArgs& a);
/// The host for the join link: --link-host, else the bind address, else (bound to all
/// addresses) this host's first non-loopback address.
std::string link_host(const ServeArgs& a);
/// With --link-file: writes `link` and a newline there, mode 0600, replacing the file at once
/// (a reader never sees half a link), for `view --connect-file`. Throws Error naming the file.
void write_link_file(const ServeArgs& a, const std::string& link);
/// The NATS connection of --nats, --nats-user and --nats-password-file, named `name` in the
/// cluster's monitoring. Throws Error for an empty URL list or an unreadable password file.
cluster::NatsOptions nats_options(const ServeArgs& a, const std::string& name);
/// The browser viewer's page as the build or the install put it: share/volcast/web beside the
/// executable (build/PRESET/share/volcast/web), else ../share/volcast/web from it. Throws Error
/// naming both when neither holds an index.html.
std::filesystem::path web_root_default();

struct ViewArgs {
  std::string connect;        ///< join link volcast://..., HOST:PORT, or "-" (standard input)
  std::string connect_file;   ///< a file holding the join link (instead of --connect)
  std::string token;          ///< with HOST:PORT: the join token
  std::string fingerprint;    ///< with HOST:PORT: the server certificate's SHA-256 (else pinned)
  std::string known_servers;  ///< pin store; default user_config_dir()/known_servers
  bool insecure = false;      ///< plain TCP, loopback only
  int connect_timeout_ms = 5000;
  Tier tier{"volcast", "jpeg"};  ///< --depth-codec, --color-codec, --color-quality
  bool tier_pinned = false;  ///< --depth-codec, --color-codec or --color-quality given: no adapting
  std::vector<std::string> floors;  ///< --floor: lossless | full-rate
  std::string max_rate;             ///< --max-rate, e.g. "20M" (bits/s); empty: no cap
  bool no_render = false;
  bool headless = false;         ///< render offscreen (EGL) instead of opening the desktop window
  bool xr = false;               ///< try OpenXR first (falls back to the window, then headless)
  std::string surface = "mesh";  ///< CameraPassOptions::surface: splats | mesh
  std::string splat_size = "adaptive";  ///< fixed | footprint | adaptive
  float point_size = 2;                 ///< fixed splats: pixels
  float splat_scale = 1;                ///< footprint and adaptive splats: x the pixel footprint
  float edge_ratio = 0.05f;             ///< mesh: CameraPassOptions::max_edge_ratio
  std::string blend = "auto";           ///< BlendPolicy: auto | on | off (frame_budget.hpp)
  double frame_ms = 0;                  ///< window: the display period; 0: the monitor's
  std::string site_config;              ///< where the window's Save writes camera poses
  int frames = 0;
  double seconds = 0;
  std::string screenshot, save_frames, stats_json;
  std::string size = "1280x720";  ///< window or headless render size
  std::string eye, target;
  std::string keep_within;          ///< avatar filter: "x,y,z,radius" (metres, world frame)
  std::string hide_headset;         ///< avatar filter: "x,y,z[,yaw_degrees]" (metres, world frame)
  bool low_latency = false;         ///< hold the CPU wake-up latency at 0 (cpu_latency.hpp)
  int handshake_timeout_ms = 5000;  ///< ClientConfig::handshake_timeout_ms
  int receive_timeout_ms =
      2000;                      ///< ClientConfig::receive_timeout_ms: a silence this long is a cut
  bool no_reconnect = false;     ///< end on a cut instead of reconnecting (ViewerOptions)
  double give_up_after_s = 300;  ///< ViewerOptions::reconnect_give_up_s
  // Joining the virtual OR as a participant (volcast/session/participant.hpp).
  std::string join;                      ///< session name; empty: a plain viewer
  std::string name;                      ///< display name in the session
  int or_display = -1;                   ///< >= 0: draw the OR display of this site camera
  bool fullscreen = false;               ///< the OR display's window starts full screen
  std::string camera;                    ///< own RGB-D camera source: a camera avatar
  std::string camera_pose;               ///< "x,y,z,rx,ry,rz": playarea_from_camera (m, deg)
  std::string camera_intrinsics;         ///< "fx,fy,cx,cy" for a camera source without any
  std::string upload_codec = "volcast";  ///< the avatar's depth codec (lossless)
  std::string upload_color = "jpeg";     ///< the avatar's color codec
  // Voice (volcast/voice/voice_link.hpp): a .wav file or a sound device each; empty: none.
  std::string mic, speaker;
  bool mute = false;                 ///< start with the microphone muted
  bool push_to_talk = false;         ///< send only while V (window) or X (headset) is held
  std::vector<std::string> volumes;  ///< "NAME=GAIN" per participant
  bool mono_voices = false;          ///< a mono mix instead of HRTF (one channel)
  std::string voice_json;            ///< write what was heard (latency, loss) here
  std::string pose_script;           ///< JSON pose script; default: standing, idle sway
  double pose_rate = 60;             ///< poses published per second
  float avatar_radius = 0.6f;        ///< the others' camera avatars: metres around their head
  bool no_room = false;              ///< do not draw the room's furniture
};
/// Renders into the desktop window by default (headless when there is no display, with one line
/// saying so), OpenXR with --xr (the window when no runtime is available), offscreen with
/// --headless. Returns 0 when frame sets arrived and the session ended normally (--frames or
/// --seconds reached, interrupted, the window closed, the server closed); throws Error (main:
/// exit 1) when none arrived or it ended on an error, after printing the table and writing
/// --stats-json.
int run_view(const ViewArgs& args);

struct FilterArgs {
  std::string source;
  std::string out = "out/filter";
  std::string intrinsics;
  int frames = 0;  ///< 0 = one pass of the recording (at most 300)
  FilterFlags filters;
};
/// Runs the filter chain over a recording, writes before/after false-colour PNGs and quality.json.
int run_filter(const FilterArgs& args);

struct BackgroundArgs {
  std::string source;
  std::string out;
  std::string intrinsics;
  int frames = 30;
  FilterFlags filters;  ///< lens correction and crop must match what serve will use
};
/// Learns a background model (per-pixel minimum) from frames of the empty room.
int run_background(const BackgroundArgs& args);

struct CalibrateArgs {
  CalibrationOptions options;     ///< the procedure's flags
  std::string out = "site.json";  ///< the site config to write
  std::string preview;            ///< PNG: the registered clouds from above and the side
};
/// Registers the cameras (volcast/calibrate/site_calibration.hpp: target, then targetless), aligns
/// the floor, prints the residuals and writes the site config (and a preview). Exit code 0 when
/// every camera was placed, 3 when some were not (the file is written with the others; each
/// problem is printed naming its camera).
int run_calibrate(const CalibrateArgs& args);

struct CaseArgs {
  std::string folder;            ///< the case folder (volcast/assets/case.hpp)
  bool json = false;             ///< print JSON instead of a table
  std::string render;            ///< PNG: the case's parts from the front and from above
  size_t max_triangles = 60000;  ///< per part made from labels
};
/// Loads a case and prints its parts (name, triangles, volume, bounding box; one per connected
/// tumour) and DICOM series (slices, spacing), with the load time; renders it with --render.
int run_case(const CaseArgs& args);

struct InfoArgs {
  std::string file;
  bool json = false;
};
/// Describes an Azure Kinect recording, an image sequence or a Volcast recording (.vcr: cameras,
/// tier, frame sets, key frame sets, duration, size, whether it was closed or where its
/// incomplete tail begins; every record's CRC checked).
int run_info(const InfoArgs& args);
/// The .vcr half of run_info (record_commands.cpp).
int run_recording_info(const InfoArgs& args);

/// The client settings for reaching a server from --connect (a join link, or HOST:PORT with
/// --token and maybe --fingerprint; "-": the link on standard input) or --connect-file (a file
/// holding the link: its first line that is neither empty nor a '#' comment; at most 4 KiB; a
/// warning if other users may read it), --insecure and --known-servers. Reading the link from a
/// file or standard input keeps its token out of /proc/PID/cmdline, which every local user can
/// read. Throws Error naming the command and the flag (or file) at fault.
ClientConfig connect_client_config(const std::string& command, const std::string& connect,
                                   const std::string& connect_file, const std::string& token,
                                   const std::string& fingerprint, bool insecure,
                                   const std::string& known_servers);

struct RecordArgs {
  std::string connect, connect_file, token, fingerprint, known_servers;
  bool insecure = false;
  std::string out;
  std::string tier = "volcast/jpeg";  ///< DEPTH/COLOR[/QUALITY]
  double seconds = 0;                 ///< 0 = until interrupted or the server ends
  bool overwrite = false;
  int sync_interval_ms = 1000;
  /// Also join this session as a listener ("Recorder", seen by everyone in it) and record every
  /// voice in it; empty: the stream only.
  std::string session;
};
/// Connects as a receive-only viewer of one tier and appends every frame set it is sent to a
/// recording (volcast/record/recording.hpp), showing frame sets, size and rate on the terminal.
/// Returns 0 when it stopped on time, on Ctrl-C or when the server ended; throws Error (what was
/// written stays and replays) on a full disk or a broken stream.
int run_record(const RecordArgs& args);

struct ExportArgs {
  std::string file;
  std::string ply, png;     ///< output folders
  std::string mkv;          ///< Azure Kinect-style Matroska (volcast/pipeline/export.hpp)
  std::string wav;          ///< folder: one WAV per speaker (volcast/voice/voice_export.hpp)
  std::string annotations;  ///< JSON file (volcast/pipeline/annotation_export.hpp)
  double from_s = 0, to_s = -1;
};
/// Decodes a recording and writes, per frame set and camera, a binary PLY (valid depth pixels as
/// points in the world frame, metres, with color), depth and color PNGs, and/or a Matroska file
/// per camera in the Azure Kinect recording layout (at least one of them).
int run_export(const ExportArgs& args);

}  // namespace volcast
