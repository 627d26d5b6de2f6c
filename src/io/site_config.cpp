#include "volcast/io/site_config.hpp"

#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <fstream>
#include <nlohmann/json.hpp>
#include <numbers>
#include <string>

#include "volcast/core/error.hpp"

namespace volcast {
namespace {

using Json = nlohmann::ordered_json;  // keeps the order of a user's keys when rewriting the file
constexpr double kToRadians = std::numbers::pi / 180;

// "world_from_camera" -> RigidTransform; `where` names the file and camera.
RigidTransform pose_from_json(const Json& pose, const std::string& where) {
  if (!pose.is_object())
    throw Error(where +
                ": \"world_from_camera\" must be an object {\"translation_m\": [x, y, z], "
                "\"rotation_deg\": [rx, ry, rz]}");
  Eigen::Vector3d translation_m = Eigen::Vector3d::Zero(), rotation_deg = Eigen::Vector3d::Zero();
  for (const auto& [key, value] : pose.items()) {
    Eigen::Vector3d* out = key == "translation_m"  ? &translation_m
                           : key == "rotation_deg" ? &rotation_deg
                                                   : nullptr;
    if (!out)
      throw Error(where + ": unknown key \"world_from_camera\".\"" + key +
                  "\" (expected \"translation_m\" and \"rotation_deg\")");
    bool ok = value.is_array() && value.size() == 3;
    for (size_t i = 0; ok && i < 3; ++i) {
      ok = value[i].is_number() && std::isfinite(value[i].get<double>());
      if (ok) (*out)[static_cast<Eigen::Index>(i)] = value[i].get<double>();
    }
    if (!ok)
      throw Error(where + ": \"world_from_camera\".\"" + key + "\" must be 3 finite numbers, got " +
                  value.dump());
  }
  return {rotation_from_degrees(rotation_deg), translation_m};
}

Json json_from_pose(const RigidTransform& pose) {
  const Eigen::Vector3d t = pose.translation, r = degrees_from_rotation(pose.rotation);
  return Json{{"translation_m", {t.x(), t.y(), t.z()}}, {"rotation_deg", {r.x(), r.y(), r.z()}}};
}

Json read_json(const std::filesystem::path& file) {
  std::ifstream in(file);
  if (!in) throw Error("cannot read site config '" + file.string() + "'");
  Json j = Json::parse(in, nullptr, false);
  if (j.is_discarded() || !j.is_object())
    throw Error("site config '" + file.string() + "' is not a JSON object");
  return j;
}

// The lens-model keys of an "intrinsics" object, in the order they are written.
struct IntrinsicsKey {
  const char* name;
  double Intrinsics::*field;
};
constexpr IntrinsicsKey kIntrinsicsKeys[] = {{"fx", &Intrinsics::fx},
                                             {"fy", &Intrinsics::fy},
                                             {"cx", &Intrinsics::cx},
                                             {"cy", &Intrinsics::cy},
                                             {"k1", &Intrinsics::k1},
                                             {"k2", &Intrinsics::k2},
                                             {"k3", &Intrinsics::k3},
                                             {"k4", &Intrinsics::k4},
                                             {"k5", &Intrinsics::k5},
                                             {"k6", &Intrinsics::k6},
                                             {"p1", &Intrinsics::p1},
                                             {"p2", &Intrinsics::p2},
                                             {"codx", &Intrinsics::codx},
                                             {"cody", &Intrinsics::cody},
                                             {"metric_radius", &Intrinsics::metric_radius}};
constexpr int kMaxSide = 8192;

// "fx,fy,cx,cy": four finite numbers, nothing else.
Intrinsics pinhole_from_text(const std::string& text, const std::string& where) {
  Intrinsics k;
  double* out[] = {&k.fx, &k.fy, &k.cx, &k.cy};
  size_t at = 0;
  for (size_t i = 0; i < 4; ++i) {
    const size_t end = i < 3 ? text.find(',', at) : text.size();
    const std::string field = text.substr(at, end == std::string::npos ? end : end - at);
    size_t used = 0;
    bool ok = end != std::string::npos && !field.empty();
    if (ok) {
      try {
        *out[i] = std::stod(field, &used);
      } catch (const std::exception&) {
        ok = false;
      }
    }
    if (!ok || used != field.size() || !std::isfinite(*out[i]))
      throw Error(where + ": \"intrinsics\" must be \"fx,fy,cx,cy\" (4 finite numbers), got \"" +
                  text + "\"");
    at = end + 1;
  }
  if (!(k.fx > 0 && k.fy > 0))
    throw Error(where + ": \"intrinsics\" \"" + text + "\": fx and fy must be positive");
  return k;
}

Intrinsics intrinsics_from_json(const Json& j, const std::string& where) {
  if (j.is_string()) return pinhole_from_text(j.get<std::string>(), where);
  if (!j.is_object())
    throw Error(where + ": \"intrinsics\" must be \"fx,fy,cx,cy\" or an object, got " + j.dump());
  Intrinsics k;
  for (const auto& item : j.items()) {
    // Names, not structured bindings: Clang 14 cannot capture a binding in a lambda.
    const std::string& key = item.key();
    const Json& value = item.value();
    const std::string what = where + ": \"intrinsics\".\"" + key + "\"";
    if (key == "width" || key == "height") {
      if (!value.is_number_integer() || value.get<int64_t>() < 1 || value.get<int64_t>() > kMaxSide)
        throw Error(what + " must be an integer 1.." + std::to_string(kMaxSide) + ", got " +
                    value.dump());
      (key == "width" ? k.width : k.height) = value.get<int>();
      continue;
    }
    const auto* known = std::find_if(std::begin(kIntrinsicsKeys), std::end(kIntrinsicsKeys),
                                     [&](const IntrinsicsKey& e) { return key == e.name; });
    if (known == std::end(kIntrinsicsKeys))
      throw Error(where + ": unknown key \"intrinsics\".\"" + key +
                  "\" (expected width, height, fx, fy, cx, cy, k1..k6, p1, p2, codx, cody, "
                  "metric_radius)");
    if (!value.is_number() || !std::isfinite(value.get<double>()))
      throw Error(what + " must be a finite number, got " + value.dump());
    k.*(known->field) = value.get<double>();
  }
  for (const char* required : {"fx", "fy", "cx", "cy"})
    if (!j.contains(required)) throw Error(where + ": \"intrinsics\" needs \"" + required + "\"");
  for (const char* key : {"fx", "fy"})
    if (!(j.at(key).get<double>() > 0))
      throw Error(where + ": \"intrinsics\".\"" + key + "\" must be positive, got " +
                  j.at(key).dump());
  if (k.metric_radius < 0)
    throw Error(where + ": \"intrinsics\".\"metric_radius\" must be >= 0 (0 = unlimited), got " +
                j.at("metric_radius").dump());
  return k;
}

Json json_from_intrinsics(const Intrinsics& k) {
  Json j = Json::object();
  if (k.width > 0) j["width"] = k.width;
  if (k.height > 0) j["height"] = k.height;
  for (const auto& e : kIntrinsicsKeys) j[e.name] = k.*(e.field);
  return j;
}

// A residual of "registration": -1 when absent.
double residual_from_json(const Json& r, const char* key, const std::string& where) {
  if (!r.contains(key)) return -1;
  const Json& v = r[key];
  if (!v.is_number() || !std::isfinite(v.get<double>()) || v.get<double>() < 0)
    throw Error(where + ": \"registration\".\"" + key +
                "\" must be a finite number >= 0 (mm), got " + v.dump());
  return v.get<double>();
}

SiteRegistration registration_from_json(const Json& r, const std::string& where) {
  if (!r.is_object())
    throw Error(where +
                ": \"registration\" must be an object {\"method\", \"feature_rms_mm\", "
                "\"overlap_rms_mm\"}, got " +
                r.dump());
  SiteRegistration out;
  if (r.contains("method")) {
    if (!r["method"].is_string())
      throw Error(where + ": \"registration\".\"method\" must be a string, got " +
                  r["method"].dump());
    out.method = r["method"].get<std::string>();
  }
  out.feature_rms_mm = residual_from_json(r, "feature_rms_mm", where);
  out.overlap_rms_mm = residual_from_json(r, "overlap_rms_mm", where);
  return out;
}

// The file's "cameras" list; Error naming the file when there is none.
const Json& cameras_of(const Json& j, const std::filesystem::path& file) {
  if (!j.contains("cameras") || !j["cameras"].is_array())
    throw Error("site config '" + file.string() +
                "' must be a JSON object with a \"cameras\" list");
  return j["cameras"];
}

std::string where_camera(const std::filesystem::path& file, size_t index) {
  return "site config '" + file.string() + "' camera " + std::to_string(index);
}

// One entry of "cameras"; `where` names the file and camera.
SiteCamera camera_from_json(const Json& e, const std::string& where) {
  if (!e.is_object()) throw Error(where + " is not an object");
  SiteCamera c;
  if (!e.contains("source") || !e["source"].is_string() || e["source"].get<std::string>().empty())
    throw Error(where + ": needs \"source\"");
  c.source = e["source"].get<std::string>();
  if (e.contains("name")) {
    if (!e["name"].is_string() || e["name"].get<std::string>().empty() ||
        e["name"].get<std::string>().size() > 64)
      throw Error(where + ": \"name\" must be a string of 1 to 64 characters");
    c.name = e["name"].get<std::string>();
  }
  if (e.contains("intrinsics")) c.intrinsics = intrinsics_from_json(e["intrinsics"], where);
  if (e.contains("world_from_camera"))
    c.world_from_camera = pose_from_json(e["world_from_camera"], where);
  if (e.contains("registration")) c.registration = registration_from_json(e["registration"], where);
  if (e.contains("filters")) c.filters_json = e["filters"].dump();
  return c;
}

void write_json(const std::filesystem::path& file, const Json& j) {
  const std::filesystem::path temporary = file.string() + ".tmp";
  {
    std::ofstream out(temporary, std::ios::trunc);
    out << j.dump(2) << "\n";
    if (!out.flush()) throw Error("cannot write site config '" + temporary.string() + "'");
  }
  std::error_code ec;
  std::filesystem::rename(temporary, file, ec);
  if (ec) throw Error("cannot write site config '" + file.string() + "': " + ec.message());
}

}  // namespace

std::vector<SiteCamera> read_site_config(const std::filesystem::path& file) {
  const Json j = read_json(file);
  std::vector<SiteCamera> out;
  for (const Json& e : cameras_of(j, file))
    out.push_back(camera_from_json(e, where_camera(file, out.size())));
  return out;
}

void write_site_config(const std::filesystem::path& file, std::span<const SiteCamera> cameras) {
  Json j = Json::object();
  Json& list = j["cameras"] = Json::array();
  for (const SiteCamera& c : cameras) {
    Json e = Json::object();
    e["source"] = c.source;
    if (!c.name.empty()) e["name"] = c.name;
    if (c.intrinsics) e["intrinsics"] = json_from_intrinsics(*c.intrinsics);
    if (c.world_from_camera) e["world_from_camera"] = json_from_pose(*c.world_from_camera);
    if (c.registration) {
      Json r = Json::object();
      r["method"] = c.registration->method;
      if (c.registration->feature_rms_mm >= 0) r["feature_rms_mm"] = c.registration->feature_rms_mm;
      if (c.registration->overlap_rms_mm >= 0) r["overlap_rms_mm"] = c.registration->overlap_rms_mm;
      e["registration"] = r;
    }
    if (!c.filters_json.empty()) {
      Json f = Json::parse(c.filters_json, nullptr, false);
      if (f.is_discarded() || !f.is_object())
        throw Error("cannot write " + where_camera(file, list.size()) +
                    ": filters_json is not a JSON object: " + c.filters_json);
      e["filters"] = std::move(f);
    }
    try {  // what is written must read back
      camera_from_json(e, where_camera(file, list.size()));
    } catch (const Error& error) {
      throw Error(std::string("cannot write ") + error.what());
    }
    list.push_back(std::move(e));
  }
  write_json(file, j);
}

std::filesystem::path resolve_site_source(const std::string& source,
                                          const std::filesystem::path& config_file) {
  const std::filesystem::path path(source);
  std::error_code ec;
  if (source.find("://") != std::string::npos) return path;  // a device URL (k4a://...)
  if (path.is_absolute() || std::filesystem::exists(path, ec)) return path;
  return config_file.parent_path() / path;
}

Eigen::Matrix3d rotation_from_degrees(const Eigen::Vector3d& rotation_deg) {
  const Eigen::Vector3d a = rotation_deg * kToRadians;
  return (Eigen::AngleAxisd(a.z(), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(a.y(), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(a.x(), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Eigen::Vector3d degrees_from_rotation(const Eigen::Matrix3d& r) {
  // R = Rz Ry Rx: R(2,0) = -sin ry, R(2,1) = cos ry sin rx, R(2,2) = cos ry cos rx,
  // R(1,0) = sin rz cos ry, R(0,0) = cos rz cos ry. atan2 keeps ry exact near +-90 degrees, where
  // asin(-R(2,0)) would lose half the digits.
  const double cos_ry = std::hypot(r(0, 0), r(1, 0));
  const double ry = std::atan2(-r(2, 0), cos_ry);
  double rx = 0, rz = 0;
  if (cos_ry > 1e-12) {
    rx = std::atan2(r(2, 1), r(2, 2));
    rz = std::atan2(r(1, 0), r(0, 0));
  } else {  // gimbal lock: only rz - rx (or rz + rx) is defined; take rx = 0
    rz = std::atan2(-r(0, 1), r(1, 1));
  }
  return Eigen::Vector3d(rx, ry, rz) / kToRadians + Eigen::Vector3d::Zero();  // -0 written as 0
}

std::vector<std::optional<RigidTransform>> read_site_poses(const std::filesystem::path& file) {
  const Json j = read_json(file);
  std::vector<std::optional<RigidTransform>> poses;
  for (const auto& camera : cameras_of(j, file)) {
    const std::string where = where_camera(file, poses.size());
    if (camera.is_object() && camera.contains("world_from_camera"))
      poses.push_back(pose_from_json(camera["world_from_camera"], where));
    else
      poses.emplace_back();
  }
  return poses;
}

void write_site_poses(const std::filesystem::path& file,
                      std::span<const RigidTransform> world_from_camera) {
  Json j = std::filesystem::exists(file) ? read_json(file) : Json::object();
  Json& cameras = j["cameras"];
  if (cameras.is_null()) cameras = Json::array();
  if (!cameras.is_array())
    throw Error("site config '" + file.string() + "': \"cameras\" must be a list");
  for (size_t i = 0; i < world_from_camera.size(); ++i) {
    if (i == cameras.size()) cameras.push_back(Json::object());
    if (!cameras[i].is_object())
      throw Error("site config '" + file.string() + "' camera " + std::to_string(i) +
                  " is not an object");
    cameras[i]["world_from_camera"] = json_from_pose(world_from_camera[i]);
  }
  write_json(file, j);
}

}  // namespace volcast
