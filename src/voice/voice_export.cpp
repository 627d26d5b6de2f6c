#include "volcast/voice/voice_export.hpp"

#include <algorithm>
#include <array>
#include <cctype>
#include <climits>

#include "volcast/audio/opus_voice.hpp"
#include "volcast/audio/wav.hpp"
#include "volcast/core/error.hpp"
#include "volcast/record/recording.hpp"

namespace volcast::voice {
namespace {

using audio::kFrameSamples;

std::string file_safe(const std::string& name) {
  std::string out;
  for (char c : name)
    out += (std::isalnum(static_cast<unsigned char>(c)) || c == '-' || c == '_') ? c : '_';
  return out.empty() ? "speaker" : out;
}

// One speaker's packets on the time line from `t0_us`, into `out` (mono samples).
void decode_speaker(const std::vector<RecordedVoicePacket>& packets, int64_t t0_us,
                    std::vector<float>& out, ExportedVoice& e) {
  audio::VoiceDecoder decoder;
  std::array<float, kFrameSamples> frame{};
  const auto append = [&] { out.insert(out.end(), frame.begin(), frame.end()); };
  const RecordedVoicePacket* previous = nullptr;
  for (const RecordedVoicePacket& p : packets) {
    // Its frame on the time line, rounded (floor division: it may lie before sample 0).
    const int64_t from_t0 = p.capture_us - t0_us + audio::kFrameUs / 2;
    const int64_t at = from_t0 >= 0 ? from_t0 / audio::kFrameUs
                                    : -((-from_t0 + audio::kFrameUs - 1) / audio::kFrameUs);
    if (at < 0) {
      // Said before the first frame set: decoded (the decoder's state runs on) but not written,
      // since writing it at sample 0 would shift the speech after it against the frame sets.
      try {
        decoder.decode(p.bytes, frame);
      } catch (const Error&) {
      }
      ++e.packets;
      ++e.before_start;
      previous = &p;
      continue;
    }
    const int64_t now = static_cast<int64_t>(out.size() / kFrameSamples);
    int64_t missing = std::max<int64_t>(0, at - now);
    // Packets lost before this one (a gap in the sequence) are rebuilt; the rest of the gap is
    // the speaker's silence (DTX).
    int64_t lost =
        previous ? std::min<int64_t>(missing, int64_t(p.sequence - previous->sequence) - 1) : 0;
    lost = std::max<int64_t>(0, lost);
    for (int64_t k = 0; k < missing - lost; ++k) {
      frame.fill(0.0f);
      append();
    }
    for (int64_t k = 0; k < lost; ++k) {
      if (k + 1 == lost)
        decoder.decode_fec(p.bytes, frame);
      else
        decoder.conceal(frame);
      append();
      ++e.concealed;
    }
    try {
      decoder.decode(p.bytes, frame);
    } catch (const Error&) {
      decoder.conceal(frame);
      ++e.concealed;
    }
    append();
    ++e.packets;
    previous = &p;
  }
}

}  // namespace

std::vector<ExportedVoice> export_voices(const std::filesystem::path& recording,
                                         const std::filesystem::path& dir) {
  RecordingReader reader(recording);
  const RecordingInfo& info = reader.info();
  std::vector<ExportedVoice> out;
  if (info.speakers.empty()) return out;
  int64_t t0 = info.frame_sets.empty() ? INT64_MAX : info.frame_sets.front().capture_us;
  if (info.frame_sets.empty())
    for (const RecordedVoice& v : info.voices) t0 = std::min(t0, v.capture_us);
  std::filesystem::create_directories(dir);
  for (const RecordedSpeaker& s : info.speakers) {
    ExportedVoice e;
    e.participant = s.participant;
    e.name = s.name;
    e.path = dir / ("speaker-" + std::to_string(s.participant) + "-" + file_safe(s.name) + ".wav");
    audio::Pcm pcm;
    decode_speaker(reader.voices(s.participant), t0, pcm.samples, e);
    e.seconds = double(pcm.frames()) / audio::kSampleRate;
    audio::write_wav(e.path, pcm);
    out.push_back(std::move(e));
  }
  return out;
}

}  // namespace volcast::voice
