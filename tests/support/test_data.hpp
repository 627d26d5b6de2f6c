#pragma once
// Access to the shared real RGB-D recordings (../shared/data) for tests.
#include <chrono>
#include <filesystem>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "volcast/core/image.hpp"

namespace volcast::test {

/// The shared data folder; fails the calling test (FAIL()) if it is missing.
std::filesystem::path data_dir();
std::filesystem::path hands_dir();   ///< rgbd-hands-640x360 (207 frames)
std::filesystem::path kinect_mkv();  ///< k4a-recording/recording.mkv
/// Every real depth frame of one set, by name: "hands" (207), "kinect" (1), "4cam" (4),
/// "binned" (6); or only its first `count` (each PNG read costs: a test that codes a few frames
/// reads a few).
std::vector<DepthImage> real_depth_frames(const std::string& set,
                                          size_t count = std::numeric_limits<size_t>::max());
/// Colour frame `index` (0..206) of the hands sequence, decoded from its JPEG (BGRA, 640x360).
ColorImage hands_color_image(int index);
/// A fresh empty temporary folder for one test (`name` and the process id under the system's
/// temporary folder). Removed when the test program ends with every test passed, unless
/// VOLCAST_KEEP_TEST_DIRS is set; kept and named (stdout) when one failed.
std::filesystem::path temp_dir(const std::string& name);
/// Runs a shell command, returns its exit code; its stdout+stderr are stored in `output`.
int run_command(const std::string& command, std::string& output);
/// Polls `done` every 10 ms until it holds or `limit` has passed; returns its last answer. For
/// what another thread updates right after the event a test saw (a server's counters).
bool eventually(const std::function<bool()>& done,
                std::chrono::milliseconds limit = std::chrono::seconds(20));
/// Runs `f`; returns the message of the volcast::Error it threw, or "" if it threw none.
std::string error_of(const std::function<void()>& f);

}  // namespace volcast::test
