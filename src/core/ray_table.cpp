#include "volcast/core/ray_table.hpp"

#include <algorithm>
#include <deque>
#include <future>
#include <limits>
#include <mutex>
#include <utility>

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

std::shared_ptr<const RayTable> shared_ray_table(const Intrinsics& intrinsics) {
  using Table = std::shared_future<std::shared_ptr<const RayTable>>;
  static std::mutex mutex;
  static std::deque<std::pair<Intrinsics, Table>> kept;  // the newest asked for last, at most 16
  std::promise<std::shared_ptr<const RayTable>> making;
  Table table;
  bool maker = false;
  {
    std::lock_guard lock(mutex);
    const auto it = std::find_if(kept.begin(), kept.end(),
                                 [&](const auto& entry) { return entry.first == intrinsics; });
    if (it != kept.end()) {
      table = it->second;
      std::rotate(it, it + 1, kept.end());
    } else {
      table = making.get_future().share();
      maker = true;
      kept.emplace_back(intrinsics, table);
      if (kept.size() > 16) kept.pop_front();
    }
  }
  if (maker) {
    try {
      making.set_value(std::make_shared<const RayTable>(make_ray_table(intrinsics)));
    } catch (...) {  // out of memory: the callers waiting are told, the next one tries again
      making.set_exception(std::current_exception());
      std::lock_guard lock(mutex);
      std::erase_if(kept, [&](const auto& entry) { return entry.first == intrinsics; });
    }
  }
  return table.get();
}

}  // namespace volcast
