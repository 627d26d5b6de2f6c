// libFuzzer target: the NATS chunk reassembler (volcast/cluster/chunks.hpp) on hostile messages.
// The input is cut into messages at each 0xFE 0xFF pair; the first message byte 0x01 turns it into
// a chunk of a valid frame set with the rest patched in, so the checks behind the header are
// reached. A completed body must lie wholly inside the limit; nothing may crash or read past a
// message.
#include <cstdint>
#include <cstring>
#include <span>
#include <vector>

#include "volcast/cluster/chunks.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace volcast::cluster;
  constexpr size_t kLimit = 1 << 20;
  std::vector<uint8_t> body(2500, 7), scratch;
  std::vector<std::vector<uint8_t>> valid;
  chunk_frame_set({5, 1, true, body}, 1036, scratch,
                  [&](std::span<const uint8_t> m) { valid.emplace_back(m.begin(), m.end()); });
  Reassembler r(kLimit);
  size_t start = 0, k = 0;
  for (size_t i = 0; i <= size; ++i) {
    if (i < size && !(i + 1 < size && data[i] == 0xFE && data[i + 1] == 0xFF)) continue;
    std::vector<uint8_t> m(data + start, data + i);
    if (!m.empty() && m[0] == 0x01) {  // a valid chunk, patched from offset 1 on
      std::vector<uint8_t> v = valid[k++ % valid.size()];
      for (size_t j = 1; j < m.size() && j < v.size(); ++j) v[j] ^= m[j];
      m = std::move(v);
    }
    if (r.add(m) && r.done().body.size() > kLimit) __builtin_trap();
    start = i + 2;
    ++i;
  }
  return 0;
}
