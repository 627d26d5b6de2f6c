#include "volcast/io/site_config.hpp"

#include <Eigen/Geometry>
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

}  // namespace

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
  if (!j.contains("cameras") || !j["cameras"].is_array())
    throw Error("site config '" + file.string() +
                "' must be a JSON object with a \"cameras\" list");
  std::vector<std::optional<RigidTransform>> poses;
  for (const auto& camera : j["cameras"]) {
    const std::string where =
        "site config '" + file.string() + "' camera " + std::to_string(poses.size());
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

}  // namespace volcast
