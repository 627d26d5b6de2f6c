// The per-frame filter path allocates nothing once warm. This binary replaces the global
// operator new to count heap allocations, so it holds only this test.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "support/test_data.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/filter/chain.hpp"

// GCC cannot see that the replaced operator new below returns malloc'd memory.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

static std::atomic<long> g_allocations{0};
void* operator new(size_t n) {
  ++g_allocations;
  if (void* p = std::malloc(n ? n : 1)) return p;
  throw std::bad_alloc();
}
void operator delete(void* p) noexcept {
  std::free(p);
}
void operator delete(void* p, size_t) noexcept {
  std::free(p);
}
namespace volcast {
namespace {

TEST(FilterChain, AllocatesNothingPerFrameOnceWarm) {
  auto src =
      open_source(test::hands_dir(), SourceOptions{Intrinsics{0, 0, 460, 460, 320, 180}, {}, {}});
  std::vector<CameraFrame> frames;
  for (int i = 0; i < 20; ++i) frames.push_back(src->next());
  FilterConfig c = paper_chain_config(640, 360);
  c.crop = CropRect{10, 10, 600, 340};
  c.flying_pixels = FlyingPixelFilter{};
  FilterChain chain(src->calibration().depth, c);
  CameraFrame out;
  chain.apply(frames[0], out);  // first frame sizes every buffer
  const long probe = g_allocations.load();
  delete new std::vector<int>(3);  // the counter works
  ASSERT_EQ(g_allocations.load() - probe, 2);
  const long before = g_allocations.load();
  for (const CameraFrame& f : frames) chain.apply(f, out);
  EXPECT_EQ(g_allocations.load() - before, 0);
}

}  // namespace
}  // namespace volcast
