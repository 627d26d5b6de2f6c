#include "support/test_data.hpp"

#include <gtest/gtest.h>

#include <algorithm>
#include <array>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <iterator>
#include <mutex>
#include <thread>
#include <vector>

#include "support/test_paths.hpp"
#include "volcast/capture/source.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/image_io.hpp"
#include "volcast/core/jpeg.hpp"

namespace volcast::test {
namespace fs = std::filesystem;

fs::path data_dir() {
  const fs::path d = test::paths::data();
  if (!fs::exists(d / "README.md"))
    ADD_FAILURE() << "real test data not found at " << d
                  << " (clone with ../shared beside the repo)";
  return d;
}
fs::path hands_dir() {
  return data_dir() / "rgbd-hands-640x360";
}
fs::path kinect_mkv() {
  return data_dir() / "k4a-recording" / "recording.mkv";
}

std::vector<DepthImage> real_depth_frames(const std::string& set, size_t count) {
  std::vector<fs::path> files;
  fs::path dir;
  if (set == "hands") dir = hands_dir() / "depth";
  if (set == "4cam") dir = data_dir() / "k4a-4cam-nfov";
  if (set == "binned") dir = data_dir() / "k4a-binned-pairs";
  if (set == "kinect") {
    auto src = open_source(kinect_mkv());
    return {src->next().depth};
  }
  for (const auto& e : fs::directory_iterator(dir)) {
    const std::string name = e.path().filename().string();
    if (e.path().extension() == ".png" && (set != "4cam" || name.rfind("depth", 0) == 0))
      files.push_back(e.path());
  }
  std::sort(files.begin(), files.end());
  if (files.size() > count) files.resize(count);
  std::vector<DepthImage> out;
  for (const auto& f : files) out.push_back(read_depth_png(f));
  return out;
}

ColorImage hands_color_image(int index) {
  char name[32];
  std::snprintf(name, sizeof name, "%05d.jpg", index);
  std::ifstream in(hands_dir() / "color" / name, std::ios::binary);
  const std::vector<uint8_t> file((std::istreambuf_iterator<char>(in)),
                                  std::istreambuf_iterator<char>());
  ColorImage image;
  decode_jpeg(file, image);
  return image;
}

namespace {

// The folders temp_dir made in this process: removed when its tests end, if all passed and
// VOLCAST_KEEP_TEST_DIRS is unset; else kept and named, to look at what a failing test wrote.
struct TempDirs : testing::EmptyTestEventListener {
  std::mutex mutex;
  std::vector<fs::path> made;
  void OnTestProgramEnd(const testing::UnitTest& unit) override {
    std::lock_guard lock(mutex);
    const bool keep = !unit.Passed() || std::getenv("VOLCAST_KEEP_TEST_DIRS") != nullptr;
    for (const fs::path& d : made) {
      std::error_code ignored;
      if (keep)
        std::printf("test folder kept: %s\n", d.c_str());
      else
        fs::remove_all(d, ignored);
    }
    made.clear();
  }
};

TempDirs& temp_dirs() {
  // Owned by gtest's listener list once appended (it deletes it at exit).
  static TempDirs* dirs = [] {
    auto* d = new TempDirs;
    testing::UnitTest::GetInstance()->listeners().Append(d);
    return d;
  }();
  return *dirs;
}

}  // namespace

fs::path temp_dir(const std::string& name) {
  const fs::path d =
      fs::temp_directory_path() / ("volcast_test_" + name + "_" + std::to_string(::getpid()));
  fs::remove_all(d);
  fs::create_directories(d);
  TempDirs& dirs = temp_dirs();
  std::lock_guard lock(dirs.mutex);
  if (std::find(dirs.made.begin(), dirs.made.end(), d) == dirs.made.end()) dirs.made.push_back(d);
  return d;
}

int run_command(const std::string& command, std::string& output) {
  output.clear();
  FILE* p = popen((command + " 2>&1").c_str(), "r");
  if (!p) return -1;
  std::array<char, 4096> buf;
  size_t n;
  while ((n = fread(buf.data(), 1, buf.size(), p)) > 0) output.append(buf.data(), n);
  const int status = pclose(p);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

std::string error_of(const std::function<void()>& f) {
  try {
    f();
  } catch (const Error& e) {
    return e.what();
  }
  return "";
}

bool eventually(const std::function<bool()>& done, std::chrono::milliseconds limit) {
  const auto end = std::chrono::steady_clock::now() + limit;
  while (std::chrono::steady_clock::now() < end) {
    if (done()) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  return done();
}

}  // namespace volcast::test
