#include "volcast/core/ray_table.hpp"

#include <limits>

namespace volcast {

RayTable make_ray_table(const Intrinsics& k) {
  RayTable t;
  t.width = k.width;
  t.height = k.height;
  const size_t n = static_cast<size_t>(k.width) * k.height;
  t.x.assign(n, std::numeric_limits<float>::quiet_NaN());
  t.y.assign(n, std::numeric_limits<float>::quiet_NaN());
  for (int v = 0; v < k.height; ++v) {
    for (int u = 0; u < k.width; ++u) {
      if (auto xy = unproject_pixel(k, {u, v})) {
        const size_t i = static_cast<size_t>(v) * k.width + u;
        t.x[i] = static_cast<float>(xy->x());
        t.y[i] = static_cast<float>(xy->y());
      }
    }
  }
  return t;
}

}  // namespace volcast
