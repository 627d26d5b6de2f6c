// A pose script's pointing and drawing (session_client.hpp ScriptedPointing).
#include <spdlog/spdlog.h>

#include <algorithm>

#include "volcast/pipeline/session_client.hpp"

namespace volcast {
namespace {

// The point a fraction `f` (0..1) of the way along the polyline, by length.
Eigen::Vector3f along(const std::vector<Eigen::Vector3f>& path, double f) {
  double total = 0;
  for (size_t i = 1; i < path.size(); ++i) total += (path[i] - path[i - 1]).norm();
  double left = std::clamp(f, 0.0, 1.0) * total;
  for (size_t i = 1; i < path.size(); ++i) {
    const double piece = (path[i] - path[i - 1]).norm();
    if (left <= piece && piece > 0)
      return path[i - 1] + (path[i] - path[i - 1]) * float(left / piece);
    left -= piece;
  }
  return path.back();
}

// At most session::kMaxStrokePoints of `points`, evenly spaced, the first and last kept.
std::vector<Eigen::Vector3f> thinned(const std::vector<Eigen::Vector3f>& points) {
  const size_t n = points.size(), most = session::kMaxStrokePoints;
  if (n <= most) return points;
  std::vector<Eigen::Vector3f> out;
  for (size_t i = 0; i < most; ++i) out.push_back(points[i * (n - 1) / (most - 1)]);
  return out;
}

}  // namespace

std::optional<Eigen::Vector3f> ScriptedPointing::hit(const Eigen::Vector3f& hand,
                                                     const Eigen::Vector3f& at) const {
  if (!surfaces_ || (at - hand).norm() < 1e-4f) return std::nullopt;
  return surfaces_->hit(hand, at - hand);
}

void ScriptedPointing::finish(Participant& p, const Eigen::Vector3f& hand) {
  if (!active_) return;
  p.point(false, hand, false, hand + Eigen::Vector3f(0, 0, -1));
  if (active_->kind == ScriptedDrawing::Kind::kStroke) {
    if (stroke_.size() >= 2) {
      session::Annotation a;
      a.kind = session::AnnotationKind::kStroke;
      a.points = thinned(stroke_);
      p.annotate(std::move(a));
    } else {
      spdlog::warn("pose script: the stroke at {:.1f} s met the live clouds {} times: not drawn",
                   active_->t_s, stroke_.size());
    }
  }
  active_.reset();
  stroke_.clear();
}

void ScriptedPointing::sweep(const Eigen::Vector3f& hand, double until_s) {
  if (!active_ || active_->kind != ScriptedDrawing::Kind::kStroke) return;
  const double end_s = active_->t_s + active_->for_s;
  for (; swept_s_ <= std::min(until_s, end_s); swept_s_ += kSweepStep_s) {
    const std::optional<Eigen::Vector3f> met =
        hit(hand, along(active_->points, (swept_s_ - active_->t_s) / active_->for_s));
    if (met && (stroke_.empty() || (*met - stroke_.back()).norm() > 0.003f))
      stroke_.push_back(*met);
  }
}

void ScriptedPointing::step(Participant& p, const Eigen::Vector3f& hand, double script_s) {
  if (!began_s_) {
    if (surfaces_ && !surfaces_->ready()) return;  // nothing to point at yet
    began_s_ = surfaces_ ? script_s : 0.0;
    if (*began_s_ > 0.5)
      spdlog::info("pose script: the site's clouds came {:.1f} s in: its drawing begins now",
                   *began_s_);
  }
  const double t_s = script_s - *began_s_;
  // What became due since the last step, in script order: the active item ends (its stroke swept
  // to its end) before an item that starts later; an item that starts before it ends cuts it
  // short there.
  for (;;) {
    const double end_s = active_ ? active_->t_s + active_->for_s : t_s + 1;
    const bool next_due = next_ < script_.drawing.size() && script_.drawing[next_].t_s <= t_s;
    if (active_ && end_s <= t_s && (!next_due || end_s <= script_.drawing[next_].t_s)) {
      sweep(hand, end_s);
      finish(p, hand);
      continue;
    }
    if (!next_due) break;
    const ScriptedDrawing& d = script_.drawing[next_++];
    using Kind = ScriptedDrawing::Kind;
    if (d.kind == Kind::kPoint || d.kind == Kind::kStroke) {
      sweep(hand, d.t_s);
      finish(p, hand);
      active_ = d;
      swept_s_ = d.t_s;
      continue;
    }
    session::Annotation a;
    a.kind =
        d.kind == Kind::kArrow ? session::AnnotationKind::kArrow : session::AnnotationKind::kLabel;
    for (const Eigen::Vector3f& at : d.points) a.points.push_back(hit(hand, at).value_or(at));
    a.text = d.text;
    p.annotate(std::move(a));
  }
  if (!active_) return;
  sweep(hand, t_s);
  const Eigen::Vector3f aim = active_->kind == ScriptedDrawing::Kind::kStroke
                                  ? along(active_->points, (t_s - active_->t_s) / active_->for_s)
                                  : active_->points[0];
  const std::optional<Eigen::Vector3f> met = hit(hand, aim);
  p.point(true, hand, met.has_value(), met.value_or(aim));
}

}  // namespace volcast
