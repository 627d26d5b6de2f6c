#pragma once
// Parsing of the CLI's shared value formats.
#include <cstdint>
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
/// "20M", "500k", "1.5G", "8000000" -> bits per second (k = 1e3, M = 1e6, G = 1e9). Throws Error
/// naming `flag` for anything else, or a rate below 100 kbit/s or above 1 Tbit/s.
uint64_t parse_bit_rate(const std::string& text, const std::string& flag);

}  // namespace volcast
