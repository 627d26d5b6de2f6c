// Live Azure Kinect cameras (volcast/capture/k4a_device.hpp) against a stand-in libk4a
// (tests/support/fake_k4a.cpp) that serves the real k4arecorder recording through the SDK's C
// API: the factory calibration read from the "device", its depth and MJPG color, hardware-sync
// options, several devices, and the stream through a server like a recording's.
#include <gtest/gtest.h>
#include <stdlib.h>

#include <fstream>

#include "support/test_data.hpp"
#include "support/test_paths.hpp"
#include "volcast/capture/k4a_device.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/net/stream/client.hpp"
#include "volcast/pipeline/sender.hpp"

namespace volcast {
namespace {

namespace fs = std::filesystem;

// Points libk4a at the stand-in serving the real recording, with `devices` devices.
void use_stand_in(int devices, const fs::path& log = {}) {
  setenv("VOLCAST_K4A_LIBRARY", test::paths::fake_k4a(), 1);
  setenv("VOLCAST_FAKE_K4A_RECORDING", test::kinect_mkv().c_str(), 1);
  setenv("VOLCAST_FAKE_K4A_DEVICES", std::to_string(devices).c_str(), 1);
  if (!log.empty()) setenv("VOLCAST_FAKE_K4A_LOG", log.c_str(), 1);
}

TEST(K4aDevice, WithoutTheSdkOneLineSaysWhatToInstall) {
  setenv("VOLCAST_K4A_LIBRARY", "/nonexistent/libk4a.so.1.4", 1);
  const std::string e = test::error_of([] { open_source("k4a://0"); });
  EXPECT_NE(e.find("Azure Kinect Sensor SDK"), std::string::npos) << e;
  EXPECT_NE(e.find("libk4a1.4"), std::string::npos) << e;
  EXPECT_EQ(e.find('\n'), std::string::npos) << e;
}

TEST(K4aDevice, ReadsTheFactoryCalibrationFromTheDeviceAndStreamsItsDepthAndRegisteredColor) {
  use_stand_in(1);
  auto recording = open_source(test::kinect_mkv());
  const CameraFrame expected = recording->next();
  auto live = open_source("k4a://0");
  // The same calibration through the same parser: the device's raw calibration is the JSON
  // k4arecorder attached.
  const Intrinsics& a = live->calibration().depth;
  const Intrinsics& b = recording->calibration().depth;
  EXPECT_EQ(a.width, 640);
  EXPECT_EQ(a.height, 576);
  EXPECT_DOUBLE_EQ(a.fx, b.fx);
  EXPECT_DOUBLE_EQ(a.cy, b.cy);
  EXPECT_DOUBLE_EQ(a.k1, b.k1);
  EXPECT_DOUBLE_EQ(a.p2, b.p2);
  EXPECT_EQ(live->fps(), 30);
  EXPECT_NE(live->description().find("000000000001"), std::string::npos);
  int64_t last = -1;
  for (int n = 0; n < 3; ++n) {
    const CameraFrame f = live->next();
    EXPECT_EQ(f.depth.pixels, expected.depth.pixels);  // DEPTH16 read as the recording's b16g
    ASSERT_FALSE(f.color.empty());
    EXPECT_EQ(f.color.bgra, expected.color.bgra);  // MJPG decoded and registered to depth
    if (last >= 0) {
      EXPECT_EQ(f.device_timestamp_us - last, 33333);
    }
    last = f.device_timestamp_us;
  }
  // Depth only.
  auto depth_only = open_source("k4a://0?color=OFF&fps=15");
  EXPECT_EQ(depth_only->fps(), 15);
  EXPECT_TRUE(depth_only->next().color.empty());
}

TEST(K4aDevice, PicksDevicesBySerialPassesSyncOptionsAndNamesWhatIsWrong) {
  const auto dir = test::temp_dir("k4a_device");
  use_stand_in(3, dir / "starts.log");
  {
    auto sub = open_source("k4a://000000000003?sync=subordinate&delay_us=160");
    auto master = open_source("k4a://000000000002?sync=master");
    EXPECT_NE(sub->description().find("000000000003"), std::string::npos);
    EXPECT_NE(master->description().find("000000000002"), std::string::npos);
    EXPECT_EQ(sub->next().depth.width, 640);
  }
  std::ifstream log(dir / "starts.log");
  std::string line1, line2;
  std::getline(log, line1);
  std::getline(log, line2);
  // serial, depth mode (2 = NFOV unbinned), color format (0 = MJPG), resolution (1 = 720p),
  // fps (2 = 30), sync (2 = subordinate, 1 = master), subordinate delay (us).
  EXPECT_EQ(line1, "000000000003 2 0 1 2 2 160");
  EXPECT_EQ(line2, "000000000002 2 0 1 2 1 0");
  std::string e = test::error_of([] { open_source("k4a://123456789012"); });
  EXPECT_NE(e.find("no such Azure Kinect (3 connected: 000000000001, 000000000002, 000000000003)"),
            std::string::npos)
      << e;
  e = test::error_of([] { open_source("k4a://0?depth=BOGUS"); });
  EXPECT_NE(e.find("unknown depth mode 'BOGUS'"), std::string::npos) << e;
  e = test::error_of([] { open_source("k4a://0?fps=60"); });
  EXPECT_NE(e.find("fps must be 5, 15 or 30"), std::string::npos) << e;
  e = test::error_of([] { open_source("k4a://0?depth=WFOV_UNBINNED"); });
  EXPECT_NE(e.find("15 fps at most"), std::string::npos) << e;
  e = test::error_of([] { open_source("k4a://0?depth=WFOV_2X2BINNED"); });  // the stand-in refuses
  EXPECT_NE(e.find("would not start"), std::string::npos) << e;
}

TEST(K4aDevice, TwoLiveCamerasStreamThroughAServerLikeARecording) {
  use_stand_in(2);
  const CameraFrame expected = open_source(test::kinect_mkv())->next();
  std::vector<std::unique_ptr<FrameSource>> sources;
  sources.push_back(open_source("k4a://0"));
  sources.push_back(open_source("k4a://1"));
  SitePlayer site(std::move(sources), 0);
  EXPECT_EQ(site.fps(), 30);
  ServerConfig config;
  config.port = 0;
  config.insecure = true;
  Server server(site.cameras(), config);
  site.start(server);
  ClientConfig c;
  c.port = server.port();
  c.token = server.token();
  c.insecure = true;
  Client client(c);
  ReceivedFrameSet f;
  for (int n = 0; n < 10; ++n) {
    ASSERT_TRUE(client.receive(f));
    ASSERT_EQ(f.frames.cameras.size(), 2u);
    for (const CameraFrame& cam : f.frames.cameras) {
      EXPECT_EQ(cam.depth.pixels, expected.depth.pixels);
      EXPECT_EQ(cam.color.width, 640);
    }
  }
  site.stop();
  server.stop();
}

}  // namespace
}  // namespace volcast
