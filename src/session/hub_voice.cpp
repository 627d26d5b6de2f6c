// A SessionHub's voices (voice_messages.hpp): each participant's packets forwarded unchanged to
// the other members of its session and to the OR site's loudspeaker; the OR site's microphone and
// a replay's recorded speakers to everyone.
#include <spdlog/spdlog.h>

#include <algorithm>

#include "hub_state.hpp"
#include "volcast/core/error.hpp"
#include "volcast/core/text.hpp"
#include "volcast/session/names.hpp"

namespace volcast {

void SessionHub::broadcast_voice(uint32_t from, const Shared& message, const Session& s) {
  for (const auto& [pid, other] : s.members)
    if (pid != from && other->info.viewer != 0) {
      send_shared(other->info.viewer, message, voice_key(from));
      ++stats_.voice_out;
    }
}

std::span<const SessionHub::Route> SessionHub::voice_routes() {
  static constexpr Route kRoutes[] = {
      {Type::kVoice, nullptr, &SessionHub::on_voice},
      {Type::kVoiceState, nullptr, &SessionHub::on_voice_state},
  };
  return kRoutes;
}

void SessionHub::on_voice_state(Member& m, Payload payload) {
  const bool muted = session::parse_voice_state(payload);
  m.info.muted = muted;
  m.voice_state = share(session::forward(Type::kVoiceStateFrom, m.info.id, payload));
  for (const auto& [pid, other] : m.session->members)
    if (other.get() != &m)
      send_shared(other->info.viewer, m.voice_state, voice_state_key(m.info.id));
}

void SessionHub::on_voice(Member& m, Payload payload) {
  session::VoicePacketView packet;
  try {
    packet = session::parse_voice(payload);
  } catch (const Error& e) {
    // One bad packet loses only itself (a glitch of the sender's encoder); a run of them is a
    // hostile or broken sender, dropped like any malformed message.
    ++stats_.voice_malformed;
    if (++m.malformed_voice >= session::kMaxMalformedVoice)
      throw Error(std::string(e.what()) + " (" + std::to_string(m.malformed_voice) +
                  " malformed voice packets)");
    if (m.malformed_voice == 1)
      spdlog::warn("session: '{}': {}: the packet is dropped", printable(m.info.name), e.what());
    return;
  }
  ++stats_.voice_in;
  ++m.info.voice_packets;
  broadcast_voice(m.info.id, share(session::forward(Type::kVoiceFrom, m.info.id, payload)),
                  *m.session);
  if (config_.site_listener) config_.site_listener(m.info.id, packet);
}

void SessionHub::site_voice(const session::VoicePacketView& packet) {
  const Shared message =
      share(session::forward(Type::kVoiceFrom, kSiteParticipant, session::serialize(packet)));
  std::lock_guard lock(mutex_);
  ++stats_.voice_in;
  for (const auto& [id, s] : sessions_) broadcast_voice(kSiteParticipant, message, *s);
}

void SessionHub::site_voice_state(bool muted) {
  const Shared message = share(session::forward(Type::kVoiceStateFrom, kSiteParticipant,
                                                session::serialize_voice_state(muted)));
  std::lock_guard lock(mutex_);
  site_muted_ = muted;
  for (const auto& [id, s] : sessions_) {
    Member& site = *s->members.at(kSiteParticipant);
    site.info.muted = muted;
    site.voice_state = message;
    for (const auto& [pid, other] : s->members)
      send_shared(other->info.viewer, message, voice_state_key(kSiteParticipant));
  }
}

SessionHub::Member& SessionHub::add_recorded_member(Session& s, const Recorded& r) {
  auto m = std::make_unique<Member>();
  m->info.id = r.id;
  m->info.name = r.name;
  m->info.role = session::Role::kRemote;
  m->info.recorded = true;
  m->session = &s;
  if (r.or_site) {
    const Eigen::Vector3f& t = config_.room.table.center;
    m->info.spot = {t.x(), t.z(), 0};
  } else {
    m->info.spot = free_spot(s, true);
  }
  Member& ref = *m;
  s.members.emplace(r.id, std::move(m));
  return ref;
}

uint32_t SessionHub::add_recorded_speaker(const std::string& name, bool or_site) {
  static const std::string kSuffix = " (recorded)";
  std::string shown;
  try {
    shown = session::checked_name(
        session::cut_utf8(name, session::kMaxNameBytes - kSuffix.size() - 3) + kSuffix,
        "recorded speaker's name");
  } catch (const Error& e) {
    spdlog::warn("replay: a recorded speaker's name is not shown ({}): 'recorded speaker' instead",
                 e.what());
    shown = "recorded speaker";
  }
  std::lock_guard lock(mutex_);
  // Apart from the OR site's and the other recorded speakers' names (a Join's would be refused).
  const auto looks_taken = [&](const std::string& candidate) {
    const std::string skeleton = session::name_skeleton(candidate);
    if (session::name_skeleton(config_.site_name) == skeleton) return true;
    return std::any_of(recorded_.begin(), recorded_.end(), [&](const Recorded& r) {
      return session::name_skeleton(r.name) == skeleton;
    });
  };
  std::string unique = shown;
  for (int n = 2; looks_taken(unique); ++n) unique = shown + " " + std::to_string(n);
  const Recorded r{next_participant_++, unique, or_site};
  recorded_.push_back(r);
  for (const auto& [id, s] : sessions_) {
    const Member& m = add_recorded_member(*s, r);
    const Shared announce = share(session::message(
        Type::kParticipantJoined, session::serialize(session::ParticipantInfo{
                                      m.info.id, m.info.name, m.info.role, false, m.info.spot})));
    for (const auto& [pid, other] : s->members) send_shared(other->info.viewer, announce);
  }
  spdlog::info("sessions: recorded speaker '{}' is participant {}", printable(unique), r.id);
  return r.id;
}

bool SessionHub::recorded_voice(uint32_t speaker, const session::VoicePacketView& packet) {
  const Shared message =
      share(session::forward(Type::kVoiceFrom, speaker, session::serialize(packet)));
  std::lock_guard lock(mutex_);
  if (std::none_of(recorded_.begin(), recorded_.end(),
                   [&](const Recorded& r) { return r.id == speaker; }))
    return false;
  ++stats_.voice_in;
  for (const auto& [id, s] : sessions_) {
    if (const auto it = s->members.find(speaker); it != s->members.end())
      ++it->second->info.voice_packets;
    broadcast_voice(speaker, message, *s);
  }
  if (config_.site_listener) config_.site_listener(speaker, packet);
  return true;
}

}  // namespace volcast
