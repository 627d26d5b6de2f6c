#include "volcast/cluster/nats.hpp"

#include <nats/nats.h>

#include <spdlog/spdlog.h>

#include <algorithm>
#include <chrono>
#include <climits>
#include <condition_variable>
#include <mutex>

#include "volcast/core/error.hpp"

namespace volcast::cluster {
namespace {

// libnats' reason for `s`, with its last error text where it has one.
std::string reason(natsStatus s) {
  std::string text = natsStatus_GetText(s);
  natsStatus last = NATS_OK;
  if (const char* detail = nats_GetLastError(&last);
      detail && *detail && std::string(detail).find(text) == std::string::npos)
    text += std::string(" (") + detail + ")";
  return text;
}

std::string joined(const std::vector<std::string>& urls) {
  std::string out;
  for (const auto& u : urls) out += (out.empty() ? "" : ",") + u;
  return out;
}

}  // namespace

void check_subject_token(const std::string& token, const std::string& what) {
  bool ok = !token.empty() && token.size() <= 64;
  for (char c : token)
    ok = ok && ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') ||
                c == '_' || c == '-');
  if (!ok)
    throw Error(what + " '" + token +
                "' cannot be a NATS subject token: use 1-64 of A-Z a-z 0-9 _ -");
}

std::string welcome_subject(const std::string& site) {
  check_subject_token(site, "site name");
  return "volcast." + site + ".welcome";
}

std::string tier_subject(const std::string& site, const Tier& tier) {
  check_subject_token(site, "site name");
  check_subject_token(tier.depth_codec, "depth codec");
  check_subject_token(tier.color_codec, "color codec");
  if (tier.color_quality < 0 || tier.color_quality > 100)
    throw Error("color quality " + std::to_string(tier.color_quality) + " is not 0..100");
  if (tier.frame_divisor != 1)
    throw Error("tier " + to_string(tier) + ": a tier on NATS carries every frame set (no @N)");
  return "volcast." + site + ".tier." + tier.depth_codec + "." + tier.color_codec + "." +
         std::to_string(tier.color_quality);
}

std::string want_subject(const std::string& site, const Tier& tier) {
  std::string s = tier_subject(site, tier);
  return s.replace(s.find(".tier."), 6, ".want.");
}

std::vector<std::string> parse_nats_urls(const std::string& list) {
  std::vector<std::string> urls;
  size_t at = 0;
  while (at <= list.size()) {
    const size_t comma = std::min(list.find(',', at), list.size());
    const std::string url = list.substr(at, comma - at);
    if (url.empty()) throw Error("--nats: an empty URL in '" + list + "'");
    urls.push_back(url);
    at = comma + 1;
  }
  return urls;
}

struct NatsConnection::Subscription::Impl {
  natsSubscription* sub = nullptr;
  Handler handler;
  std::mutex calling;   // held while the handler runs
  bool closed = false;  // under `calling`: the handler is never called again
  // libnats' delivery thread for the subscription is done with it (its on-complete callback ran:
  // the subscription is closed and its last message handed over). Until then that thread may
  // still call on_message with this object, even after the connection was closed.
  std::mutex completing;
  std::condition_variable completed_cv;
  bool completed = false;  // under `completing`
};

struct NatsConnection::Impl {
  natsConnection* nc = nullptr;
  std::mutex mutex;
  // Subscriptions unsubscribed but not destroyed: libnats 3.4 (Debian 12) may still be handing
  // one an inbound message on its read loop when another thread destroys it (nats.c#637, fixed
  // in 3.6), so they are destroyed with the connection, after its read loop has stopped.
  std::vector<std::shared_ptr<Subscription::Impl>> retired;
};

