// libFuzzer target: every session-channel parser (volcast/session/messages.hpp, objects.hpp,
// voice_messages.hpp, annotations.hpp), the pose script parser and the name check (names.hpp, ICU)
// on arbitrary bytes. The first byte picks the parser; a parser may throw Error, nothing else (no
// crash, no read past the input, no unbounded allocation).
#include <cstdint>
#include <span>
#include <string>

#include "volcast/core/error.hpp"
#include "volcast/session/annotations.hpp"
#include "volcast/session/messages.hpp"
#include "volcast/session/names.hpp"
#include "volcast/session/objects.hpp"
#include "volcast/session/pose_script.hpp"
#include "volcast/session/voice_messages.hpp"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  using namespace volcast;
  if (size == 0) return 0;
  const std::span<const uint8_t> p(data + 1, size - 1);
  CameraCalibration camera;
  camera.depth.width = 640;
  camera.depth.height = 360;
  try {
    switch (data[0] % 23) {
      case 0:
        session::parse_join(p);
        break;
      case 1:
        session::parse_session_list(p);
        break;
      case 2:
        session::parse_joined(p);
        break;
      case 3:
        session::parse_error(p);
        break;
      case 4:
        session::parse_participant(p);
        break;
      case 5:
        session::parse_left(p);
        break;
      case 6:
        session::parse_pose(p);
        break;
      case 7:
        session::parse_echo(p);
        break;
      case 8:
        session::parse_teleport(p);
        break;
      case 9:
        session::parse_teleported(p);
        break;
      case 10:
        session::parse_avatar_camera(p);
        break;
      case 11: {
        const auto [id, rest] = session::split_forwarded(p);
        session::parse_avatar_frame(rest, camera);
        break;
      }
      case 12:
        parse_pose_script(std::string(p.begin(), p.end())).at(1.5);
        break;
      case 13: {  // a case, and the monitor drawn from it at its last slice
        const SharedCase c = session::parse_case(p);
        if (c.monitor) {
          MonitorState m;
          m.slice = static_cast<uint16_t>(c.monitor->slices - 1);
          monitor_image(*c.monitor, m);
        }
        break;
      }
      case 14:
        session::parse_object_state(p);
        break;
      case 15:
        session::parse_monitor_state(p);
        break;
      case 16:
        session::parse_set_monitor(p);
        break;
      case 17:
        session::parse_object_request(p, p.size() % 2 == 0);
        break;
      case 18:  // a name as a peer sends it: checked, then its skeleton
        session::name_skeleton(session::checked_name(
            std::string_view(reinterpret_cast<const char*>(p.data()), p.size()), "name"));
        break;
      case 19:
        session::parse_voice(p);
        session::parse_voice_state(p);
        break;
      case 20:
        session::parse_pointer(p);
        break;
      case 21: {  // an annotation as the server sends it; a label's text as the hub checks it
        const session::Annotation a = session::parse_annotation(p);
        if (a.kind == session::AnnotationKind::kLabel) session::check_label_text(a.text);
        break;
      }
      case 22:
        session::parse_annotate(p);
        session::parse_erase(p);
        session::parse_erased(p);
        break;
    }
  } catch (const Error&) {
  }
  return 0;
}
