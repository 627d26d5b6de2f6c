#pragma once
// Which server certificates a viewer trusts: fingerprints pinned per server, like SSH's
// known_hosts. The file (default user_config_dir()/known_servers) holds one line per server,
//   HOST:PORT SHA256-FINGERPRINT-HEX
// in the form the user typed HOST (no resolution); lines starting with '#' are comments.
#include <filesystem>
#include <string>

namespace volcast {

/// What check_server_fingerprint decided.
enum class TrustDecision {
  kPinned,    ///< the fingerprint matches the one stored for this server
  kFirstUse,  ///< no fingerprint was stored or given: this one is now stored (trust on first use)
  kFromLink,  ///< it matches the one the join link gave; stored (replacing any older pin)
};

/// Checks the fingerprint `actual` a server at `host_port` presented against `expected` (from the
/// join link or --fingerprint; empty if none) and the pin stored in `known_servers`. A match with
/// `expected` wins and is stored; without `expected` the stored pin must match, or, if none is
/// stored, `actual` is stored. Throws Error (before any secret is sent) when the certificate is not
/// the expected one, saying what to check: the fingerprint the server printed at start, and the
/// line of `known_servers` to delete if the server's certificate was legitimately replaced. Throws
/// Error naming the file if it cannot be written. An empty `known_servers` means no store: then
/// `expected` must be given.
TrustDecision check_server_fingerprint(const std::filesystem::path& known_servers,
                                       const std::string& host_port, const std::string& actual,
                                       const std::string& expected);

}  // namespace volcast
