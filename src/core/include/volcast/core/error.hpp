#pragma once
// Volcast's one error type: every stage reports bad input (a corrupt recording, a malformed packet,
// a wrong flag) by throwing volcast::Error with a message that names what was wrong.
#include <stdexcept>
#include <string>

namespace volcast {

/// Thrown for bad input or a failed operation; what() names the file, field or value at fault.
class Error : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

}  // namespace volcast