NatsConnection::NatsConnection(const NatsOptions& o) : impl_(std::make_unique<Impl>()) {
  if (o.urls.empty()) throw Error("NATS: no server URL given");
  natsOptions* opts = nullptr;
  natsStatus s = natsOptions_Create(&opts);
  std::vector<const char*> urls;
  for (const auto& u : o.urls) urls.push_back(u.c_str());
  if (s == NATS_OK) s = natsOptions_SetServers(opts, urls.data(), static_cast<int>(urls.size()));
  if (s == NATS_OK) s = natsOptions_SetName(opts, o.name.c_str());
  if (s == NATS_OK) s = natsOptions_SetTimeout(opts, o.connect_timeout_ms);
  if (s == NATS_OK) s = natsOptions_SetMaxReconnect(opts, -1);  // keep trying: a node may return
  if (s == NATS_OK) s = natsOptions_SetReconnectWait(opts, 250);
  // Write each publish now rather than when libnats' flusher next runs: a pose or a frame set's
  // chunks wait for nobody. Measured on loopback (docs/cluster.md): a pose's round trip between
  // participants of two relays, p50 5.2/4.6 ms -> 1.7/1.8 ms.
  if (s == NATS_OK) s = natsOptions_SetSendAsap(opts, true);
  if (s == NATS_OK && o.in_order) s = natsOptions_SetNoRandomize(opts, true);
  if (s == NATS_OK && (!o.user.empty() || !o.password.empty()))
    s = natsOptions_SetUserInfo(opts, o.user.c_str(), o.password.c_str());
  bool tls = !o.ca_file.empty();
  for (const auto& u : o.urls)
    if (u.starts_with("tls://") && !tls) {
      natsOptions_Destroy(opts);
      throw Error("NATS: " + u + " is a TLS URL: give the CA that signed the cluster's " +
                  "certificates (--nats-ca)");
    }
  if (tls && (o.cert_file.empty() != o.key_file.empty())) {
    natsOptions_Destroy(opts);
    throw Error("NATS: a client certificate needs both its file and its key (--nats-cert, " +
                std::string("--nats-key)"));
  }
  std::string failed;  // the TLS file libnats could not load
  if (s == NATS_OK && tls) s = natsOptions_SetSecure(opts, true);
  if (s == NATS_OK && tls) {
    s = natsOptions_LoadCATrustedCertificates(opts, o.ca_file.c_str());
    if (s != NATS_OK) failed = "CA file " + o.ca_file;
  }
  if (s == NATS_OK && tls && !o.tls_name.empty())
    s = natsOptions_SetExpectedHostname(opts, o.tls_name.c_str());
  if (s == NATS_OK && tls && !o.cert_file.empty()) {
    s = natsOptions_LoadCertificatesChain(opts, o.cert_file.c_str(), o.key_file.c_str());
    if (s != NATS_OK) failed = "client certificate " + o.cert_file + " / key " + o.key_file;
  }
  if (!failed.empty()) {
    const std::string why = reason(s);
    natsOptions_Destroy(opts);
    throw Error("NATS: cannot load the " + failed + ": " + why);
  }
  if (s == NATS_OK) s = natsConnection_Connect(&impl_->nc, opts);
  std::string why = s == NATS_OK ? "" : reason(s);
  // A node that verifies clients closes the link after the handshake without saying why.
  if (s == NATS_PROTOCOL_ERROR && tls && o.cert_file.empty())
    why +=
        " (do the nodes verify clients? give this process's certificate: --nats-cert, "
        "--nats-key)";
  natsOptions_Destroy(opts);
  if (s != NATS_OK) throw Error("NATS: cannot connect to " + joined(o.urls) + ": " + why);
}

NatsConnection::~NatsConnection() {
  if (!impl_->nc) return;
  natsConnection_Close(impl_->nc);  // closes every subscription; their threads finish on their own
  // Each retired subscription's Impl is freed with impl_: first wait until libnats' delivery
  // thread has finished with it (a CI run's ASan found one handing a queued message to a freed
  // Impl). One that does not finish within 10 s is kept alive, and said: a leak, not a crash.
  for (auto& r : impl_->retired) {
    std::unique_lock lock(r->completing);
    if (!r->completed_cv.wait_for(lock, std::chrono::seconds(10), [&] { return r->completed; })) {
      spdlog::warn("NATS: a subscription's delivery thread did not finish in 10 s: kept");
      static std::mutex kept_mutex;  // connections may be destroyed on several threads at once
      static auto* kept = new std::vector<std::shared_ptr<Subscription::Impl>>;  // never freed
      std::lock_guard kept_lock(kept_mutex);
      kept->push_back(r);
    }
  }
  for (const auto& r : impl_->retired) natsSubscription_Destroy(r->sub);
  natsConnection_Destroy(impl_->nc);
}

