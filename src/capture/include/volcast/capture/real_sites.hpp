#pragma once
// The real recordings in ../shared/data arranged as sites, for the demo, the benchmarks, the tests
// and calibrate's nominal intrinsics.
#include <filesystem>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "volcast/capture/source.hpp"

namespace volcast {

inline constexpr const char* kHandsSet = "rgbd-hands-640x360";
inline constexpr const char* kKinectSet = "k4a-recording/recording.mkv";
inline constexpr const char* kFourKinectSet = "k4a-4cam-nfov";

/// The data folder: `flag` if given, else $VOLCAST_DATA, ../shared/data beside the repository or
/// the working directory, ./shared/data; nullopt if none holds the recordings.
std::optional<std::filesystem::path> find_data(const std::string& flag);

/// Two cameras: the 207-frame hands sequence (30 fps, nominal pinhole -- its intrinsics were never
/// published; logged) and the genuine Azure Kinect recording (5 fps, factory calibration), placed
/// 1.6 m to the right of camera 0. Throws Error if a recording cannot be opened.
std::vector<std::unique_ptr<FrameSource>> two_camera_site(const std::filesystem::path& data);

/// The Azure Kinect recording's factory color calibration (1280x720, and color_from_depth), as a
/// NOMINAL one for the four Azure Kinects of k4a-4cam-nfov, which recorded none. Throws Error if
/// the recording cannot be read.
ColorCalibration nominal_kinect_color(const std::filesystem::path& data);

/// Four cameras: the four Azure Kinects of k4a-4cam-nfov (one real capture each, repeated at
/// 30 fps), with the Azure Kinect recording's factory NFOV intrinsics (the set has none) and 1.6 m
/// apart; their color registered to depth with that recording's color calibration (nominal:
/// the set has none), so colors sit on the surfaces within the spread between units.
std::vector<std::unique_ptr<FrameSource>> four_camera_site(const std::filesystem::path& data);

/// `cameras` (e.g. four_camera_site's, which has no extrinsics) turned about one point 2 m in
/// front of the first camera (its camera frame's +z), camera i by 0, 12, -12 or 24 degrees
/// (i mod 4) about that frame's y axis, so that their surfaces overlap on screen as an operating
/// room's cameras around one table do: for benchmarks and tests whose cost or coverage depends on
/// how much is drawn, not on where. Sets each world_from_camera; world = the first camera's frame.
std::vector<CameraCalibration> turned_to_overlap(std::vector<CameraCalibration> cameras);

}  // namespace volcast
