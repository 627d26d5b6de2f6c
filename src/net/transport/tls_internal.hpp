#pragma once
// Internal to volcast_net_transport: what TLS connections (tls.cpp) share with the identities
// and contexts (tls_identity.cpp).
#include <openssl/ssl.h>
#include <openssl/x509.h>

#include <asio.hpp>
#include <asio/ssl.hpp>
#include <memory>
#include <string>

#include "volcast/net/transport/tls.hpp"

namespace volcast {

struct TlsContext::Impl {
  explicit Impl(asio::ssl::context::method m) : context(m) {}
  asio::ssl::context context;
  std::string fingerprint;
};

namespace detail {

/// The newest OpenSSL error on this thread's queue, as text (and the queue cleared).
std::string openssl_error();
/// SHA-256 of `cert`'s DER encoding, 64 lower-case hex digits. Throws Error if OpenSSL fails.
std::string fingerprint_of(X509* cert);

template <typename T, void (*Free)(T*)>
struct Deleter {
  void operator()(T* p) const { Free(p); }
};
using X509Ptr = std::unique_ptr<X509, Deleter<X509, X509_free>>;

}  // namespace detail
}  // namespace volcast
