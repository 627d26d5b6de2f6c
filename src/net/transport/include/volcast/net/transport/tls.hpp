#pragma once
// TLS 1.3 for the stream (OpenSSL 3 through asio's SSL context): server identities (a self-signed
// certificate made on first run, or the operator's own), the contexts, and TLS connections that
// implement the Connection seam (connection.hpp) with the same deadlines as TCP.
//
// Trust model: the server's certificate is not checked against certificate authorities; a viewer
// pins its SHA-256 fingerprint instead (given in the join link, or trusted on first use and stored:
// see trust.hpp). Only TLS 1.3 is offered, with AES-GCM or ChaCha20-Poly1305; no session tickets,
// no client certificates (viewers authenticate with the join token inside the TLS channel).
#include <cstdint>
#include <filesystem>
#include <memory>
#include <string>

#include "volcast/core/error.hpp"
#include "volcast/net/transport/connection.hpp"

namespace volcast {

/// A certificate and its private key, PEM text.
struct TlsIdentity {
  std::string certificate_pem;
  std::string private_key_pem;
};

/// A new self-signed certificate (ECDSA P-256, SHA-256, valid 10 years, subject CN =
/// `common_name`). Throws Error if OpenSSL fails.
TlsIdentity make_self_signed_identity(const std::string& common_name);
/// Reads PEM files. Throws Error naming the file that cannot be read or parsed, or if the key does
/// not belong to the certificate.
TlsIdentity load_identity(const std::filesystem::path& certificate_file,
                          const std::filesystem::path& private_key_file);
/// The server's persistent identity in `dir` (cert.pem, key.pem): loaded if both exist, else made
/// and written (the directory 0700, the key 0600; never overwrites an existing file). `created`
/// (optional) tells which. Throws Error naming the file on any failure.
TlsIdentity load_or_create_identity(const std::filesystem::path& dir, bool* created = nullptr);
/// SHA-256 of the certificate's DER encoding, 64 lower-case hex digits. Throws Error if the PEM
/// holds no certificate.
std::string certificate_fingerprint(const std::string& certificate_pem);

/// Volcast's per-user configuration folder: $XDG_CONFIG_HOME/volcast, else ~/.config/volcast
/// (XDG Base Directory Specification). Not created here.
std::filesystem::path user_config_dir();

/// An OpenSSL context (asio::ssl::context) set up for TLS 1.3 only. Immutable once made; shared by
/// every connection it creates, from any thread.
class TlsContext {
 public:
  /// A server context presenting `identity`. Throws Error if the key or certificate is invalid.
  static std::shared_ptr<TlsContext> server(const TlsIdentity& identity);
  /// A client context. It does not verify certificate chains: the caller pins the fingerprint.
  static std::shared_ptr<TlsContext> client();
  ~TlsContext();
  TlsContext(const TlsContext&) = delete;
  TlsContext& operator=(const TlsContext&) = delete;
  /// The server certificate's fingerprint (certificate_fingerprint); empty for a client context.
  const std::string& fingerprint() const;

  struct Impl;
  Impl& impl() const { return *impl_; }

 private:
  explicit TlsContext(std::unique_ptr<Impl> impl);
  std::unique_ptr<Impl> impl_;
};

/// Server side: wraps an accepted, connected socket `fd` (owned from here on, even on error) in a
/// TLS connection whose handshake has not run yet: drive it with Connection::handshake_step().
std::unique_ptr<Connection> accept_tls(int fd, std::string peer,
                                       std::shared_ptr<const TlsContext> context);

/// Thrown by connect_tls when the TCP connection was made but the server closed it, or did not
/// answer, before the TLS handshake finished: what a server whose door is full does (it drops the
/// oldest pending handshake for a newcomer, or refuses one over the per-address limit, and
/// answers nothing). Worth retrying with back-off, unlike a TLS alert or a refused connection.
class TlsHandshakeDropped : public Error {
 public:
  using Error::Error;
};

/// A client's TLS connection and what the server proved.
struct TlsClientConnection {
  std::unique_ptr<Connection> connection;
  std::string server_fingerprint;  ///< SHA-256 of the certificate the server presented (hex)
};
/// Connects over TCP and completes the TLS handshake, both within `timeout_ms`. The caller checks
/// `server_fingerprint` before sending anything secret. Throws Error("cannot connect to HOST:PORT:
/// reason"), e.g. "TLS handshake failed (is the server started with --insecure?)";
/// TlsHandshakeDropped when the server closed or did not finish the handshake (busy).
TlsClientConnection connect_tls(const std::string& host, uint16_t port,
                                std::shared_ptr<const TlsContext> context, int timeout_ms);

}  // namespace volcast
