#include "options.hpp"

#include <charconv>

#include "volcast/core/error.hpp"

namespace volcast {

std::vector<double> parse_numbers(const std::string& text, size_t count, const std::string& flag) {
  std::vector<double> out;
  size_t pos = 0;
  while (pos <= text.size()) {
    const size_t comma = std::min(text.find(',', pos), text.size());
    const std::string item = text.substr(pos, comma - pos);
    try {
      size_t used = 0;
      out.push_back(std::stod(item, &used));
      if (used != item.size()) throw std::invalid_argument(item);
    } catch (const std::exception&) {
      throw Error(flag + ": '" + item + "' is not a number");
    }
    pos = comma + 1;
  }
  if (out.size() != count)
    throw Error(flag + " needs " + std::to_string(count) + " comma-separated numbers, got " +
                std::to_string(out.size()));
  return out;
}

Intrinsics parse_pinhole(const std::string& text) {
  const auto v = parse_numbers(text, 4, "--intrinsics");
  Intrinsics k;
  k.fx = v[0], k.fy = v[1], k.cx = v[2], k.cy = v[3];
  if (!(k.fx > 0 && k.fy > 0)) throw Error("--intrinsics: fx and fy must be positive");
  return k;
}

std::pair<std::string, uint16_t> parse_host_port(const std::string& text) {
  const size_t colon = text.rfind(':');
  if (colon == std::string::npos || colon == 0)
    throw Error("--connect expects HOST:PORT, got '" + text + "'");
  const std::string port_text = text.substr(colon + 1);
  unsigned port = 0;
  auto [ptr, ec] = std::from_chars(port_text.data(), port_text.data() + port_text.size(), port);
  if (ec != std::errc() || ptr != port_text.data() + port_text.size() || port == 0 || port > 65535)
    throw Error("--connect: '" + port_text + "' is not a port number (1-65535)");
  return {text.substr(0, colon), static_cast<uint16_t>(port)};
}

uint64_t parse_bit_rate(const std::string& text, const std::string& flag) {
  const auto bad = [&] {
    return Error(flag + " '" + text +
                 "' must be bits per second, a number with k, M or G (e.g. 20M), 100k to 1000G");
  };
  if (text.empty()) throw bad();
  double scale = 1;
  std::string digits = text;
  switch (text.back()) {
    case 'k':
      scale = 1e3;
      break;
    case 'M':
      scale = 1e6;
      break;
    case 'G':
      scale = 1e9;
      break;
    default:
      break;
  }
  if (scale != 1) digits.pop_back();
  if (digits.empty() || digits.find_first_not_of("0123456789.") != std::string::npos) throw bad();
  size_t used = 0;
  double value = 0;
  try {
    value = std::stod(digits, &used);
  } catch (const std::exception&) {
    throw bad();
  }
  if (used != digits.size()) throw bad();
  const double bits = value * scale;
  if (!(bits >= 1e5 && bits <= 1e12)) throw bad();
  return static_cast<uint64_t>(bits);
}

}  // namespace volcast
