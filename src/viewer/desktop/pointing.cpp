#include "pointing.hpp"

#include <imgui.h>

#include "volcast/core/error.hpp"
#include "volcast/pipeline/session_scene.hpp"
#include "volcast/render/annotation_scene.hpp"
#include "volcast/render/drawn_depth.hpp"

namespace volcast {
namespace {

// The ray through framebuffer pixel (x, y): a point 1 m along it.
Eigen::Vector3f ahead_of(const View& view, const RenderTarget& target, double x, double y) {
  const Eigen::Vector4f ndc(float(2 * x / target.width - 1), float(1 - 2 * y / target.height), 0,
                            1);
  const Eigen::Vector4f p = view.clip_from_world().inverse() * ndc;
  const Eigen::Vector3f eye = view.world_from_view.translation.cast<float>();
  return eye + (Eigen::Vector3f(p.head<3>() / p.w()) - eye).normalized();
}

void send(Participant& participant, PointingState& state, session::Annotation a, int64_t now_us) {
  try {
    state.erase_last.sent(participant.annotate(std::move(a)), now_us);
    state.status.clear();
  } catch (const Error& e) {
    state.status = e.what();
  }
}

}  // namespace

std::vector<Primitive> point_and_draw(PointingState& state, Participant& participant,
                                      const SessionSnapshot& snapshot, const View& view,
                                      const RenderTarget& target, double x, double y,
                                      const Eigen::Vector3f& rgb, int64_t now_us) {
  // The pointer comes from where a right hand would hold it: 20 cm right of the eye, 25 cm down.
  const RigidTransform& eye = view.world_from_view;
  state.origin = (eye * Eigen::Vector3d(0.2, -0.25, 0)).cast<float>();
  const bool aiming = state.laser || state.dragging || state.pin_label;
  const Eigen::Vector3f eye_at = eye.translation.cast<float>();
  state.hit = aiming ? DrawnDepth(view, target).hit(eye_at, ahead_of(view, target, x, y) - eye_at)
                     : std::nullopt;
  const bool was_on =
      snapshot.pointers.end() !=
      std::find_if(snapshot.pointers.begin(), snapshot.pointers.end(),
                   [&](const PointerView& p) { return p.participant == snapshot.id; });
  if (state.laser || state.dragging) {
    const Eigen::Vector3f through = state.hit.value_or(ahead_of(view, target, x, y));
    participant.point(true, state.origin, state.hit.has_value(), through);
  } else if (was_on) {
    participant.point(false, state.origin, false, state.origin + Eigen::Vector3f(0, 0, -1));
  }
  // A stroke: the dots while the left button is held, a new one 3 mm or more from the last.
  if (state.drawing && state.hit &&
      (state.stroke.empty() || (*state.hit - state.stroke.back()).norm() >= 0.003f) &&
      state.stroke.size() < session::kMaxStrokePoints)
    state.stroke.push_back(*state.hit);
  if (!state.drawing && !state.stroke.empty()) {
    if (state.stroke.size() >= 2) {
      session::Annotation a;
      a.kind = session::AnnotationKind::kStroke;
      a.points = std::move(state.stroke);
      send(participant, state, std::move(a), now_us);
    }
    state.stroke.clear();
  }
  // An arrow: from where the right button went down to where it came up.
  if (state.arrow && state.hit && !state.arrow_tail) state.arrow_tail = state.hit;
  if (!state.arrow && state.arrow_tail) {
    if (state.hit && (*state.hit - *state.arrow_tail).norm() > 0.01f) {
      session::Annotation a;
      a.kind = session::AnnotationKind::kArrow;
      a.points = {*state.arrow_tail, *state.hit};
      send(participant, state, std::move(a), now_us);
    }
    state.arrow_tail.reset();
  }
  if (state.pin_label) {
    state.pin_label = false;
    if (state.hit) {
      session::Annotation a;
      a.kind = session::AnnotationKind::kLabel;
      a.points = {*state.hit};
      a.text = state.label;
      send(participant, state, std::move(a), now_us);
    } else {
      state.status = "N pins the label on the surface under the mouse: there is none there";
    }
  }
  // Erase my last: a Backspace counts from now, after what this frame sent (a stroke let go in
  // the same frame as the key went down is what it erases).
  if (state.erase_pressed) state.erase_last.pressed(now_us);
  state.erase_pressed = false;
  if (const auto id = state.erase_last.due(snapshot, now_us)) participant.erase(*id);
  std::vector<Primitive> out;
  if (state.laser || state.dragging) {
    const Eigen::Vector3f through = state.hit.value_or(ahead_of(view, target, x, y));
    out = pointer_primitives(state.origin, state.hit.has_value(), through, rgb,
                             eye.translation.cast<float>());
  }
  if (state.stroke.size() >= 2) {
    session::Annotation preview;
    preview.points = state.stroke;
    const auto shape = annotation_primitives(preview, rgb);
    out.insert(out.end(), shape.begin(), shape.end());
  }
  return out;
}

void draw_label_texts(const SessionSnapshot& snapshot, const View& view, float width,
                      float height) {
  ImDrawList* list = ImGui::GetBackgroundDrawList();
  const Eigen::Matrix4f clip_from_world = view.clip_from_world();
  for (const session::Annotation& a : snapshot.annotations) {
    if (a.kind != session::AnnotationKind::kLabel) continue;
    const Eigen::Vector4f c = clip_from_world * label_anchor(a).homogeneous();
    if (c.w() <= 0) continue;  // behind the eye
    const float x = (c.x() / c.w() + 1) / 2 * width, y = (1 - c.y() / c.w()) / 2 * height;
    const Eigen::Vector3f rgb = participant_color(a.author);
    list->AddText(ImVec2(x + 1, y - 17), IM_COL32(0, 0, 0, 200), a.text.c_str());
    list->AddText(ImVec2(x, y - 18),
                  IM_COL32(int(rgb.x() * 255), int(rgb.y() * 255), int(rgb.z() * 255), 255),
                  a.text.c_str());
  }
}

void draw_annotation_panel(PointingState& state, Participant& participant,
                           const SessionSnapshot& snapshot) {
  if (!ImGui::CollapsingHeader("Pointer and annotations", ImGuiTreeNodeFlags_DefaultOpen)) return;
  ImGui::TextWrapped(
      "Hold L: your laser pointer. Shift+drag (or L + drag) draws, Alt+drag (or L + right drag) "
      "an arrow, N pins the label under the mouse, Backspace erases your last.");
  ImGui::InputText("label", state.label, sizeof state.label);
  if (!state.status.empty())
    ImGui::TextColored(ImVec4(1, 0.5f, 0.3f, 1), "%s", state.status.c_str());
  for (const session::Annotation& a : snapshot.annotations) {
    std::string author =
        a.author == snapshot.id ? "you" : "participant " + std::to_string(a.author);
    for (const RemoteParticipant& o : snapshot.others)
      if (o.id == a.author) author = o.name;
    ImGui::PushID(static_cast<int>(a.id));
    if (ImGui::SmallButton("erase")) participant.erase(a.id);
    ImGui::SameLine();
    ImGui::Text("%s %u by %s%s%s", session::to_string(a.kind), a.id, author.c_str(),
                a.text.empty() ? "" : ": ", a.text.c_str());
    ImGui::PopID();
  }
  if (!snapshot.last_error.empty() && snapshot.last_error.find("annotation") != std::string::npos)
    ImGui::TextColored(ImVec4(1, 0.5f, 0.3f, 1), "%s", snapshot.last_error.c_str());
}

}  // namespace volcast
