// TLS identities (self-signed certificates made on first run, or the operator's own), their
// fingerprints, and the TLS 1.3 contexts made from them (tls.hpp).
#include <fcntl.h>
#include <openssl/err.h>
#include <openssl/evp.h>
#include <openssl/pem.h>
#include <openssl/rand.h>
#include <openssl/ssl.h>
#include <openssl/x509.h>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include "tls_internal.hpp"
#include "volcast/core/error.hpp"
#include "volcast/net/transport/tls.hpp"

namespace volcast {
namespace detail {

// The newest OpenSSL error on this thread's queue, as text (and the queue cleared).
std::string openssl_error() {
  const unsigned long code = ERR_get_error();
  ERR_clear_error();
  if (code == 0) return "unknown OpenSSL error";
  char text[256];
  ERR_error_string_n(code, text, sizeof text);
  return text;
}

}  // namespace detail

namespace {

using detail::Deleter;
using detail::fingerprint_of;
using detail::openssl_error;
using detail::X509Ptr;
using Bio = std::unique_ptr<BIO, Deleter<BIO, BIO_free_all>>;
using Pkey = std::unique_ptr<EVP_PKEY, Deleter<EVP_PKEY, EVP_PKEY_free>>;

std::string bio_text(BIO* bio) {
  char* data = nullptr;
  const long n = BIO_get_mem_data(bio, &data);
  return std::string(data, static_cast<size_t>(n));
}

X509Ptr parse_certificate(const std::string& pem) {
  Bio bio(BIO_new_mem_buf(pem.data(), static_cast<int>(pem.size())));
  X509Ptr cert(PEM_read_bio_X509(bio.get(), nullptr, nullptr, nullptr));
  if (!cert) throw Error("not a PEM certificate: " + openssl_error());
  return cert;
}

Pkey parse_private_key(const std::string& pem) {
  Bio bio(BIO_new_mem_buf(pem.data(), static_cast<int>(pem.size())));
  Pkey key(PEM_read_bio_PrivateKey(bio.get(), nullptr, nullptr, nullptr));
  if (!key) throw Error("not a PEM private key: " + openssl_error());
  return key;
}

std::string hex(const unsigned char* data, size_t n) {
  static const char kDigits[] = "0123456789abcdef";
  std::string out;
  for (size_t i = 0; i < n; ++i) {
    out += kDigits[data[i] >> 4];
    out += kDigits[data[i] & 15];
  }
  return out;
}

std::string read_file(const std::filesystem::path& path) {
  std::ifstream in(path, std::ios::binary);
  if (!in) throw Error("cannot read '" + path.string() + "'");
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

// Writes a new file with `mode`; never replaces one (O_EXCL).
void write_new_file(const std::filesystem::path& path, const std::string& text, mode_t mode) {
  const int fd = ::open(path.c_str(), O_WRONLY | O_CREAT | O_EXCL | O_CLOEXEC, mode);
  if (fd < 0) throw Error("cannot create '" + path.string() + "': " + std::strerror(errno));
  size_t done = 0;
  while (done < text.size()) {
    const ssize_t n = ::write(fd, text.data() + done, text.size() - done);
    if (n <= 0) {
      const std::string why = std::strerror(errno);
      ::close(fd);
      throw Error("cannot write '" + path.string() + "': " + why);
    }
    done += static_cast<size_t>(n);
  }
  if (::close(fd) != 0)
    throw Error("cannot write '" + path.string() + "': " + std::strerror(errno));
}

}  // namespace

namespace detail {

std::string fingerprint_of(X509* cert) {
  unsigned char md[EVP_MAX_MD_SIZE];
  unsigned int n = 0;
  if (X509_digest(cert, EVP_sha256(), md, &n) != 1)
    throw Error("cannot hash the certificate: " + openssl_error());
  return hex(md, n);
}

}  // namespace detail

TlsIdentity make_self_signed_identity(const std::string& common_name) {
  Pkey key(EVP_EC_gen("P-256"));
  if (!key) throw Error("cannot make a TLS key: " + openssl_error());
  X509Ptr cert(X509_new());
  if (!cert) throw Error("cannot make a certificate: " + openssl_error());
  X509_set_version(cert.get(), 2);  // v3
  unsigned char serial[16];
  if (RAND_bytes(serial, sizeof serial) != 1) throw Error("random source failed");
  serial[0] &= 0x7f;  // positive
  BIGNUM* bn = BN_bin2bn(serial, sizeof serial, nullptr);
  BN_to_ASN1_INTEGER(bn, X509_get_serialNumber(cert.get()));
  BN_free(bn);
  X509_gmtime_adj(X509_getm_notBefore(cert.get()), -3600);
  X509_gmtime_adj(X509_getm_notAfter(cert.get()), 10L * 365 * 24 * 3600);
  X509_set_pubkey(cert.get(), key.get());
  X509_NAME* name = X509_get_subject_name(cert.get());
  X509_NAME_add_entry_by_txt(name, "CN", MBSTRING_UTF8,
                             reinterpret_cast<const unsigned char*>(common_name.c_str()), -1, -1,
                             0);
  X509_set_issuer_name(cert.get(), name);
  if (X509_sign(cert.get(), key.get(), EVP_sha256()) == 0)
    throw Error("cannot sign the certificate: " + openssl_error());
  Bio cert_bio(BIO_new(BIO_s_mem())), key_bio(BIO_new(BIO_s_mem()));
  if (PEM_write_bio_X509(cert_bio.get(), cert.get()) != 1 ||
      PEM_write_bio_PrivateKey(key_bio.get(), key.get(), nullptr, nullptr, 0, nullptr, nullptr) !=
          1)
    throw Error("cannot write the certificate: " + openssl_error());
  return {bio_text(cert_bio.get()), bio_text(key_bio.get())};
}

TlsIdentity load_identity(const std::filesystem::path& certificate_file,
                          const std::filesystem::path& private_key_file) {
  TlsIdentity id{read_file(certificate_file), read_file(private_key_file)};
  X509Ptr cert, dummy;
  try {
    cert = parse_certificate(id.certificate_pem);
  } catch (const Error& e) {
    throw Error("certificate '" + certificate_file.string() + "': " + e.what());
  }
  Pkey key;
  try {
    key = parse_private_key(id.private_key_pem);
  } catch (const Error& e) {
    throw Error("private key '" + private_key_file.string() + "': " + e.what());
  }
  if (X509_check_private_key(cert.get(), key.get()) != 1) {
    ERR_clear_error();
    throw Error("private key '" + private_key_file.string() + "' does not belong to certificate '" +
                certificate_file.string() + "'");
  }
  return id;
}

TlsIdentity load_or_create_identity(const std::filesystem::path& dir, bool* created) {
  const auto cert = dir / "cert.pem", key = dir / "key.pem";
  std::error_code ec;
  if (std::filesystem::exists(cert, ec) && std::filesystem::exists(key, ec)) {
    if (created) *created = false;
    return load_identity(cert, key);
  }
  std::filesystem::create_directories(dir, ec);
  if (ec) throw Error("cannot create '" + dir.string() + "': " + ec.message());
  ::chmod(dir.c_str(), 0700);
  char host[256] = "volcast";
  ::gethostname(host, sizeof host - 1);
  const TlsIdentity id = make_self_signed_identity(std::string("volcast server ") + host);
  write_new_file(key, id.private_key_pem, 0600);
  write_new_file(cert, id.certificate_pem, 0644);
  if (created) *created = true;
  return id;
}

std::string certificate_fingerprint(const std::string& certificate_pem) {
  return fingerprint_of(parse_certificate(certificate_pem).get());
}

std::filesystem::path user_config_dir() {
  if (const char* xdg = std::getenv("XDG_CONFIG_HOME"); xdg && *xdg == '/')
    return std::filesystem::path(xdg) / "volcast";
  if (const char* home = std::getenv("HOME"); home && *home)
    return std::filesystem::path(home) / ".config" / "volcast";
  return std::filesystem::current_path() / ".volcast";
}

TlsContext::TlsContext(std::unique_ptr<Impl> impl) : impl_(std::move(impl)) {}
TlsContext::~TlsContext() = default;

const std::string& TlsContext::fingerprint() const {
  return impl_->fingerprint;
}

namespace {

void restrict_to_tls13(SSL_CTX* ctx) {
  SSL_CTX_set_min_proto_version(ctx, TLS1_3_VERSION);
  SSL_CTX_set_max_proto_version(ctx, TLS1_3_VERSION);
  SSL_CTX_set_ciphersuites(ctx,
                           "TLS_AES_128_GCM_SHA256:TLS_AES_256_GCM_SHA384:"
                           "TLS_CHACHA20_POLY1305_SHA256");
  // Our messages are length-framed, so a missing close_notify cannot truncate one unnoticed.
  SSL_CTX_set_options(ctx, SSL_OP_IGNORE_UNEXPECTED_EOF | SSL_OP_NO_COMPRESSION);
  // Buffers are kept between writes (no SSL_MODE_RELEASE_BUFFERS): no allocation per frame set.
  SSL_CTX_set_mode(ctx, SSL_MODE_ENABLE_PARTIAL_WRITE | SSL_MODE_ACCEPT_MOVING_WRITE_BUFFER);
}

}  // namespace

std::shared_ptr<TlsContext> TlsContext::server(const TlsIdentity& identity) {
  auto impl = std::make_unique<Impl>(asio::ssl::context::tls_server);
  SSL_CTX* ctx = impl->context.native_handle();
  restrict_to_tls13(ctx);
  SSL_CTX_set_num_tickets(ctx, 0);  // no resumption: one connection per session anyway
  SSL_CTX_set_session_cache_mode(ctx, SSL_SESS_CACHE_OFF);
  try {
    impl->context.use_certificate_chain(asio::buffer(identity.certificate_pem));
    impl->context.use_private_key(asio::buffer(identity.private_key_pem), asio::ssl::context::pem);
  } catch (const std::system_error& e) {
    throw Error(std::string("TLS identity: ") + e.what());
  }
  if (SSL_CTX_check_private_key(ctx) != 1)
    throw Error("TLS identity: the private key does not belong to the certificate");
  impl->fingerprint = certificate_fingerprint(identity.certificate_pem);
  return std::shared_ptr<TlsContext>(new TlsContext(std::move(impl)));
}

std::shared_ptr<TlsContext> TlsContext::client() {
  auto impl = std::make_unique<Impl>(asio::ssl::context::tls_client);
  restrict_to_tls13(impl->context.native_handle());
  impl->context.set_verify_mode(asio::ssl::verify_none);  // pinned by fingerprint instead
  return std::shared_ptr<TlsContext>(new TlsContext(std::move(impl)));
}

}  // namespace volcast
