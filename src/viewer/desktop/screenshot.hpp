#pragma once
// The desktop viewer's screenshot (internal to volcast_viewer_desktop).
#include <filesystem>

namespace volcast {

/// `configured` if not empty, else volcast-screenshot-<n>.png in the working directory with the
/// smallest n >= 1 not taken.
std::filesystem::path screenshot_path(const std::filesystem::path& configured);

/// Reads the back buffer of the current context's default framebuffer (width x height pixels,
/// glReadPixels: bottom row first) and writes it to `path` as an RGBA PNG (alpha 255), top row
/// first. Throws Error naming the file if it cannot be written or OpenGL reports an error.
void save_screenshot(int width, int height, const std::filesystem::path& path);

}  // namespace volcast
