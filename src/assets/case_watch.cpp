#include "volcast/assets/case_watch.hpp"

#include <spdlog/spdlog.h>

#include <chrono>
#include <utility>

#include "volcast/assets/case.hpp"
#include "volcast/assets/shared_case.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

namespace fs = std::filesystem;

namespace {

// What the folder holds now: names, sizes and times of its files and its subfolders' files.
std::string fingerprint(const fs::path& folder) {
  std::string out;
  std::error_code ec;
  const auto add = [&](const fs::directory_entry& e) {
    if (!e.is_regular_file(ec)) return;
    out += e.path().string() + '|' + std::to_string(e.file_size(ec)) + '|' +
           std::to_string(e.last_write_time(ec).time_since_epoch().count()) + '\n';
  };
  for (const auto& e : fs::directory_iterator(folder, ec)) {
    add(e);
    if (e.is_directory(ec))
      for (const auto& sub : fs::directory_iterator(e.path(), ec)) add(sub);
  }
  return out;
}

}  // namespace

CaseWatch::CaseWatch(const fs::path& folder, Share share, size_t max_triangles)
    : folder_(folder), share_(std::move(share)), max_triangles_(max_triangles) {
  load();
  thread_ = std::thread([this] { watch(); });
}

CaseWatch::~CaseWatch() {
  stop_ = true;
  thread_.join();
}

void CaseWatch::load() {
  CaseLoadOptions options;
  options.max_triangles = max_triangles_;
  options.progress = [](const std::string& what) { spdlog::info("case: loading {}", what); };
  const Case c = load_case(folder_, options);
  size_t triangles = 0;
  for (const CasePart& p : c.parts) triangles += p.mesh.triangles();
  share_(to_shared_case(c));
  spdlog::info("case '{}': {} parts, {} triangles{}, loaded in {:.0f} ms", c.name, c.parts.size(),
               triangles, c.dicom ? ", " + std::to_string(c.dicom->slices) + " CT slices" : "",
               c.load_ms);
}

void CaseWatch::watch() {
  std::string seen = fingerprint(folder_), pending;
  auto changed_at = std::chrono::steady_clock::now();
  while (!stop_) {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    const auto now = std::chrono::steady_clock::now();
    const std::string current = fingerprint(folder_);
    if (current != pending) {  // still changing: wait until it settles
      pending = current;
      changed_at = now;
      continue;
    }
    if (current == seen || now - changed_at < std::chrono::seconds(1)) continue;
    seen = current;
    spdlog::info("case: {} changed, loading it again", folder_.string());
    try {
      load();
      ++reloads_;
    } catch (const std::exception& e) {
      spdlog::error("case: reload failed, the case shown stays: {}", e.what());
      ++failed_reloads_;
    }
  }
}

}  // namespace volcast
