// The hub's camera avatars (hub.hpp): a participant's RGB-D camera, announced once per
// connection (0x07), and its frames (0x08), checked against it and forwarded to the others
// unchanged (0x49, 0x4a; messages.hpp).
#include <string>

#include "hub_state.hpp"
#include "volcast/codec/registry.hpp"
#include "volcast/core/error.hpp"

namespace volcast {

std::span<const SessionHub::Route> SessionHub::avatar_routes() {
  static constexpr Route kRoutes[] = {
      {Type::kAvatarCamera, &SessionHub::on_avatar_camera},
      {Type::kAvatarFrame, nullptr, &SessionHub::on_avatar_frame},
  };
  return kRoutes;
}

void SessionHub::on_avatar_camera(uint64_t viewer, Member* m, Payload payload) {
  session::AvatarCamera cam = session::parse_avatar_camera(payload);
  if (!in_session(viewer, m, "avatar camera")) return;
  // Once per connection: a participant that rejoined after a cut (take_over) announces its
  // camera again on its new one, and the others take it as new (it may have changed).
  if (m->camera && m->camera_viewer == viewer) throw Error("avatar camera announced twice");
  m->camera = std::move(cam);
  m->camera_viewer = viewer;
  m->info.has_camera = true;
  m->camera_message = share(session::forward(Type::kAvatarCameraFrom, m->info.id, payload));
  for (const auto& [pid, other] : m->session->members)
    if (other.get() != m) send_shared(other->info.viewer, m->camera_message);
}

void SessionHub::on_avatar_frame(Member& m, Payload payload) {
  if (!m.camera) throw Error("avatar frame before its camera was announced");
  const session::AvatarFrameView f = session::parse_avatar_frame(payload, m.camera->calibration);
  const Intrinsics& k = m.camera->calibration.depth;
  const auto d = declared_depth_size(f.depth);
  if (!d || d->width != k.width || d->height != k.height)
    throw Error("malformed avatar frame: its depth stream is not a " + std::to_string(k.width) +
                "x" + std::to_string(k.height) + " frame of the announced codec");
  if (!f.color.empty())
    if (const auto c = declared_color_size(f.color);
        c && (c->width != k.width || c->height != k.height))
      throw Error("malformed avatar frame: its color stream has another size than its camera");
  ++stats_.avatar_frames_in;
  ++m.info.avatar_frames;
  const Shared msg = share(session::forward(Type::kAvatarFrameFrom, m.info.id, payload));
  for (const auto& [pid, other] : m.session->members)
    if (other.get() != &m && other->info.viewer != 0) {
      send_shared(other->info.viewer, msg, avatar_key(m.info.id));
      ++stats_.avatar_frames_out;
      stats_.avatar_bytes_out += msg->size();
    }
}

}  // namespace volcast
