#include "volcast/session/objects.hpp"

#include <algorithm>
#include <cmath>

#include "feature_layouts.hpp"
#include "volcast/core/error.hpp"
#include "wire_fields.hpp"

namespace volcast::session {

using fields::decode;
using fields::encode;
using fields::In;
using fields::Of;
using fields::Out;
using wire::Reader;
using wire::Writer;

namespace {

int8_t snorm8(float v) {
  return static_cast<int8_t>(std::lround(std::clamp(v, -1.0f, 1.0f) * 127.0f));
}

// Checks that `count` items of `bytes` each fit in what is left, before anything is allocated.
void need_items(const Reader& r, uint64_t count, uint64_t bytes, const char* what) {
  if (count * bytes > r.remaining())
    r.fail(std::string(what) + ": " + std::to_string(count) +
           " declared, more than the message holds");
}

}  // namespace

std::vector<uint8_t> serialize(const SharedCase& c) {
  std::vector<uint8_t> out;
  Writer w(out);
  Out io{w};
  w.put<uint32_t>(c.generation);
  w.put_string(c.name);
  if (c.objects.size() > kMaxCaseObjects) throw Error("case: too many objects");
  w.put<uint16_t>(static_cast<uint16_t>(c.objects.size()));
  for (const SharedObject& o : c.objects) {
    w.put_string(o.name);
    io.pose(o.rest, "rest");
    if (o.parts.size() > kMaxObjectParts) throw Error("case: too many parts in " + o.name);
    w.put<uint16_t>(static_cast<uint16_t>(o.parts.size()));
    for (const SharedPart& p : o.parts) {
      w.put_string(p.name);
      for (int i = 0; i < 4; ++i)
        w.put<uint8_t>(static_cast<uint8_t>(std::lround(std::clamp(p.rgba[i], 0.0f, 1.0f) * 255)));
      w.put<uint32_t>(static_cast<uint32_t>(p.positions.size()));
      w.put<uint32_t>(static_cast<uint32_t>(p.indices.size() / 3));
      for (const Eigen::Vector3f& v : p.positions) w.put_array<float>({v.data(), 3});
      for (size_t i = 0; i < p.positions.size(); ++i) {
        const Eigen::Vector3f n = i < p.normals.size() ? p.normals[i] : Eigen::Vector3f::UnitY();
        for (int k = 0; k < 3; ++k) w.put<int8_t>(snorm8(n[k]));
      }
      w.put_array<uint32_t>(std::span(p.indices).first(p.indices.size() / 3 * 3));
    }
  }
  w.put<uint8_t>(c.monitor ? 1 : 0);
  if (c.monitor) {
    const MonitorSeries& m = *c.monitor;
    w.put<uint16_t>(static_cast<uint16_t>(m.width));
    w.put<uint16_t>(static_cast<uint16_t>(m.height));
    w.put<uint16_t>(static_cast<uint16_t>(m.slices));
    for (int i = 0; i < 3; ++i) w.put<float>(m.spacing_mm[i]);
    w.put_array<int16_t>(m.hu);
    w.put<uint8_t>(m.overlay.empty() ? 0 : 1);
    if (!m.overlay.empty()) {
      w.put_string(m.overlay_label);
      std::vector<uint8_t> bits((m.overlay.size() + 7) / 8, 0);
      for (size_t i = 0; i < m.overlay.size(); ++i)
        if (m.overlay[i]) bits[i / 8] = static_cast<uint8_t>(bits[i / 8] | (1u << (i % 8)));
      w.append(bits.data(), bits.size());
    }
  }
  if (out.size() > kMaxCaseBytes)
    throw Error("case: " + std::to_string(out.size() >> 20) + " MiB is over the limit of " +
                std::to_string(kMaxCaseBytes >> 20) + " MiB");
  return out;
}

SharedCase parse_case(std::span<const uint8_t> p) {
  Reader r(p, "case");
  In in{r};
  SharedCase c;
  c.generation = r.get<uint32_t>();
  c.name = r.get_string();
  const uint16_t objects = r.get<uint16_t>();
  if (objects > kMaxCaseObjects)
    r.fail("more than " + std::to_string(kMaxCaseObjects) + " objects");
  uint64_t triangles_total = 0;
  c.objects.resize(objects);
  for (SharedObject& o : c.objects) {
    in.name(o.name, "object name");
    in.pose(o.rest, "rest");
    const uint16_t parts = r.get<uint16_t>();
    if (parts > kMaxObjectParts) r.fail("more than " + std::to_string(kMaxObjectParts) + " parts");
    o.parts.resize(parts);
    for (SharedPart& part : o.parts) {
      in.name(part.name, "part name");
      for (int i = 0; i < 4; ++i) part.rgba[i] = r.get<uint8_t>() / 255.0f;
      const uint32_t vertices = r.get<uint32_t>(), triangles = r.get<uint32_t>();
      triangles_total += triangles;
      if (triangles_total > kMaxCaseTriangles)
        r.fail("more than " + std::to_string(kMaxCaseTriangles) + " triangles");
      need_items(r, vertices, 15, "vertices");
      part.positions.resize(vertices);
      for (Eigen::Vector3f& v : part.positions) {
        for (int i = 0; i < 3; ++i) in.finite(v[i], "position");
        o.radius_m = std::max(o.radius_m, v.norm());
      }
      part.normals.resize(vertices);
      for (Eigen::Vector3f& n : part.normals) {
        for (int i = 0; i < 3; ++i) n[i] = r.get<int8_t>() / 127.0f;
        n = n.norm() > 0 ? Eigen::Vector3f(n.normalized()) : Eigen::Vector3f::UnitY();
      }
      need_items(r, triangles, 12, "triangles");
      part.indices.resize(static_cast<size_t>(triangles) * 3);
      for (uint32_t& index : part.indices) {
        index = r.get<uint32_t>();
        if (index >= vertices) r.fail("an index is out of range");
      }
    }
  }
  bool has_monitor = false;
  in.flag(has_monitor, "has_monitor");
  if (has_monitor) {
    MonitorSeries m;
    m.width = r.get<uint16_t>();
    m.height = r.get<uint16_t>();
    m.slices = r.get<uint16_t>();
    if (m.width < 1 || m.height < 1 || m.slices < 1) r.fail("an empty monitor series");
    for (int i = 0; i < 3; ++i) {
      in.finite(m.spacing_mm[i], "spacing_mm");
      if (m.spacing_mm[i] <= 0) r.fail("a spacing is not positive");
    }
    const uint64_t pixels = static_cast<uint64_t>(m.width) * m.height * m.slices;
    need_items(r, pixels, 2, "monitor pixels");
    m.hu.resize(pixels);
    for (int16_t& v : m.hu) v = r.get<int16_t>();
    bool has_overlay = false;
    in.flag(has_overlay, "has_overlay");
    if (has_overlay) {
      m.overlay_label = r.get_string();
      need_items(r, (pixels + 7) / 8, 1, "overlay bytes");
      m.overlay.resize(pixels);
      uint8_t byte = 0;
      for (uint64_t i = 0; i < pixels; ++i) {
        if (i % 8 == 0) byte = r.get<uint8_t>();
        m.overlay[i] = (byte >> (i % 8)) & 1;
      }
    }
    c.monitor = std::move(m);
  }
  r.expect_end();
  return c;
}

template <typename Io, Of<ObjectState> M>
void layout(Io& io, M& s) {
  io.number(s.generation, "generation");
  io.number(s.object, "object");
  io.number(s.owner, "owner");
  io.number(s.sequence, "sequence");
  io.number(s.time_us, "time_us");
  io.pose(s.pose, "pose");
}

std::vector<uint8_t> serialize(const ObjectState& s) {
  return encode(s);
}

ObjectState parse_object_state(std::span<const uint8_t> p) {
  return decode<ObjectState>(p, "object state");
}

namespace {

// 0x0d's fields, which 0x4d follows with `by`.
template <typename Io, typename M>
void monitor_layout(Io& io, M& s) {
  io.number(s.generation, "generation");
  io.number(s.slice, "slice");
  io.finite(s.center, "center");
  io.finite(s.width, "width");
  io.check(s.width >= 1, "window width below 1 HU");
  io.flag(s.overlay, "overlay");
}

const auto kSetMonitor = [](auto& io, auto& s) { monitor_layout(io, s); };
const auto kMonitorState = [](auto& io, auto& s) {
  monitor_layout(io, s);
  io.number(s.by, "by");
};

}  // namespace

std::vector<uint8_t> serialize(const MonitorState& s) {
  return encode(s, kMonitorState);
}

MonitorState parse_monitor_state(std::span<const uint8_t> p) {
  return decode<MonitorState>(p, "monitor state", kMonitorState);
}

std::vector<uint8_t> serialize_set_monitor(const MonitorState& s) {
  return encode(s, kSetMonitor);
}

MonitorState parse_set_monitor(std::span<const uint8_t> p) {
  return decode<MonitorState>(p, "set monitor", kSetMonitor);
}

namespace {

// 0x0a without a pose, 0x0b and 0x0c with one.
auto request_layout(bool with_pose) {
  return [with_pose](auto& io, auto& q) {
    io.number(q.generation, "generation");
    io.number(q.object, "object");
    if (with_pose) io.pose(q.pose, "pose");
  };
}

}  // namespace

std::vector<uint8_t> serialize(const ObjectRequest& q, bool with_pose) {
  return encode(q, request_layout(with_pose));
}

ObjectRequest parse_object_request(std::span<const uint8_t> p, bool with_pose) {
  return decode<ObjectRequest>(p, "object request", request_layout(with_pose));
}

bool describe_objects(Type type, std::vector<LayoutField>& out) {
  using fields::describe;
  switch (type) {
    case Type::kGrab:
      out = describe<ObjectRequest>(request_layout(false));
      return true;
    case Type::kObjectMove:
    case Type::kRelease:
      out = describe<ObjectRequest>(request_layout(true));
      return true;
    case Type::kSetMonitor:
      out = describe<MonitorState>(kSetMonitor);
      return true;
    case Type::kObjectState:
      out = describe<ObjectState>();
      return true;
    case Type::kMonitorState:
      out = describe<MonitorState>(kMonitorState);
      return true;
    default:
      return false;
  }
}

}  // namespace volcast::session
