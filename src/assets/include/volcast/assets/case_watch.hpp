#pragma once
// serve --case: the case folder, loaded at start and again whenever its files change, shared with
// every session (SessionHub::set_case).
#include <atomic>
#include <filesystem>
#include <string>
#include <thread>

#include "volcast/session/hub.hpp"

namespace volcast {

class CaseWatch {
 public:
  /// Loads the case in `folder` and shares it through `hub` (throws Error if it does not load),
  /// then watches the folder (and its subfolders, one level) every second: when its files
  /// changed and have stayed unchanged for a second, loads it again and swaps it for everyone.
  /// A reload that fails is logged and the case shown stays.
  CaseWatch(const std::filesystem::path& folder, SessionHub& hub, size_t max_triangles);
  ~CaseWatch();
  CaseWatch(const CaseWatch&) = delete;
  CaseWatch& operator=(const CaseWatch&) = delete;
  uint64_t reloads() const { return reloads_; }                ///< reloads shared with everyone
  uint64_t failed_reloads() const { return failed_reloads_; }  ///< refused; the case stayed

 private:
  void load();
  void watch();
  std::filesystem::path folder_;
  SessionHub& hub_;
  size_t max_triangles_;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> reloads_{0};
  std::atomic<uint64_t> failed_reloads_{0};
  std::thread thread_;
};

}  // namespace volcast
