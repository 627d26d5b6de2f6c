#include "volcast/cluster/session_state.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <cmath>
#include <cstdio>
#include <nlohmann/json.hpp>

#include "volcast/core/clock.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"

namespace volcast::cluster {
namespace {

float finite(const nlohmann::json& v, const char* what) {
  if (!v.is_number()) throw Error(std::string("session state: '") + what + "' is not a number");
  const double d = v.get<double>();
  if (!std::isfinite(d) || std::abs(d) > 1e6)
    throw Error(std::string("session state: '") + what + "' is out of range");
  return static_cast<float>(d);
}

template <typename T>
T whole(const nlohmann::json& v, const char* what) {
  if (!v.is_number_unsigned() || v.get<uint64_t>() > std::numeric_limits<T>::max())
    throw Error(std::string("session state: '") + what + "' is not a " +
                std::to_string(8 * sizeof(T)) + "-bit count");
  return static_cast<T>(v.get<uint64_t>());
}

const nlohmann::json& field(const nlohmann::json& j, const char* name) {
  if (!j.is_object() || !j.contains(name))
    throw Error(std::string("session state: no '") + name + "'");
  return j[name];
}

}  // namespace

std::string session_state_bucket(const std::string& site) {
  check_subject_token(site, "site name");
  return "volcast-" + site + "-sessions";
}

std::string session_state_key(const std::string& name) {
  std::string key;
  for (unsigned char c : name) {
    if ((c >= 'A' && c <= 'Z') || (c >= 'a' && c <= 'z') || (c >= '0' && c <= '9') || c == '_' ||
        c == '-') {
      key += static_cast<char>(c);
    } else {
      char hex[4];
      std::snprintf(hex, sizeof hex, "=%02X", c);
      key += hex;
    }
  }
  return key;
}

nlohmann::json session_state_json(const SessionHub& hub, const std::string& name) {
  bool exists = false;
  for (const auto& s : hub.sessions()) exists = exists || s.name == name;
  if (!exists) return nullptr;
  nlohmann::json j;
  j["session"] = name;
  j["case"] = hub.case_name();
  j["members"] = nlohmann::json::array();
  for (const SessionMember& m : hub.members(name))
    j["members"].push_back({{"id", m.id}, {"name", m.name}, {"role", session::to_string(m.role)}});
  j["objects"] = nlohmann::json::array();
  for (const session::ObjectState& o : hub.objects(name)) {
    const auto& p = o.pose.position;
    const auto& q = o.pose.orientation;
    j["objects"].push_back({{"object", o.object},
                            {"owner", o.owner},
                            {"sequence", o.sequence},
                            {"position", {p.x(), p.y(), p.z()}},
                            {"orientation", {q.w(), q.x(), q.y(), q.z()}}});
  }
  if (const auto m = hub.monitor(name))
    j["monitor"] = {
        {"slice", m->slice}, {"center", m->center}, {"width", m->width}, {"overlay", m->overlay}};
  return j;
}

bool restore_session_state(SessionHub& hub, const nlohmann::json& state) {
  const auto& name = field(state, "session");
  const auto& case_name = field(state, "case");
  if (!name.is_string() || !case_name.is_string())
    throw Error("session state: 'session' and 'case' must be strings");
  std::vector<session::ObjectState> objects;
  const auto& list = field(state, "objects");
  if (!list.is_array() || list.size() > 65536)
    throw Error("session state: 'objects' is not a list");
  for (const auto& o : list) {
    session::ObjectState s;
    s.object = whole<uint16_t>(field(o, "object"), "object");
    s.sequence = whole<uint32_t>(field(o, "sequence"), "sequence");
    const auto& p = field(o, "position");
    const auto& q = field(o, "orientation");
    if (!p.is_array() || p.size() != 3 || !q.is_array() || q.size() != 4)
      throw Error("session state: an object's position needs 3 numbers, its orientation 4");
    s.pose.position = {finite(p[0], "position"), finite(p[1], "position"),
                       finite(p[2], "position")};
    Eigen::Quaternionf r(finite(q[0], "orientation"), finite(q[1], "orientation"),
                         finite(q[2], "orientation"), finite(q[3], "orientation"));
    if (r.norm() < 0.5f || r.norm() > 1.5f)
      throw Error("session state: an object's orientation is not a unit quaternion");
    s.pose.orientation = r.normalized();
    objects.push_back(s);
  }
  std::optional<MonitorState> monitor;
  if (state.contains("monitor")) {
    const auto& m = state["monitor"];
    MonitorState s;
    s.slice = whole<uint16_t>(field(m, "slice"), "slice");
    s.center = finite(field(m, "center"), "center");
    s.width = finite(field(m, "width"), "width");
    if (s.width < 1) throw Error("session state: a window width under 1 HU");
    if (!field(m, "overlay").is_boolean()) throw Error("session state: 'overlay' is no boolean");
    s.overlay = m["overlay"].get<bool>();
    monitor = s;
  }
  return hub.restore(name.get<std::string>(), case_name.get<std::string>(), objects, monitor);
}

SessionStateMirror::SessionStateMirror(NatsConnection& nats, const std::string& site,
                                       SessionHub& hub, int replicas, int period_ms)
    : hub_(hub), period_ms_(period_ms) {
  const std::string bucket = session_state_bucket(site);
  kv_ = nats.key_value(bucket, replicas);
  for (const std::string& key : kv_->keys()) {
    try {
      const auto value = kv_->get(key);
      if (!value) continue;
      const auto state = nlohmann::json::parse(value->begin(), value->end());
      if (restore_session_state(hub_, state)) {
        ++stats_.restored;
        written_[key];  // known: deleted with its session
      } else {
        spdlog::info("session state '{}' in {} was saved for case '{}': not restored", key, bucket,
                     printable(state.value("case", std::string())));
      }
    } catch (const std::exception& e) {  // Error, or nlohmann's parse error
      ++stats_.errors;
      stats_.last_error = "session state " + key + ": " + e.what();
      spdlog::warn("{} in {}: not restored", stats_.last_error, bucket);
    }
  }
  thread_ = std::thread([this] { run(); });
}

SessionStateMirror::~SessionStateMirror() {
  {
    std::lock_guard lock(mutex_);
    stop_ = true;
  }
  wake_.notify_all();
  thread_.join();
}

SessionStateStats SessionStateMirror::stats() const {
  std::lock_guard lock(mutex_);
  return stats_;
}

void SessionStateMirror::run() {
  std::unique_lock lock(mutex_);
  while (true) {
    const bool stopping =
        wake_.wait_for(lock, std::chrono::milliseconds(period_ms_), [this] { return stop_; });
    lock.unlock();
    write_changes();
    lock.lock();
    if (stopping) return;
  }
}

void SessionStateMirror::write_changes() {
  const auto sessions = hub_.sessions();
  // The states of sessions the hub has removed (nobody in them any more) go with them.
  for (auto it = written_.begin(); it != written_.end();) {
    bool exists = false;
    for (const auto& summary : sessions)
      exists = exists || session_state_key(summary.name) == it->first;
    if (exists) {
      ++it;
      continue;
    }
    try {
      kv_->erase(it->first);
      it = written_.erase(it);
      std::lock_guard lock(mutex_);
      ++stats_.deletes;
    } catch (const Error& e) {
      std::lock_guard lock(mutex_);
      if (stats_.errors++ == 0) spdlog::warn("session state not deleted: {}", e.what());
      stats_.last_error = e.what();
      ++it;
    }
  }
  for (const auto& summary : sessions) {
    nlohmann::json state = session_state_json(hub_, summary.name);
    if (state.is_null()) continue;
    const std::string key = session_state_key(summary.name);
    const std::string text = state.dump();
    if (written_[key] == text) continue;
    state["saved_us"] = wall_clock_us();
    const std::string value = state.dump();
    try {
      kv_->put(key, {reinterpret_cast<const uint8_t*>(value.data()), value.size()});
      written_[key] = text;
      std::lock_guard lock(mutex_);
      ++stats_.writes;
    } catch (const Error& e) {
      std::lock_guard lock(mutex_);
      if (stats_.errors++ == 0) spdlog::warn("session state not saved: {}", e.what());
      stats_.last_error = e.what();
    }
  }
}

}  // namespace volcast::cluster
