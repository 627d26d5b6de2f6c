#include "volcast/assets/shared_case.hpp"

#include <algorithm>

namespace volcast {

SharedCase to_shared_case(const Case& c, const RoomLayout& room) {
  SharedCase out;
  out.name = c.name;
  const float table_top = room.table.center.y() + room.table.half_extent.y();
  float next_x = room.table.center.x() + 0.45f;
  for (const std::string& group : c.groups()) {
    BoundingBox box;  // room axes, mm, about the case origin
    for (const CasePart& p : c.parts)
      if (p.group == group)
        for (const Eigen::Vector3f& v : p.mesh.positions) box.extend(c.room_from_case * v);
    const Eigen::Vector3f center = box.center();
    SharedObject o;
    o.name = group;
    bool has_liver = false;
    for (const CasePart& p : c.parts) {
      if (p.group != group) continue;
      std::string lower = p.name;
      std::transform(lower.begin(), lower.end(), lower.begin(),
                     [](unsigned char ch) { return std::tolower(ch); });
      has_liver = has_liver || lower.find("liver") != std::string::npos;
      SharedPart part;
      part.name = p.name;
      part.rgba = p.rgba;
      part.positions.reserve(p.mesh.positions.size());
      for (const Eigen::Vector3f& v : p.mesh.positions) {
        part.positions.push_back((c.room_from_case * v - center) / 1000.0f);
        o.radius_m = std::max(o.radius_m, part.positions.back().norm());
      }
      for (const Eigen::Vector3f& n : p.mesh.normals) part.normals.push_back(c.room_from_case * n);
      part.indices = p.mesh.indices;
      o.parts.push_back(std::move(part));
    }
    const Eigen::Vector3f half = box.size() / 2000.0f;  // metres
    if (has_liver) {
      o.rest.position = {room.table.center.x(), table_top + 0.4f + half.y(), room.table.center.z()};
    } else if (half.maxCoeff() > 0.12f && half.maxCoeff() < 1.2f) {  // a body: on the table
      o.rest.position = {room.table.center.x(), table_top + 0.07f + half.y(),
                         room.table.center.z()};
    } else {
      o.rest.position = {next_x + half.x(), table_top + 0.4f + half.y(), room.table.center.z()};
      next_x += 2 * half.x() + 0.1f;
    }
    out.objects.push_back(std::move(o));
  }
  if (c.dicom) {
    const DicomSeries& d = *c.dicom;
    MonitorSeries m;
    m.width = d.width, m.height = d.height, m.slices = d.slices;
    m.spacing_mm = d.spacing_mm.cast<float>();
    m.hu = d.hu;
    m.overlay = d.overlay;
    m.overlay_label = d.overlay_label;
    out.monitor = std::move(m);
  }
  return out;
}

}  // namespace volcast
