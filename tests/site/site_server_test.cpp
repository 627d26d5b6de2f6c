// One OR site's server as a whole (volcast/site/site_server.hpp), as `volcast serve --record`
// runs it, on the real hands sequence: a participant is told that the room is recorded, the
// recording holds what was served, and stopping tells every participant that the recording
// stopped before their connections close, then closes the file.
#include <gtest/gtest.h>

#include <filesystem>

#include "support/session_site.hpp"
#include "support/test_data.hpp"
#include "volcast/core/clock.hpp"
#include "volcast/net/protocol/join.hpp"
#include "volcast/pipeline/headless_participant.hpp"
#include "volcast/record/recording.hpp"
#include "volcast/site/site_server.hpp"

namespace volcast {
namespace {

using test::eventually;

SiteServerOptions hands_site(const std::filesystem::path& recording) {
  SiteServerOptions o;
  o.sources = {test::hands_dir().string()};
  o.intrinsics = Intrinsics{0, 0, 460, 460, 320, 180};  // the set has none
  o.fps = 15;
  o.hub = test::patient_hub();
  o.sessions = {"OR", "Teaching"};
  o.server.port = 0;
  o.server.insecure = true;
  o.record_path = recording.string();
  o.record_tier = parse_tier("volcast/jpeg", "test", TierRate::kEveryFrameSet);
  return o;
}

TEST(SiteServer, ARecordedSiteIsShownAsRecordedUntilItStopsAndItsFileHoldsWhatWasServed) {
  const auto dir = test::temp_dir("site_server");
  const auto file = dir / "site.vcr";
  SiteServer site(hands_site(file));
  EXPECT_EQ(site.cameras().size(), 1u);
  EXPECT_EQ(site.cameras()[0].description, "camera 0") << "a name, never the source's path";
  EXPECT_EQ(site.hub().sessions().size(), 2u);
  site.start();

  ClientConfig c = client_config_from_link(site.server().join_link("127.0.0.1"));
  c.decode = false;
  c.receive_timeout_ms = 20000;
  HeadlessParticipant a(c, test::named("Dr. A"));
  ASSERT_TRUE(a.wait_joined(20000)) << a.error();
  const auto recording = [&] { return a.participant().snapshot(wall_clock_us()).recording; };
  ASSERT_TRUE(eventually([&] { return recording().recording; }));
  EXPECT_EQ(recording().by, "the OR server (volcast serve --record)");
  ASSERT_TRUE(eventually([&] {
    const std::string p = site.progress();
    return p.find("; recorded ") != std::string::npos &&
           p.find("; recorded 0 frame sets") == std::string::npos;
  })) << site.progress();
  EXPECT_NE(site.progress().find("1 viewer(s) connected"), std::string::npos) << site.progress();

  site.stop();
  // Told before its connection closed (nothing can arrive after: the server is gone).
  EXPECT_TRUE(eventually([&] { return !recording().recording; }));
  site.stop();  // once
  a.end();

  const RecordingReader reader(file);
  EXPECT_TRUE(reader.info().closed);
  EXPECT_GT(reader.info().frame_sets.size(), 0u);
  EXPECT_EQ(to_string(reader.info().stream.tier), "volcast/jpeg");
  EXPECT_EQ(reader.info().stream.origin, "volcast serve --record");
}

// A source that cannot be opened is named, and nothing is left listening or recording.
TEST(SiteServer, ASourceThatCannotBeOpenedIsNamed) {
  const auto dir = test::temp_dir("site_server_bad");
  SiteServerOptions o = hands_site(dir / "never.vcr");
  o.sources.push_back((dir / "no such camera").string());
  try {
    SiteServer site(std::move(o));
    ADD_FAILURE() << "a missing source was taken";
  } catch (const Error& e) {
    EXPECT_NE(std::string(e.what()).find("no such camera"), std::string::npos) << e.what();
  }
  EXPECT_FALSE(std::filesystem::exists(dir / "never.vcr"));
}

}  // namespace
}  // namespace volcast
