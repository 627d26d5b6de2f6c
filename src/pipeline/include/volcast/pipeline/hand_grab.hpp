#pragma once
// Grabbing the case's objects with tracked hands (a headset's controllers; objects.hpp): squeeze
// a grip with the hand within reach of an object (its radius + 0.15 m from its origin) to ask to
// hold it; once the server made this participant its owner, the object follows the hand rigidly
// (room_from_object = room_from_hand * hand_from_object, as it was at the squeeze); letting go of
// the grip releases it where it is. Squeezed: above 0.7; let go: below 0.3 (no flicker between).
#include <array>
#include <optional>

#include "volcast/session/participant.hpp"

namespace volcast {

/// One tracked hand this frame: its grip pose in the room (metres, room frame), and how far its
/// grip is squeezed (0..1).
struct HandInput {
  bool tracked = false;
  Pose room_from_hand;
  float squeeze = 0;
};

class HandGrab {
 public:
  /// Acts for both hands (0 left, 1 right) on `participant`, whose state now is `s`. Call once per
  /// frame.
  void update(Participant& participant, const SessionSnapshot& s,
              const std::array<HandInput, 2>& hands);
  /// The object hand `hand` holds or asked for (-1: none).
  int held(int hand) const { return hands_[hand].object; }

 private:
  struct Hand {
    bool squeezed = false;
    int object = -1;
    Pose hand_from_object;
  };
  std::array<Hand, 2> hands_;
};

}  // namespace volcast
