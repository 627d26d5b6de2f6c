// A Participant's camera avatars of the others (participant.hpp): their cameras, announced
// (0x49), and their newest frames (0x4a), decoded when asked (Participant::avatar_frame).
#include "participant_impl.hpp"

namespace volcast {

std::span<const Participant::Impl::Route> Participant::Impl::avatar_routes() {
  static constexpr Route kRoutes[] = {
      {Type::kAvatarCameraFrom, &Impl::on_avatar_camera},
      {Type::kAvatarFrameFrom, &Impl::on_avatar_frame},
  };
  return kRoutes;
}

void Participant::Impl::on_avatar_camera(Payload p, int64_t) {
  const auto [id, rest] = session::split_forwarded(p);
  session::AvatarCamera cam = session::parse_avatar_camera(rest);
  const auto it = remotes.find(id);
  if (it == remotes.end()) return;
  std::lock_guard decode_lock(decode_mutex);
  Remote& r = *it->second;
  r.depth_decoder = make_depth_decoder(cam.depth_codec);
  r.color_decoder = make_color_decoder(cam.color_codec);
  r.info.has_camera = true;
  r.camera = std::move(cam);
  r.decoded_sequence = 0;
  r.decoded.reset();
}

void Participant::Impl::on_avatar_frame(Payload p, int64_t now_server) {
  const auto [id, rest] = session::split_forwarded(p);
  const auto it = remotes.find(id);
  if (it == remotes.end() || !it->second->camera) return;
  Remote& r = *it->second;
  const session::AvatarFrameView f = session::parse_avatar_frame(rest, r.camera->calibration);
  if (f.sequence <= r.info.avatar_sequence) return;
  r.info.avatar_sequence = f.sequence;
  r.avatar_payload = std::make_shared<const std::vector<uint8_t>>(rest.begin(), rest.end());
  const int64_t rx = wall_clock_us();
  if (r.avatars_received++ == 0) r.first_avatar_rx_us = rx;
  r.last_avatar_rx_us = rx;
  add_sample(r.avatar_latencies_ms, double(now_server - f.capture_us) / 1000.0);
}

}  // namespace volcast
