// Per-frame paths allocate nothing once warm: the filter chain, and the heads the voice loop
// reads every 20 ms (Participant::voice_scene). This binary replaces the global operator new to
// count heap allocations (all of them, and the calling thread's), so it holds only these tests.
#include <gtest/gtest.h>

#include <atomic>
#include <cstdlib>
#include <new>

#include "support/session_site.hpp"
#include "support/test_data.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/filter/chain.hpp"

// GCC cannot see that the replaced operator new below returns malloc'd memory.
#pragma GCC diagnostic ignored "-Wmismatched-new-delete"

static std::atomic<long> g_allocations{0};
static thread_local long t_allocations = 0;  // this thread's: others run beside a session test
void* operator new(size_t n) {
  ++g_allocations;
  ++t_allocations;
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

TEST(FilterChainAllocation, AllocatesNothingPerFrameOnceWarm) {
  auto src = open_source(test::hands_dir(),
                         SourceOptions{Intrinsics{0, 0, 460, 460, 320, 180}, {}, {}, {}});
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

// Three others in the session, with poses: the second call of voice_scene into the same scene
// allocates nothing on the calling thread, and gives what snapshot() gives.
TEST(VoiceScene, AllocatesNothingOnceWarm) {
  test::SessionSite s({}, 2);
  test::TestParticipant listener(s, test::hand_driven("Listener with a long display name"));
  std::vector<std::unique_ptr<test::TestParticipant>> others;
  for (const char* name : {"Dr. A", "Dr. B with a name past the small-string buffer", "Dr. C"})
    others.push_back(std::make_unique<test::TestParticipant>(s, test::hand_driven(name)));
  ASSERT_TRUE(test::eventually([&] {
    for (auto& o : others) o->p().publish(BodyPose{});  // ignored until joined
    listener.p().publish(BodyPose{});
    const SessionSnapshot n = listener.now();
    size_t posed = 0;
    for (const RemoteParticipant& r : n.others) posed += r.has_pose;
    return posed == 3 && n.has_own_body;
  }));
  VoiceScene scene;
  const int64_t now = wall_clock_us();
  listener.p().voice_scene(now, scene);  // sizes the vector and the names
  const long probe = t_allocations;
  delete new std::vector<int>(3);  // the thread's counter works
  ASSERT_EQ(t_allocations - probe, 2);
  const long before = t_allocations;
  for (int i = 0; i < 50; ++i) listener.p().voice_scene(now + i * 20'000, scene);
  EXPECT_EQ(t_allocations - before, 0);
  const SessionSnapshot snap = listener.p().snapshot(now + 49 * 20'000);
  ASSERT_EQ(scene.others.size(), snap.others.size());  // the OR site too
  for (size_t i = 0; i < snap.others.size(); ++i) {
    EXPECT_EQ(scene.others[i].id, snap.others[i].id);
    EXPECT_EQ(scene.others[i].name, snap.others[i].name);
    EXPECT_EQ(scene.others[i].has_pose, snap.others[i].has_pose);
    EXPECT_TRUE(scene.others[i].head.position.isApprox(snap.others[i].pose.head.position));
  }
  EXPECT_TRUE(scene.has_own_body);
}

}  // namespace
}  // namespace volcast
