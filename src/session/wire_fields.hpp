#pragma once
// Field codecs shared by the session channel's message parsers (messages.cpp, objects.cpp): names,
// finite numbers, spots, poses, flags. Private to src/session. Each get_* fails the Reader
// ("malformed <message>: ...") on a bad value.
#include <cmath>
#include <string>

#include "volcast/core/wire.hpp"
#include "volcast/session/messages.hpp"

namespace volcast::session::fields {

using wire::Reader;
using wire::Writer;

inline std::string get_name(Reader& r, const char* field) {
  std::string s = r.get_string();
  if (s.empty() || s.size() > kMaxNameBytes)
    r.fail(std::string(field) + " must be 1 to " + std::to_string(kMaxNameBytes) + " bytes");
  for (unsigned char c : s)
    if (c < 0x20 || c == 0x7f) r.fail(std::string(field) + " has a control character");
  return s;
}

inline float get_finite(Reader& r) {
  const float v = r.get<float>();
  if (!std::isfinite(v)) r.fail("a number is not finite");
  return v;
}

inline void put_spot(Writer& w, const Spot& s) {
  w.put<float>(s.x);
  w.put<float>(s.z);
  w.put<float>(s.yaw);
}

inline Spot get_spot(Reader& r) {
  Spot s;
  s.x = get_finite(r);
  s.z = get_finite(r);
  s.yaw = get_finite(r);
  return s;
}

inline void put_pose(Writer& w, const Pose& p) {
  for (int i = 0; i < 3; ++i) w.put<float>(p.position[i]);
  for (float v : {p.orientation.x(), p.orientation.y(), p.orientation.z(), p.orientation.w()})
    w.put<float>(v);
}

inline Pose get_pose(Reader& r) {
  Pose p;
  for (int i = 0; i < 3; ++i) p.position[i] = get_finite(r);
  const float x = get_finite(r), y = get_finite(r), z = get_finite(r), w = get_finite(r);
  p.orientation = Eigen::Quaternionf(w, x, y, z);
  if (std::abs(p.orientation.squaredNorm() - 1.0f) > 2e-3f)
    r.fail("orientation is not a unit quaternion");
  p.orientation.normalize();
  return p;
}

template <typename T>
T checked_enum(Reader& r, uint8_t max, const char* what) {
  const uint8_t v = r.get<uint8_t>();
  if (v > max) r.fail(std::string("unknown ") + what + " " + std::to_string(v));
  return static_cast<T>(v);
}

inline bool get_flag(Reader& r) {
  const uint8_t v = r.get<uint8_t>();
  if (v > 1) r.fail("a flag is neither 0 nor 1");
  return v == 1;
}

}  // namespace volcast::session::fields
