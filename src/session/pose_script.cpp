#include "volcast/session/pose_script.hpp"

#include "volcast/session/annotations.hpp"

#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>

#include <sstream>
#include "volcast/session/objects.hpp"

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

constexpr float kDegToRad = 3.14159265358979f / 180.0f;

Eigen::Quaternionf head_orientation(float yaw_deg, float pitch_deg) {
  return Eigen::Quaternionf(Eigen::AngleAxisf(yaw_deg * kDegToRad, Eigen::Vector3f::UnitY()) *
                            Eigen::AngleAxisf(pitch_deg * kDegToRad, Eigen::Vector3f::UnitX()));
}

Eigen::Vector3f vec3(const nlohmann::json& j, const std::string& where) {
  if (!j.is_array() || j.size() != 3)
    throw Error("pose script: " + where + " must be [x, y, z] in metres");
  Eigen::Vector3f v;
  for (int i = 0; i < 3; ++i) {
    if (!j[i].is_number()) throw Error("pose script: " + where + " must hold numbers");
    const double d = j[i].get<double>();
    if (!std::isfinite(d) || std::abs(d) > 100)
      throw Error("pose script: " + where + " is out of range (|value| <= 100 m)");
    v[i] = static_cast<float>(d);
  }
  return v;
}

float number(const nlohmann::json& j, const char* key, float fallback, const std::string& where) {
  if (!j.contains(key)) return fallback;
  if (!j[key].is_number()) throw Error("pose script: " + where + "." + key + " must be a number");
  const double v = j[key].get<double>();
  if (!std::isfinite(v) || std::abs(v) > 1e6)
    throw Error("pose script: " + where + "." + key + " is out of range");
  return static_cast<float>(v);
}

}  // namespace

BodyPose PoseScript::at(double t_s) const {
  BodyPose b;
  if (keys.empty()) return b;
  const double end = keys.back().t_s;
  if (loop && end > 0 && t_s > end) t_s = std::fmod(t_s, end);
  const PoseKey* a = &keys.front();
  const PoseKey* c = &keys.front();
  float f = 0;
  if (t_s >= end) {
    a = c = &keys.back();
  } else {
    for (size_t i = 1; i < keys.size(); ++i)
      if (t_s < keys[i].t_s) {
        a = &keys[i - 1];
        c = &keys[i];
        f = t_s <= a->t_s ? 0 : float((t_s - a->t_s) / (c->t_s - a->t_s));
        break;
      }
  }
  const auto mix = [f](const auto& x, const auto& y) { return x + (y - x) * f; };
  b.head.position = mix(a->head, c->head);
  b.head.orientation =
      head_orientation(mix(a->yaw_deg, c->yaw_deg), mix(a->pitch_deg, c->pitch_deg));
  b.hands_tracked = a->hands && c->hands;
  const Eigen::Quaternionf body_turn(
      Eigen::AngleAxisf(mix(a->yaw_deg, c->yaw_deg) * kDegToRad, Eigen::Vector3f::UnitY()));
  b.left_hand = {mix(a->left, c->left), body_turn};
  b.right_hand = {mix(a->right, c->right), body_turn};
  return b;
}

PoseScript idle_pose_script() {
  PoseScript s;
  for (int i = 0; i <= 8; ++i) {
    const float phase = float(i) / 8.0f * 2 * 3.14159265f;
    PoseKey k;
    k.t_s = i * 0.25;
    k.head = {0.04f * std::sin(phase), 1.6f + 0.01f * std::sin(2 * phase), 0.02f * std::cos(phase)};
    k.yaw_deg = 8 * std::sin(phase);
    k.pitch_deg = -8;
    k.hands = true;
    k.left = {-0.22f, 1.05f + 0.05f * std::sin(phase), -0.3f};
    k.right = {0.22f, 1.05f - 0.05f * std::sin(phase), -0.3f};
    s.keys.push_back(k);
  }
  return s;
}

