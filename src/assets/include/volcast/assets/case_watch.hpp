#pragma once
// serve --case: the case folder, loaded at start and again whenever its files change, each load
// handed on as the session shares it (serve hands it to SessionHub::set_case).
#include <atomic>
#include <filesystem>
#include <functional>
#include <string>
#include <thread>

#include "volcast/room/patient_case.hpp"

namespace volcast {

class CaseWatch {
 public:
  /// Where each loaded case goes (serve: SessionHub::set_case); it may throw Error to refuse one.
  using Share = std::function<void(SharedCase)>;
  /// Loads the case in `folder` and hands it to `share` (throws Error if it does not load or
  /// `share` refuses it), then watches the folder (and its subfolders, one level) every second:
  /// when its files changed and have stayed unchanged for a second, loads it again and hands it
  /// on (everyone's case is swapped). A reload that fails is logged and the case shown stays.
  CaseWatch(const std::filesystem::path& folder, Share share, size_t max_triangles);
  ~CaseWatch();
  CaseWatch(const CaseWatch&) = delete;
  CaseWatch& operator=(const CaseWatch&) = delete;
  uint64_t reloads() const { return reloads_; }                ///< reloads shared with everyone
  uint64_t failed_reloads() const { return failed_reloads_; }  ///< refused; the case stayed

 private:
  void load();
  void watch();
  std::filesystem::path folder_;
  Share share_;
  size_t max_triangles_;
  std::atomic<bool> stop_{false};
  std::atomic<uint64_t> reloads_{0};
  std::atomic<uint64_t> failed_reloads_{0};
  std::thread thread_;
};

}  // namespace volcast
