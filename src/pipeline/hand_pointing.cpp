// A tracked controller's laser pointer and drawing (hand_pointing.hpp).
#include "volcast/pipeline/hand_pointing.hpp"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>

#include "volcast/core/error.hpp"

namespace volcast {

void HandPointing::send(Participant& p, session::Annotation a, int64_t now_us) {
  try {
    erase_last_.sent(p.annotate(std::move(a)), now_us);
  } catch (const Error& e) {  // refused before sending (a limit): the user tries again
    spdlog::warn("drawing: {}", e.what());
  }
}

int labeled_preset(float x, float y) {
  if (std::hypot(x, y) < 0.5f) return 0;
  if (std::abs(x) > std::abs(y)) return x > 0 ? 2 : 4;
  return y > 0 ? 1 : 3;
}

void HandPointing::update(Participant& p, const SessionSnapshot& snapshot,
                          const SurfaceHit* surfaces, const PointerInput& in, int64_t now_us) {
  const bool aimed = in.tracked && in.direction.squaredNorm() > 0;
  const bool on = aimed && (in.point || in.draw);
  const bool label = aimed && in.label >= 0 && in.label < int(kHeadsetLabels.size());
  hit_.reset();
  if ((on || label) && surfaces) hit_ = surfaces->hit(in.origin, in.direction);
  if (label && hit_) {
    session::Annotation a;
    a.kind = session::AnnotationKind::kLabel;
    a.points = {*hit_};
    a.text = std::string(kHeadsetLabels[size_t(in.label)]);
    send(p, std::move(a), now_us);
  } else if (label) {
    spdlog::info("drawing: the label goes where the ray meets a surface: it meets none");
  }
  if (on) {
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
      send(p, std::move(a), now_us);
    }
    stroke_.clear();
  }
  drawing_ = draw;
  // Erase my last: a press counts from now, after what this frame sent (a stroke let go in the
  // same frame as the button went down is what it erases).
  if (in.erase) erase_last_.pressed(now_us);
  if (const auto id = erase_last_.due(snapshot, now_us)) p.erase(*id);
}

}  // namespace volcast
