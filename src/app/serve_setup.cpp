// The settings serve, replay and relay share: the server's configuration from their flags, the join
// link's host and file, the NATS connection; the interrupt flag and --low-latency of every command.
#include <arpa/inet.h>
#include <ifaddrs.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <fstream>

#include "commands.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/private_file.hpp"
#include "volcast/filter/filters.hpp"
#include "volcast/net/transport/tls.hpp"

namespace volcast {

std::atomic<bool> g_interrupted{false};

FilterConfig FilterFlags::to_config(size_t index) const {
  FilterConfig c;
  c.undistort = undistort;
  if (!crop.empty()) c.crop = parse_crop(crop);
  if (near_mm < 0 || near_mm > 65535 || far_mm < 0 || far_mm > 65535)
    throw Error("--near/--far must be 0..65535 mm");
  c.near_mm = static_cast<uint16_t>(near_mm);
  c.far_mm = static_cast<uint16_t>(far_mm);
  if (index < backgrounds.size()) c.background_file = backgrounds[index];
  c.background_margin_mm = static_cast<uint16_t>(std::clamp(background_margin_mm, 0, 65535));
  if (flying_pixels) c.flying_pixels = FlyingPixelFilter{};
  if (hole_fill > 0) {
    c.hole_filling = HoleFiller{};
    c.hole_filling->iterations = hole_fill;
  }
  if (kalman) c.kalman = KalmanFilter{};
  return c;
}

// The server's security settings from the flags: TLS identity (made on first run), join token,
// policy limits. Logs where the identity comes from.
static void apply_security(const ServeArgs& a, ServerConfig& config) {
  config.insecure = a.insecure;
  if (!a.insecure) {
    if (a.cert.empty() != a.key.empty()) throw Error("serve: --cert and --key go together");
    if (!a.cert.empty()) {
      config.identity = load_identity(a.cert, a.key);
    } else {
      const auto dir = user_config_dir() / "server";
      bool created = false;
      config.identity = load_or_create_identity(dir, &created);
      if (created)
        spdlog::info("made a self-signed TLS certificate in {} (kept for later runs)",
                     dir.string());
    }
  }
  if (!a.token_file.empty()) config.token = read_token_file(a.token_file);
  config.offered_tiers = a.tiers;
  config.ladder =
      a.ladder == std::vector<std::string>{"none"} ? std::vector<std::string>{} : a.ladder;
  config.tier_cpu_budget = a.tier_cpu_budget;
  config.max_tiers_per_address = a.max_tiers_per_address;
  config.handshake_timeout_ms = a.handshake_timeout_ms;
  config.max_pending = a.max_pending;
  config.max_pending_per_address = a.max_pending_per_address;
  if (a.web || !a.web_root.empty())
    config.web_root = a.web_root.empty() ? web_root_default() : std::filesystem::path(a.web_root);
}

void write_link_file(const ServeArgs& a, const std::string& link) {
  if (a.link_file.empty()) return;
  const std::filesystem::path file(a.link_file), temporary(a.link_file + ".tmp");
  write_private_file(temporary, link + "\n");
  std::error_code ec;
  std::filesystem::rename(temporary, file, ec);
  if (ec) throw Error("--link-file: cannot write '" + a.link_file + "': " + ec.message());
}

// The host for the join link: --link-host, else the bind address, else (bound to all addresses)
// this host's first non-loopback address.
std::string link_host(const ServeArgs& a) {
  if (!a.link_host.empty()) return a.link_host;
  const std::string bound = resolve_bind_address(a.bind);
  if (bound != "0.0.0.0" && bound != "::") return a.bind;
  ifaddrs* list = nullptr;
  std::string found = "HOST";
  if (::getifaddrs(&list) == 0) {
    for (ifaddrs* i = list; i; i = i->ifa_next) {
      if (!i->ifa_addr || i->ifa_addr->sa_family != AF_INET) continue;
      char text[INET_ADDRSTRLEN];
      const auto* in = reinterpret_cast<const sockaddr_in*>(i->ifa_addr);
      if (!inet_ntop(AF_INET, &in->sin_addr, text, sizeof text)) continue;
      if (std::string(text).starts_with("127.")) continue;
      found = text;
      break;
    }
    ::freeifaddrs(list);
  }
  return found;
}

ServerConfig server_config(const ServeArgs& a) {
  ServerConfig config;
  if (a.camera_only) {  // no viewers: the server only feeds the NATS publisher's taps
    if (a.web || a.insecure || a.port != ServeArgs{}.port || a.bind != ServeArgs{}.bind)
      throw Error(
          "serve: a capture node (--camera-only) has no viewers: drop --web, --insecure, "
          "--port and --bind");
    config.insecure = true;
    config.bind_address = "127.0.0.1";
    config.port = 0;
    return config;
  }
  apply_security(a, config);
  config.bind_address = a.bind;
  config.port = a.port;
  config.key_frame_interval = a.key_frame_interval;
  config.max_viewers = a.max_viewers;
  config.max_window = a.max_window;
  config.latency_budget_ms = a.latency_budget_ms;
  config.min_key_interval_ms = a.min_key_interval_ms;
  if (!is_loopback_address(a.bind))
    spdlog::warn(
        "listening on {} beyond this host: anyone who can reach it can try to join; only "
        "holders of the join link get in",
        a.bind);
  return config;
}

std::filesystem::path web_root_default() {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path exe_dir = fs::read_symlink("/proc/self/exe", ec).parent_path();
  // The build tree (build/PRESET/volcast), then an install (bin/volcast).
  const fs::path built = exe_dir / "share/volcast/web",
                 installed = exe_dir / "../share/volcast/web";
  for (const fs::path& p : {built, installed})
    if (!ec && fs::exists(p / "index.html", ec)) return fs::weakly_canonical(p);
  throw Error("the browser viewer is not built: no index.html in " + built.string() + " or " +
              installed.string() +
              " (it needs Debian's emscripten: bash scripts/install-deps.sh, then build again; or "
              "pass --web-root)");
}

std::unique_ptr<CpuLatencyRequest> hold_low_latency(bool on) {
  if (!on) return nullptr;
  auto request = std::make_unique<CpuLatencyRequest>(0);
  if (request->active())
    spdlog::info("--low-latency: idle cores kept awake (CPU wake-up latency held at 0 us)");
  else
    spdlog::warn("--low-latency has no effect: {}", request->error());
  return request;
}

// The first line of `path` (a password file), without its line end. Throws Error naming `flag`.
static std::string read_first_line(const std::string& path, const char* flag) {
  std::ifstream in(path);
  std::string line;
  if (path.empty() || !in || !std::getline(in, line) || line.empty())
    throw Error(std::string(flag) + ": cannot read a first line from '" + path + "'");
  if (!line.empty() && line.back() == '\r') line.pop_back();
  return line;
}

cluster::NatsOptions nats_options(const ServeArgs& a, const std::string& name) {
  cluster::NatsOptions o;
  o.urls = cluster::parse_nats_urls(a.nats);
  o.name = name;
  if (!a.nats_user.empty()) {
    o.user = a.nats_user;
    o.password = read_first_line(a.nats_password_file, "--nats-password-file");
  } else if (!a.nats_password_file.empty()) {
    throw Error("--nats-password-file goes with --nats-user");
  }
  if (a.nats_ca.empty() && !(a.nats_tls_name.empty() && a.nats_cert.empty() && a.nats_key.empty()))
    throw Error("--nats-tls-name, --nats-cert and --nats-key go with --nats-ca");
  o.ca_file = a.nats_ca;
  o.tls_name = a.nats_tls_name;
  o.cert_file = a.nats_cert;
  o.key_file = a.nats_key;
  if (!o.ca_file.empty() && o.tls_name.empty())
    spdlog::warn(
        "NATS TLS: node certificates are checked against {} but not by name: give "
        "--nats-tls-name to require the name they carry",
        o.ca_file);
  if (o.ca_file.empty() && !o.user.empty())
    spdlog::warn(
        "NATS: the password of '{}' goes to the cluster in clear text: give --nats-ca "
        "for TLS",
        o.user);
  return o;
}

}  // namespace volcast
