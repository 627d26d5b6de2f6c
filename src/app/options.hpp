#pragma once
// Parsing of the CLI's shared value formats.
#include <string>
#include <vector>

#include "volcast/core/calibration.hpp"

namespace volcast {

/// "a,b,c" -> {a, b, c}; throws Error naming `flag` if a value is not a number or the count
/// differs.
std::vector<double> parse_numbers(const std::string& text, size_t count, const std::string& flag);
/// "fx,fy,cx,cy" in pixels -> pinhole intrinsics (width/height left 0 for the source to fill).
Intrinsics parse_pinhole(const std::string& text);
/// "HOST:PORT" -> host, port. Throws Error on a missing or invalid port.
std::pair<std::string, uint16_t> parse_host_port(const std::string& text);

}  // namespace volcast
