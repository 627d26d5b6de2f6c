#pragma once
// `volcast bench`'s codec section: the layout of the paper's Table 1 on the real recordings.
#include <filesystem>
#include <nlohmann/json.hpp>
#include <string>
#include <vector>

namespace volcast {

/// Times every depth codec (and JPEG for color) on the shared data sets in `data` and on
/// `extra` recordings, one thread, median of `repeats` passes over at most `max_frames` frames of
/// each sequence (0: all); prints a table and fills
/// json["depth_codecs"] and json["color_codecs"]. Lossless codecs are verified bit-exact on every
/// frame (else the maximum and mean absolute error are reported).
void bench_codecs(const std::filesystem::path& data, const std::vector<std::string>& extra,
                  int repeats, int max_frames, nlohmann::json& json);

}  // namespace volcast