size_t NatsConnection::max_payload() const {
  const int64_t m = natsConnection_GetMaxPayload(impl_->nc);
  return m > 0 ? static_cast<size_t>(m) : 0;
}

void NatsConnection::publish(const std::string& subject, std::span<const uint8_t> data) {
  if (data.size() > static_cast<size_t>(INT_MAX))
    throw Error("NATS: a message of " + std::to_string(data.size()) + " bytes");
  const natsStatus s = natsConnection_Publish(impl_->nc, subject.c_str(), data.data(),
                                              static_cast<int>(data.size()));
  if (s != NATS_OK) throw Error("NATS: cannot publish on " + subject + ": " + reason(s));
}

std::string NatsConnection::connected_url() const {
  char url[512] = {0};
  if (natsConnection_GetConnectedUrl(impl_->nc, url, sizeof url) != NATS_OK) return "";
  return url;
}

void NatsConnection::flush(int64_t timeout_ms) {
  const natsStatus s = natsConnection_FlushTimeout(impl_->nc, timeout_ms);
  if (s != NATS_OK) throw Error("NATS: flush: " + reason(s));
}

NatsConnection::Subscription::~Subscription() {
  if (!impl_ || !impl_->sub) return;
  natsSubscription_Unsubscribe(impl_->sub);
  {
    std::lock_guard lock(impl_->calling);  // waits for a handler call in progress
    impl_->closed = true;
  }
  std::lock_guard lock(owner_->mutex);
  owner_->retired.push_back(std::move(impl_));
}

int64_t NatsConnection::Subscription::dropped() const {
  int64_t n = 0;
  natsSubscription_GetDropped(impl_->sub, &n);
  return n;
}

std::unique_ptr<NatsConnection::Subscription> NatsConnection::subscribe(const std::string& subject,
                                                                        Handler handler) {
  std::unique_ptr<Subscription> out(new Subscription);
  out->impl_ = std::make_shared<Subscription::Impl>();
  out->owner_ = impl_.get();
  out->impl_->handler = std::move(handler);
  const auto on_message = [](natsConnection*, natsSubscription*, natsMsg* msg, void* closure) {
    auto* self = static_cast<Subscription::Impl*>(closure);
    const auto* data = reinterpret_cast<const uint8_t*>(natsMsg_GetData(msg));
    try {  // nothing may escape into libnats' thread
      std::lock_guard lock(self->calling);
      if (!self->closed)
        self->handler(natsMsg_GetSubject(msg),
                      {data, static_cast<size_t>(std::max(natsMsg_GetDataLength(msg), 0))});
    } catch (const std::exception& e) {
      spdlog::warn("NATS: a message on {} was dropped: {}", natsMsg_GetSubject(msg), e.what());
    }
    natsMsg_Destroy(msg);
  };
  natsStatus s = natsConnection_Subscribe(&out->impl_->sub, impl_->nc, subject.c_str(), on_message,
                                          out->impl_.get());
  // Called on the delivery thread once the subscription is closed and its handler has returned
  // for the last time (nats.h: what makes freeing what the handler uses safe). Notified under the
  // lock: the waiter frees this Impl only after the callback has let go of it.
  const auto on_complete = [](void* closure) {
    auto* self = static_cast<Subscription::Impl*>(closure);
    std::lock_guard lock(self->completing);
    self->completed = true;
    self->completed_cv.notify_all();
  };
  if (s == NATS_OK)
    s = natsSubscription_SetOnCompleteCB(out->impl_->sub, on_complete, out->impl_.get());
  // Room for a few seconds of a tier's chunks before libnats drops (counted in dropped()).
  if (s == NATS_OK) s = natsSubscription_SetPendingLimits(out->impl_->sub, 65536, 512 << 20);
  // A permissions violation arrives asynchronously: a flush makes it this call's error.
  if (s == NATS_OK) s = natsConnection_FlushTimeout(impl_->nc, 2000);
  if (s == NATS_OK) {
    const char* last = nullptr;
    if (natsConnection_GetLastError(impl_->nc, &last) != NATS_OK && last && *last)
      throw Error("NATS: cannot subscribe to " + subject + ": " + last);
  }
  if (s != NATS_OK) throw Error("NATS: cannot subscribe to " + subject + ": " + reason(s));
  return out;
}

}  // namespace volcast::cluster

