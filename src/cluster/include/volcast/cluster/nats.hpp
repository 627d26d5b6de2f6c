#pragma once
// A connection to a NATS cluster (libnats, the NATS C client) and the subjects Volcast uses on
// it (issue 17).
//
// Subjects of a site (each token is checked by nats_subject_token):
//   volcast.<site>.welcome                              the site's Welcome (protocol::serialize)
//   volcast.<site>.tier.<depth>.<color>.<quality>       the tier's frame sets, as chunks
//                                                       (chunks.hpp); quality 0 = codec default
//   volcast.<site>.want.<depth>.<color>.<quality>       a subscriber wants the tier: 1 byte,
//                                                       bit 0 = a key frame set, please; sent
//                                                       every second while it does
#include <cstdint>
#include <functional>
#include <memory>
#include <optional>
#include <span>
#include <string>
#include <vector>

#include "volcast/codec/tier.hpp"

namespace volcast::cluster {

/// Throws Error unless `token` is usable as one token of a NATS subject: 1..64 characters of
/// A-Z a-z 0-9 _ - (no '.', wildcards or spaces). `what` names it in the message.
void check_subject_token(const std::string& token, const std::string& what);

std::string welcome_subject(const std::string& site);
/// "volcast.<site>.tier.<depth>.<color>.<quality>" (quality 0: the codec's default); codec names
/// are tokens ("volcast-t", "jpeg"). A tier on NATS carries every frame set: throws Error for a
/// tier with @N, a name that is no token or a quality outside 0..100.
std::string tier_subject(const std::string& site, const Tier& tier);
/// "volcast.<site>.want.<depth>.<color>.<quality>" (tier_subject's tokens and checks).
std::string want_subject(const std::string& site, const Tier& tier);

struct NatsOptions {
  std::vector<std::string> urls;  ///< e.g. nats://127.0.0.1:4222; several: a cluster
  std::string name = "volcast";   ///< the connection's name in the server's monitoring
  std::string user, password;     ///< both empty: no authentication
  /// TLS to the cluster (nats-server's `tls` block), on when `ca_file` is given: each node's
  /// certificate must chain to a certificate in `ca_file` (PEM), and carry the name `tls_name`
  /// (its DNS name or CN) when that is given. libnats checks no name otherwise: any certificate
  /// of the CA is taken. `cert_file` + `key_file` (PEM): this client's certificate, for nodes
  /// that verify clients (`verify: true`).
  std::string ca_file, tls_name, cert_file, key_file;
  int64_t connect_timeout_ms = 2000;
  /// Try `urls` in the order given (a relay placed on one node), else in random order (libnats'
  /// default: clients spread over the cluster).
  bool in_order = false;
};

/// Splits "URL[,URL...]" into urls. Throws Error for an empty list or URL.
std::vector<std::string> parse_nats_urls(const std::string& list);

class NatsConnection {
  struct Impl;

 public:
  /// Connects to one of `o.urls` (reconnecting to any of them, forever, if the link drops).
  /// Throws Error with libnats' reason (e.g. "No server available for connection", "SSL
  /// Error - certificate verify failed", "Secure Connection - TLS Required") and the URLs; a
  /// TLS file that cannot be loaded is named. tls:// URLs need `ca_file`.
  explicit NatsConnection(const NatsOptions& o);
  ~NatsConnection();
  NatsConnection(const NatsConnection&) = delete;
  NatsConnection& operator=(const NatsConnection&) = delete;

  /// The server's max_payload: the largest message it takes, bytes (1 MiB by default).
  size_t max_payload() const;
  /// Publishes `data` on `subject` (buffered; flush() waits for the server). Throws Error.
  void publish(const std::string& subject, std::span<const uint8_t> data);
  /// The URL of the server this connection uses now; empty while reconnecting.
  std::string connected_url() const;
  /// Waits until the server has everything published so far (at most `timeout_ms`). Throws Error.
  void flush(int64_t timeout_ms = 2000);

  /// A subscription. The callback runs on libnats' thread for the subscription, one message at a
  /// time, in order; the span is valid during the call. Destroying it unsubscribes and waits for
  /// a callback in progress: the callback is never called after. Destroy it before its
  /// connection (whose destructor frees what libnats still holds of it).
  class Subscription {
   public:
    ~Subscription();
    Subscription(const Subscription&) = delete;
    Subscription& operator=(const Subscription&) = delete;
    /// Messages dropped because the callback fell behind (libnats' pending limits).
    int64_t dropped() const;

   private:
    friend class NatsConnection;
    Subscription() = default;
    struct Impl;
    std::shared_ptr<Impl> impl_;
    NatsConnection::Impl* owner_ = nullptr;
  };
  /// A JetStream key-value bucket (the nodes must run JetStream: nats-server's `jetstream {}`
  /// block). Values at most the server's max_payload; keys of A-Z a-z 0-9 - _ = . / .
  class KeyValue {
   public:
    ~KeyValue();
    KeyValue(const KeyValue&) = delete;
    KeyValue& operator=(const KeyValue&) = delete;
    /// Stores `value` under `key` (a new revision). Throws Error with libnats' reason.
    void put(const std::string& key, std::span<const uint8_t> value);
    /// The newest value of `key`; nullopt if there is none (or it was deleted). Throws Error.
    std::optional<std::vector<uint8_t>> get(const std::string& key);
    /// Deletes `key` (get() then finds nothing; no-op if it has no value). Throws Error.
    void erase(const std::string& key);
    /// Every key with a value now. Throws Error.
    std::vector<std::string> keys();

   private:
    friend class NatsConnection;
    KeyValue() = default;
    struct Impl;
    std::unique_ptr<Impl> impl_;
  };
  /// Opens bucket `bucket` (A-Z a-z 0-9 - _), making it if missing with the newest value per key
  /// kept, on `replicas` nodes (1..5; at most the cluster's nodes). Throws Error naming JetStream
  /// when the cluster does not run it.
  std::unique_ptr<KeyValue> key_value(const std::string& bucket, int replicas = 1);

  using Handler = std::function<void(const std::string& subject, std::span<const uint8_t> data)>;
  /// Subscribes to `subject` (wildcards allowed). Throws Error (e.g. not permitted).
  std::unique_ptr<Subscription> subscribe(const std::string& subject, Handler handler);

 private:
  std::unique_ptr<Impl> impl_;
};

}  // namespace volcast::cluster