PoseScript parse_pose_script(const std::string& text) {
  nlohmann::json j;
  try {
    j = nlohmann::json::parse(text);
  } catch (const std::exception& e) {
    throw Error(std::string("pose script: not JSON: ") + e.what());
  }
  if (!j.is_object()) throw Error("pose script: must be a JSON object with \"keys\"");
  PoseScript s;
  if (j.contains("loop")) {
    if (!j["loop"].is_boolean()) throw Error("pose script: loop must be true or false");
    s.loop = j["loop"].get<bool>();
  }
  if (!j.contains("keys") || !j["keys"].is_array() || j["keys"].empty())
    throw Error("pose script: \"keys\" must be a non-empty list");
  for (size_t i = 0; i < j["keys"].size(); ++i) {
    const auto& k = j["keys"][i];
    const std::string where = "keys[" + std::to_string(i) + "]";
    if (!k.is_object()) throw Error("pose script: " + where + " must be an object");
    PoseKey key;
    key.t_s = number(k, "t", -1, where);
    if (key.t_s < 0) throw Error("pose script: " + where + ".t must be given, >= 0 seconds");
    if (!s.keys.empty() && key.t_s <= s.keys.back().t_s)
      throw Error("pose script: " + where + ".t must be later than the key before");
    if (k.contains("head")) key.head = vec3(k["head"], where + ".head");
    key.yaw_deg = number(k, "yaw_deg", 0, where);
    key.pitch_deg = number(k, "pitch_deg", 0, where);
    if (k.contains("left") != k.contains("right"))
      throw Error("pose script: " + where + " must give both hands or neither");
    if (k.contains("left")) {
      key.hands = true;
      key.left = vec3(k["left"], where + ".left");
      key.right = vec3(k["right"], where + ".right");
    }
    s.keys.push_back(key);
  }
  if (j.contains("teleports")) {
    if (!j["teleports"].is_array()) throw Error("pose script: \"teleports\" must be a list");
    for (size_t i = 0; i < j["teleports"].size(); ++i) {
      const auto& t = j["teleports"][i];
      const std::string where = "teleports[" + std::to_string(i) + "]";
      if (!t.is_object() || !t.contains("to") || !t["to"].is_array() || t["to"].size() != 2 ||
          !t["to"][0].is_number() || !t["to"][1].is_number())
        throw Error("pose script: " + where + " needs \"to\": [x, z] in metres");
      ScriptedTeleport st;
      st.t_s = number(t, "t", -1, where);
      if (st.t_s < 0) throw Error("pose script: " + where + ".t must be given, >= 0 seconds");
      const double x = t["to"][0].get<double>(), z = t["to"][1].get<double>();
      if (!std::isfinite(x) || !std::isfinite(z) || std::abs(x) > 100 || std::abs(z) > 100)
        throw Error("pose script: " + where + ".to is out of range (|value| <= 100 m)");
      st.to.x = static_cast<float>(x);
      st.to.z = static_cast<float>(z);
      st.to.yaw = number(t, "yaw_deg", 0, where) * kDegToRad;
      if (!s.teleports.empty() && st.t_s < s.teleports.back().t_s)
        throw Error("pose script: teleports must be in time order");
      s.teleports.push_back(st);
    }
  }
  const auto list = [&](const char* key) {
    if (j.contains(key) && !j[key].is_array())
      throw Error(std::string("pose script: \"") + key + "\" must be a list");
    return j.contains(key) ? j[key] : nlohmann::json::array();
  };
  const nlohmann::json grabs = list("grabs");
  for (size_t i = 0; i < grabs.size(); ++i) {
    const auto& g = grabs[i];
    const std::string where = "grabs[" + std::to_string(i) + "]";
    if (!g.is_object() || !g.contains("object") || !g["object"].is_string())
      throw Error("pose script: " + where + " needs \"object\": a name");
    ScriptedGrab sg;
    sg.object = g["object"].get<std::string>();
    sg.t_s = number(g, "t", -1, where);
    sg.for_s = number(g, "for_s", 1, where);
    sg.turn_deg_per_s = number(g, "turn_deg_per_s", 0, where);
    if (sg.t_s < 0 || sg.for_s <= 0)
      throw Error("pose script: " + where + " needs t >= 0 and for_s > 0 seconds");
    if (!s.grabs.empty() && sg.t_s < s.grabs.back().t_s)
      throw Error("pose script: grabs must be in time order");
    s.grabs.push_back(sg);
  }
  const nlohmann::json monitor = list("monitor");
  for (size_t i = 0; i < monitor.size(); ++i) {
    const auto& m = monitor[i];
    const std::string where = "monitor[" + std::to_string(i) + "]";
    if (!m.is_object()) throw Error("pose script: " + where + " must be an object");
    ScriptedMonitor sm;
    sm.t_s = number(m, "t", -1, where);
    if (sm.t_s < 0) throw Error("pose script: " + where + ".t must be given, >= 0 seconds");
    sm.slice = static_cast<int>(number(m, "slice", -1, where));
    if (m.contains("preset")) {
      if (!m["preset"].is_string()) throw Error("pose script: " + where + ".preset must be a name");
      const WindowPreset p = window_preset(m["preset"].get<std::string>());
      sm.center = p.center, sm.width = p.width;
    }
    if (m.contains("center")) sm.center = number(m, "center", 0, where);
    if (m.contains("width")) sm.width = std::max(1.0f, number(m, "width", 1, where));
    if (m.contains("overlay")) {
      if (!m["overlay"].is_boolean())
        throw Error("pose script: " + where + ".overlay must be true or false");
      sm.overlay = m["overlay"].get<bool>();
    }
    if (!s.monitor.empty() && sm.t_s < s.monitor.back().t_s)
      throw Error("pose script: monitor changes must be in time order");
    s.monitor.push_back(sm);
  }
  const nlohmann::json drawing = list("drawing");
  for (size_t i = 0; i < drawing.size(); ++i) {
    const auto& d = drawing[i];
    const std::string where = "drawing[" + std::to_string(i) + "]";
    if (!d.is_object() || !d.contains("kind") || !d["kind"].is_string())
      throw Error("pose script: " + where + " needs \"kind\": point, stroke, arrow or label");
    ScriptedDrawing sd;
    const std::string kind = d["kind"].get<std::string>();
    sd.t_s = number(d, "t", -1, where);
    if (sd.t_s < 0) throw Error("pose script: " + where + ".t must be given, >= 0 seconds");
    const auto need = [&](const char* field) {
      if (!d.contains(field)) throw Error("pose script: " + where + " needs \"" + field + "\"");
      return vec3(d[field], where + "." + field);
    };
    if (kind == "point" || kind == "stroke") {
      sd.for_s = number(d, "for_s", 1, where);
      if (sd.for_s <= 0) throw Error("pose script: " + where + ".for_s must be > 0 seconds");
    }
    if (kind == "point") {
      sd.kind = ScriptedDrawing::Kind::kPoint;
      sd.points = {need("at")};
    } else if (kind == "stroke") {
      sd.kind = ScriptedDrawing::Kind::kStroke;
      if (!d.contains("path") || !d["path"].is_array() || d["path"].size() < 2 ||
          d["path"].size() > session::kMaxStrokePoints)
        throw Error("pose script: " + where + ".path must be a list of 2 to 256 points");
      for (size_t k = 0; k < d["path"].size(); ++k)
        sd.points.push_back(vec3(d["path"][k], where + ".path[" + std::to_string(k) + "]"));
    } else if (kind == "arrow") {
      sd.kind = ScriptedDrawing::Kind::kArrow;
      sd.points = {need("from"), need("to")};
    } else if (kind == "label") {
      sd.kind = ScriptedDrawing::Kind::kLabel;
      sd.points = {need("at")};
      if (!d.contains("text") || !d["text"].is_string())
        throw Error("pose script: " + where + " needs \"text\"");
      sd.text = session::check_label_text(d["text"].get<std::string>());
    } else {
      throw Error("pose script: " + where + ".kind '" + kind +
                  "' is none of point, stroke, arrow, label");
    }
    if (!s.drawing.empty() && sd.t_s < s.drawing.back().t_s)
      throw Error("pose script: drawing events must be in time order");
    s.drawing.push_back(std::move(sd));
  }
  return s;
}

PoseScript read_pose_script(const std::filesystem::path& path) {
  std::ifstream in(path);
  if (!in) throw Error("cannot read pose script " + path.string());
  std::stringstream ss;
  ss << in.rdbuf();
  try {
    return parse_pose_script(ss.str());
  } catch (const Error& e) {
    throw Error(path.string() + ": " + e.what());
  }
}

}  // namespace volcast