namespace volcast::cluster {

struct NatsConnection::KeyValue::Impl {
  jsCtx* js = nullptr;
  kvStore* kv = nullptr;
  std::string bucket;
  ~Impl() {
    if (kv) kvStore_Destroy(kv);
    if (js) jsCtx_Destroy(js);
  }
};

NatsConnection::KeyValue::~KeyValue() = default;

std::unique_ptr<NatsConnection::KeyValue> NatsConnection::key_value(const std::string& bucket,
                                                                    int replicas) {
  check_subject_token(bucket, "key-value bucket");
  if (replicas < 1 || replicas > 5)
    throw Error("NATS: " + std::to_string(replicas) + " replicas (1..5) for bucket " + bucket);
  std::unique_ptr<KeyValue> out(new KeyValue());
  out->impl_ = std::make_unique<KeyValue::Impl>();
  auto& k = *out->impl_;
  k.bucket = bucket;
  natsStatus s = natsConnection_JetStream(&k.js, impl_->nc, nullptr);
  if (s == NATS_OK) {
    s = js_KeyValue(&k.kv, k.js, bucket.c_str());
    if (s == NATS_NOT_FOUND) {
      kvConfig cfg;
      kvConfig_Init(&cfg);
      cfg.Bucket = bucket.c_str();
      cfg.History = 1;
      cfg.Replicas = replicas;
      s = js_CreateKeyValue(&k.kv, k.js, &cfg);
    }
  }
  if (s != NATS_OK)
    throw Error("NATS: cannot open key-value bucket " + bucket + ": " + reason(s) +
                " (the nodes need JetStream: a `jetstream { store_dir: ... }` block)");
  return out;
}

void NatsConnection::KeyValue::put(const std::string& key, std::span<const uint8_t> value) {
  uint64_t revision = 0;
  const natsStatus s =
      kvStore_Put(&revision, impl_->kv, key.c_str(), value.data(), static_cast<int>(value.size()));
  if (s != NATS_OK)
    throw Error("NATS: cannot store " + key + " in bucket " + impl_->bucket + ": " + reason(s));
}

std::optional<std::vector<uint8_t>> NatsConnection::KeyValue::get(const std::string& key) {
  kvEntry* e = nullptr;
  const natsStatus s = kvStore_Get(&e, impl_->kv, key.c_str());
  if (s == NATS_NOT_FOUND) return std::nullopt;
  if (s != NATS_OK)
    throw Error("NATS: cannot read " + key + " from bucket " + impl_->bucket + ": " + reason(s));
  const auto* data = static_cast<const uint8_t*>(kvEntry_Value(e));
  std::vector<uint8_t> out(data, data + kvEntry_ValueLen(e));
  kvEntry_Destroy(e);
  return out;
}

void NatsConnection::KeyValue::erase(const std::string& key) {
  const natsStatus s = kvStore_Delete(impl_->kv, key.c_str());
  if (s != NATS_OK && s != NATS_NOT_FOUND)
    throw Error("NATS: cannot delete " + key + " from bucket " + impl_->bucket + ": " + reason(s));
}

std::vector<std::string> NatsConnection::KeyValue::keys() {
  kvKeysList list{};
  const natsStatus s = kvStore_Keys(&list, impl_->kv, nullptr);
  std::vector<std::string> out;
  if (s == NATS_NOT_FOUND) return out;  // an empty bucket
  if (s != NATS_OK) throw Error("NATS: cannot list bucket " + impl_->bucket + ": " + reason(s));
  for (int i = 0; i < list.Count; ++i) out.emplace_back(list.Keys[i]);
  kvKeysList_Destroy(&list);
  return out;
}

}  // namespace volcast::cluster
