// The session messages' layouts as data (message_layout.hpp), which the page's codec is made
// from: every type's described fields walk exactly the bytes its C++ encoder writes, so a layout
// the page reads cannot differ from the one the server writes. Synthetic messages: exact
// behaviour only.
#include <gtest/gtest.h>

#include <functional>
#include <map>
#include <set>

#include "volcast/core/error.hpp"
#include "volcast/core/wire.hpp"
#include "volcast/net/protocol/protocol.hpp"
#include "volcast/session/annotations.hpp"
#include "volcast/session/message_layout.hpp"
#include "volcast/session/message_table.hpp"
#include "volcast/session/messages.hpp"
#include "volcast/session/objects.hpp"
#include "volcast/session/voice_messages.hpp"

namespace volcast {
namespace {

using session::FieldKind;
using session::LayoutField;
using session::Type;
using Bytes = std::vector<uint8_t>;

// Walks `fields` over `p` from `at` as a reader that knows only the description would; returns
// where it stopped. A length that runs past the end fails the test and stops the walk.
size_t walk(const std::vector<LayoutField>& fields, std::span<const uint8_t> p, size_t at) {
  auto take = [&](size_t n) {
    EXPECT_LE(at + n, p.size()) << "a field runs past the payload";
    at = std::min(at + n, p.size());
  };
  auto u16 = [&] { return at + 2 <= p.size() ? wire::load<uint16_t>(p.data() + at) : 0; };
  for (const LayoutField& f : fields) {
    switch (f.kind) {
      case FieldKind::kTail:
        if (at == p.size()) return at;
        break;
      case FieldKind::kU8:
      case FieldKind::kFlag:
      case FieldKind::kEnum:
        take(1);
        break;
      case FieldKind::kU16:
        take(2);
        break;
      case FieldKind::kU32:
      case FieldKind::kF32:
      case FieldKind::kFinite:
        take(4);
        break;
      case FieldKind::kU64:
      case FieldKind::kI64:
        take(8);
        break;
      case FieldKind::kString:
      case FieldKind::kName: {
        const size_t n = u16();
        take(2 + n);
        break;
      }
      case FieldKind::kBytes: {
        const size_t n = at + 4 <= p.size() ? wire::load<uint32_t>(p.data() + at) : 0;
        take(4 + n);
        break;
      }
      case FieldKind::kSpot:
      case FieldKind::kVec3:
        take(12);
        break;
      case FieldKind::kPose:
        take(28);
        break;
      case FieldKind::kList: {
        const size_t n = u16();
        EXPECT_LE(n, f.max) << f.name;
        take(2);
        for (size_t i = 0; i < n; ++i) at = walk(f.items, p, at);
        break;
      }
    }
  }
  return at;
}

Bytes forwarded(Type type, uint32_t from, const Bytes& payload) {
  const Bytes m = session::forward(type, from, payload);
  return {m.begin() + protocol::kHeaderBytes, m.end()};
}

// One real payload of every described type, from its C++ encoder (and, for a Join, one with and
// one without its optional tail).
std::multimap<Type, Bytes> samples() {
  session::Join join{"OR 1", true, "Dr. Müller", session::Role::kRemote, true, {}};
  session::Join rejoin = join;
  rejoin.rejoin_key = {0x1234, 5};
  session::PoseMessage pose;
  pose.sequence = 9;
  pose.body.hands_tracked = true;
  const session::Spot spot{1.5f, -2, 0.25f};
  session::ObjectRequest request{3, 2, {}};
  MonitorState monitor;
  monitor.generation = 3;
  monitor.width = 400;
  monitor.by = 7;
  const uint8_t opus[] = {1, 2, 3, 4, 5};
  const session::VoicePacketView voice{11, 480, 123, opus};
  session::PointerMessage pointer{4, 99, true, {0, 1, 2}, true, {1, 1, 1}};
  session::Annotation stroke;
  stroke.points = {{0, 1, 0}, {0.1f, 1, 0}, {0.2f, 1.1f, 0}};
  stroke.id = 12;
  session::Annotation label = stroke;
  label.kind = session::AnnotationKind::kLabel;
  label.points.resize(1);
  label.text = "resection line";
  session::Joined joined{7, 2, "OR 1", spot, {0.5f, 0, -1}, 0.1f};
  session::ParticipantInfo info{7, "Dr. Müller", session::Role::kOrSite, true, spot};
  session::Teleported teleported{7, spot, spot, 77};
  session::ObjectState state{3, 1, 7, 12, 500, {}};
  session::RecordingState recording{true, 1'700'000'000'000'000, "the OR server"};
  return {
      {Type::kListSessions, {}},
      {Type::kJoin, session::serialize(join)},
      {Type::kJoin, session::serialize(rejoin)},
      {Type::kLeave, {}},
      {Type::kPose, session::serialize(pose)},
      {Type::kPoseEcho, session::serialize_echo(7, 9)},
      {Type::kTeleport, session::serialize(spot)},
      {Type::kHeartbeat, {}},
      {Type::kGrab, session::serialize(request, false)},
      {Type::kObjectMove, session::serialize(request, true)},
      {Type::kRelease, session::serialize(request, true)},
      {Type::kSetMonitor, session::serialize_set_monitor(monitor)},
      {Type::kVoice, session::serialize(voice)},
      {Type::kVoiceState, session::serialize_voice_state(true)},
      {Type::kPointer, session::serialize(pointer)},
      {Type::kAnnotate, session::serialize_annotate(stroke)},
      {Type::kAnnotate, session::serialize_annotate(label)},
      {Type::kErase, session::serialize_erase(12)},
      {Type::kSessionList, session::serialize({{1, "OR 1", 3}, {2, "Tumour board", 70000}})},
      {Type::kJoined, session::serialize(joined)},
      {Type::kSessionError, session::serialize_error("session 'OR 2' is full")},
      {Type::kParticipantJoined, session::serialize(info)},
      {Type::kParticipantLeft, session::serialize_left(7, session::LeftReason::kTimedOut)},
      {Type::kPoseFrom, forwarded(Type::kPoseFrom, 7, session::serialize(pose))},
      {Type::kPoseEchoFrom, session::serialize_echo(8, 9)},
      {Type::kTeleported, session::serialize(teleported)},
      {Type::kObjectState, session::serialize(state)},
      {Type::kMonitorState, session::serialize(monitor)},
      {Type::kVoiceFrom, forwarded(Type::kVoiceFrom, 7, session::serialize(voice))},
      {Type::kVoiceStateFrom,
       forwarded(Type::kVoiceStateFrom, 7, session::serialize_voice_state(false))},
      {Type::kPointerFrom, forwarded(Type::kPointerFrom, 7, session::serialize(pointer))},
      {Type::kAnnotation, session::serialize(stroke)},
      {Type::kAnnotation, session::serialize(label)},
      {Type::kErased, session::serialize_erased(12, 7)},
      {Type::kRecordingState, session::serialize(recording)},
  };
}

TEST(SessionLayouts, EveryDescribedLayoutWalksExactlyWhatItsEncoderWrites) {
  const auto all = samples();
  std::set<Type> undescribed;
  for (const session::PayloadLayout& l : session::payload_layouts()) {
    if (!l.described) {
      EXPECT_TRUE(l.fields.empty());
      undescribed.insert(l.type);
      continue;
    }
    const auto [first, last] = all.equal_range(l.type);
    EXPECT_NE(first, last) << "no sample of described type " << int(l.type);
    for (auto it = first; it != last; ++it) {
      SCOPED_TRACE(session::find_message(static_cast<uint8_t>(l.type))->name);
      // The table's own decoder takes the sample, and the description ends where it does.
      session::find_message(static_cast<uint8_t>(l.type))->check(it->second);
      EXPECT_EQ(walk(l.fields, it->second, 0), it->second.size());
    }
  }
  // Bulk payloads, by hand: the avatar camera and frames, the case.
  EXPECT_EQ(undescribed,
            (std::set<Type>{Type::kAvatarCamera, Type::kAvatarFrame, Type::kAvatarCameraFrom,
                            Type::kAvatarFrameFrom, Type::kCase}));
  EXPECT_EQ(session::payload_layouts().size(), session::message_table().size());
}

// The names the page's fields take, and what the description says of limits and tails.
TEST(SessionLayouts, FieldsCarryTheirNamesLimitsAndTails) {
  auto names = [](const session::PayloadLayout* l) {
    std::vector<std::string> out;
    for (const LayoutField& f : l->fields) out.push_back(f.name + ":" + to_string(f.kind));
    return out;
  };
  EXPECT_EQ(names(session::find_layout(0x42)),
            (std::vector<std::string>{"participant:u32", "session:u32", "session_name:name",
                                      "spot:spot", "site_translation:vec3", "site_yaw:finite"}));
  EXPECT_EQ(names(session::find_layout(0x46)).front(), "participant:u32");  // forwarded
  EXPECT_EQ(names(session::find_layout(0x02)),
            (std::vector<std::string>{"session_name:name", "create:flag", "display_name:name",
                                      "role:enum", "has_camera:flag", ":tail", "rejoin_key_low:u64",
                                      "rejoin_key_high:u64"}));
  const LayoutField& points = session::find_layout(0x11)->fields[5];
  EXPECT_EQ(points.kind, FieldKind::kList);
  EXPECT_EQ(points.max, session::kMaxStrokePoints);
  ASSERT_EQ(points.items.size(), 1u);
  EXPECT_EQ(points.items[0].kind, FieldKind::kVec3);
  EXPECT_EQ(session::find_layout(0x44)->fields[2].max, 1u);  // role: 0..1
  EXPECT_EQ(session::find_layout(0x7f), nullptr);
}

// The checks the description names are the decoder's, in the same words the page uses.
TEST(SessionLayouts, TheDecoderNamesTheFieldItRefuses) {
  session::ParticipantInfo info{7, "Dr. Müller", session::Role::kRemote, false, {}};
  Bytes bad = session::serialize(info);
  bad[4 + 2 + info.name.size() + 1] = 2;  // has_camera
  try {
    session::parse_participant(bad);
    ADD_FAILURE() << "a flag of 2 was taken";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "malformed participant joined: has camera is neither 0 nor 1");
  }
  Bytes list = session::serialize(std::vector<session::SessionSummary>{{1, "OR", 1}});
  wire::store<uint16_t>(list.data(), 65);
  try {
    session::parse_session_list(list);
    ADD_FAILURE() << "65 sessions were taken";
  } catch (const Error& e) {
    EXPECT_STREQ(e.what(), "malformed session list: 65 sessions, more than 64");
  }
}

}  // namespace
}  // namespace volcast
