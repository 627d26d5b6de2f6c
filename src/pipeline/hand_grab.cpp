#include "volcast/pipeline/hand_grab.hpp"

#include <limits>

namespace volcast {
namespace {

constexpr float kPress = 0.7f, kLetGo = 0.3f, kReach = 0.15f;

Pose compose(const Pose& a_from_b, const Pose& b_from_c) {
  return {a_from_b.orientation * b_from_c.position + a_from_b.position,
          (a_from_b.orientation * b_from_c.orientation).normalized()};
}

Pose inverse(const Pose& p) {
  const Eigen::Quaternionf q = p.orientation.conjugate();
  return {q * -p.position, q};
}

}  // namespace

void HandGrab::update(Participant& participant, const SessionSnapshot& s,
                      const std::array<HandInput, 2>& hands) {
  const auto c = participant.shared_case();
  for (int h = 0; h < 2; ++h) {
    Hand& hand = hands_[h];
    const HandInput& in = hands[h];
    const bool was = hand.squeezed;
    hand.squeezed = in.tracked && (was ? in.squeeze > kLetGo : in.squeeze > kPress);
    if (!c || s.case_generation != c->generation) {
      hand.object = -1;
      continue;
    }
    const auto mine = [&](int object) {
      return object >= 0 && object < static_cast<int>(s.objects.size()) &&
             s.objects[object].owner != 0 && s.objects[object].owner == s.id;
    };
    if (hand.squeezed && !was && hand.object < 0) {  // a new squeeze: the nearest within reach
      float best = std::numeric_limits<float>::max();
      for (size_t i = 0; i < s.objects.size() && i < c->objects.size(); ++i) {
        const float d = (s.objects[i].pose.position - in.room_from_hand.position).norm();
        if (d <= c->objects[i].radius_m + kReach && d < best) {
          best = d;
          hand.object = static_cast<int>(i);
        }
      }
      if (hand.object >= 0) {
        hand.hand_from_object = compose(inverse(in.room_from_hand), s.objects[hand.object].pose);
        participant.grab(static_cast<uint16_t>(hand.object));
      }
    } else if (!hand.squeezed && was && hand.object >= 0) {  // let go
      if (mine(hand.object))
        participant.release(static_cast<uint16_t>(hand.object),
                            compose(in.room_from_hand, hand.hand_from_object));
      hand.object = -1;
    } else if (hand.squeezed && hand.object >= 0 && mine(hand.object) && in.tracked) {
      participant.move_object(static_cast<uint16_t>(hand.object),
                              compose(in.room_from_hand, hand.hand_from_object));
    } else if (hand.object >= 0 && !hand.squeezed) {
      hand.object = -1;
    }
  }
}

}  // namespace volcast
