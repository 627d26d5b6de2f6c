#pragma once
// Live Azure Kinect (and K4A-compatible) cameras through the vendor's Sensor SDK, which Debian does
// not ship: libk4a is opened at run time (dlopen) and only the documented C API functions this
// source uses are bound (Azure Kinect Sensor SDK 1.4, k4a.h / k4atypes.h).
//
// A camera is named by a URL:
//   k4a://INDEX or k4a://SERIAL
//   [?depth=MODE&color=FORMAT&resolution=RES&fps=F&sync=ROLE&delay_us=D] MODE   NFOV_UNBINNED
//   (default) | NFOV_2X2BINNED | WFOV_2X2BINNED | WFOV_UNBINNED FORMAT MJPG (default) | BGRA32 |
//   OFF (depth only) RES    720P (default) | 1080P | 1440P | 1536P | 2160P | 3072P F      5 | 15 |
//   30 (default; WFOV unbinned and 3072P allow at most 15) ROLE   standalone (default) | master |
//   subordinate  (hardware sync over the 3.5 mm cables: one
//          master, the others subordinate; start subordinates first, as the SDK asks)
//   D      a subordinate's delay after the master (us, default 0; e.g. 160 per camera so that
//          their lasers do not interfere)
// The factory calibration is read from the device (k4a_device_get_raw_calibration: the same JSON
// that k4arecorder attaches to a recording) and goes through the same parser; color is registered
// to depth as for recordings.
#include <filesystem>
#include <memory>
#include <string>

#include "volcast/capture/source.hpp"

namespace volcast {

/// True for a "k4a://..." source name.
bool is_k4a_device_url(const std::string& name);

/// Opens and starts the camera `url` names (format above). libk4a is looked for as
/// $VOLCAST_K4A_LIBRARY if set, else libk4a.so.1.4, libk4a.so.1 and libk4a.so on the loader's
/// path (loaded on first use, kept). Throws Error with one line saying what to install when it
/// cannot be loaded; naming the URL's bad field; when no device has that
/// index or serial (listing the serials present); or when the device will not start.
/// The source's frame_count() is INT_MAX (live: no end), fps() the configured rate; next() blocks
/// for the device's next capture (up to 2 s, then Error) and returns depth (mm) with color
/// registered to it (empty when the capture had none).
std::unique_ptr<FrameSource> open_k4a_device(const std::string& url,
                                             const SourceOptions& options = {});

}  // namespace volcast
