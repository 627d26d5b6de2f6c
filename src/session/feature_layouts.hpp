#pragma once
// Each feature's payload layouts (message_layout.hpp), private to src/session: the file that
// writes a feature's layouts describes them from the same `layout(io, m)` functions.
// message_layout.cpp asks each in turn.
#include <vector>

#include "volcast/session/message_layout.hpp"

namespace volcast::session {

/// Sets `out` to the fields of `type` and returns true when `type` is the feature's and is
/// described; false otherwise (`out` untouched).
bool describe_presence(Type type, std::vector<LayoutField>& out);  // messages.cpp
bool describe_voice(Type type, std::vector<LayoutField>& out);     // voice_messages.cpp
bool describe_drawing(Type type, std::vector<LayoutField>& out);   // annotations.cpp
bool describe_objects(Type type, std::vector<LayoutField>& out);   // objects.cpp

}  // namespace volcast::session
