// A tracked controller's laser pointer and drawing (hand_pointing.hpp).
#include "volcast/pipeline/hand_pointing.hpp"

#include <spdlog/spdlog.h>

#include "volcast/core/error.hpp"

namespace volcast {

void HandPointing::update(Participant& p, const LiveSurfaces* surfaces, const PointerInput& in) {
  const bool on = in.tracked && (in.point || in.draw) && in.direction.squaredNorm() > 0;
  hit_.reset();
  if (on) {
    if (surfaces) hit_ = surfaces->hit(in.origin, in.direction);
    const Eigen::Vector3f towards = in.origin + in.direction.normalized();
    p.point(true, in.origin, hit_.has_value(), hit_.value_or(towards));
    shown_ = true;
    last_origin_ = in.origin;
  } else if (shown_) {
    p.point(false, last_origin_, false, last_origin_ + Eigen::Vector3f(0, 0, -1));
    shown_ = false;
  }
  const bool draw = on && in.draw;
  if (draw && hit_ && (stroke_.empty() || (*hit_ - stroke_.back()).norm() >= 0.003f) &&
      stroke_.size() < session::kMaxStrokePoints)
    stroke_.push_back(*hit_);
  if (drawing_ && !draw) {  // let go (or lost): the stroke as drawn
    if (stroke_.size() >= 2) {
      session::Annotation a;
      a.kind = session::AnnotationKind::kStroke;
      a.points = stroke_;
      try {
        p.annotate(std::move(a));
      } catch (const Error& e) {  // refused before sending (a limit): the user tries again
        spdlog::warn("drawing: {}", e.what());
      }
    }
    stroke_.clear();
  }
  drawing_ = draw;
}

}  // namespace volcast
