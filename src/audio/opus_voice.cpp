#include "volcast/audio/opus_voice.hpp"

#include <opus.h>

#include <cstring>
#include <memory>
#include <string>

#include "volcast/core/error.hpp"

namespace volcast::audio {
namespace {

constexpr auto kFrameInt = static_cast<int>(kFrameSamples);

void check_ctl(int rc, const char* what) {
  if (rc != OPUS_OK) throw Error(std::string("opus encoder: ") + what + ": " + opus_strerror(rc));
}

// Why `packet` is not a voice packet, or nullptr if it is one.
const char* voice_packet_fault(std::span<const uint8_t> packet) {
  if (packet.empty()) return "empty";
  if (packet.size() > kMaxOpusPacketBytes) return "larger than 1275 bytes";
  const auto len = static_cast<opus_int32>(packet.size());
  if (opus_packet_get_nb_channels(packet.data()) != 1) return "not mono";
  if (opus_packet_get_nb_samples(packet.data(), len, kSampleRate) != kFrameInt) {
    return "not 20 ms of audio";
  }
  unsigned char toc = 0;
  const unsigned char* frames[48];
  opus_int16 sizes[48];
  int payload_offset = 0;
  if (opus_packet_parse(packet.data(), len, &toc, frames, sizes, &payload_offset) < 0) {
    return "bad frame lengths";
  }
  return nullptr;
}

void check_packet(std::span<const uint8_t> packet) {
  if (const char* fault = voice_packet_fault(packet)) {
    throw Error(std::string("malformed voice packet: ") + fault + " (" +
                std::to_string(packet.size()) + " bytes)");
  }
}

}  // namespace

bool is_voice_packet(std::span<const uint8_t> packet) {
  return voice_packet_fault(packet) == nullptr;
}

struct VoiceEncoder::Codec {
  OpusEncoder* enc = nullptr;
  ~Codec() { opus_encoder_destroy(enc); }
};

VoiceEncoder::VoiceEncoder(VoiceEncoderConfig config) : codec_(std::make_unique<Codec>()) {
  int err = OPUS_OK;
  codec_->enc = opus_encoder_create(kSampleRate, 1, OPUS_APPLICATION_VOIP, &err);
  if (codec_->enc == nullptr)
    throw Error(std::string("opus_encoder_create: ") + opus_strerror(err));
  OpusEncoder* enc = codec_->enc;
  check_ctl(opus_encoder_ctl(enc, OPUS_SET_BITRATE(config.bitrate_bps)), "bitrate");
  check_ctl(opus_encoder_ctl(enc, OPUS_SET_INBAND_FEC(config.fec ? 1 : 0)), "fec");
  check_ctl(opus_encoder_ctl(enc, OPUS_SET_DTX(config.dtx ? 1 : 0)), "dtx");
  check_ctl(opus_encoder_ctl(enc, OPUS_SET_PACKET_LOSS_PERC(config.expected_loss_percent)),
            "expected loss percent");
  check_ctl(opus_encoder_ctl(enc, OPUS_SET_COMPLEXITY(config.complexity)), "complexity");
  check_ctl(opus_encoder_ctl(enc, OPUS_SET_SIGNAL(OPUS_SIGNAL_VOICE)), "signal");
}

VoiceEncoder::~VoiceEncoder() = default;
VoiceEncoder::VoiceEncoder(VoiceEncoder&&) noexcept = default;
VoiceEncoder& VoiceEncoder::operator=(VoiceEncoder&&) noexcept = default;

std::span<const uint8_t> VoiceEncoder::encode(std::span<const float, kFrameSamples> pcm) {
  const opus_int32 n = opus_encode_float(codec_->enc, pcm.data(), kFrameInt, packet_.data(),
                                         static_cast<opus_int32>(packet_.size()));
  if (n < 0) throw Error(std::string("opus_encode_float: ") + opus_strerror(n));
  last_was_dtx_ = n <= 2;
  return {packet_.data(), static_cast<size_t>(n)};
}

struct VoiceDecoder::Codec {
  OpusDecoder* dec = nullptr;
  size_t size = 0;                   // opus_decoder_get_size(1), bytes
  std::unique_ptr<uint8_t[]> saved;  // save()'s copy of *dec
  ~Codec() { opus_decoder_destroy(dec); }
};

VoiceDecoder::VoiceDecoder() : codec_(std::make_unique<Codec>()) {
  int err = OPUS_OK;
  codec_->dec = opus_decoder_create(kSampleRate, 1, &err);
  if (codec_->dec == nullptr)
    throw Error(std::string("opus_decoder_create: ") + opus_strerror(err));
  codec_->size = static_cast<size_t>(opus_decoder_get_size(1));
  codec_->saved = std::make_unique<uint8_t[]>(codec_->size);
  save();
}

VoiceDecoder::~VoiceDecoder() = default;
VoiceDecoder::VoiceDecoder(VoiceDecoder&&) noexcept = default;
VoiceDecoder& VoiceDecoder::operator=(VoiceDecoder&&) noexcept = default;

namespace {

void run_decode(OpusDecoder* dec, const uint8_t* data, size_t size, float* out, int fec) {
  const int n = opus_decode_float(dec, data, static_cast<opus_int32>(size), out, kFrameInt, fec);
  if (n < 0) throw Error(std::string("malformed voice packet: ") + opus_strerror(n));
  if (n != kFrameInt) {
    throw Error("malformed voice packet: decoded " + std::to_string(n) + " samples, not 960");
  }
}

}  // namespace

void VoiceDecoder::decode(std::span<const uint8_t> packet, std::span<float, kFrameSamples> out) {
  check_packet(packet);
  run_decode(codec_->dec, packet.data(), packet.size(), out.data(), 0);
}

void VoiceDecoder::decode_fec(std::span<const uint8_t> next_packet,
                              std::span<float, kFrameSamples> out) {
  check_packet(next_packet);
  run_decode(codec_->dec, next_packet.data(), next_packet.size(), out.data(), 1);
}

void VoiceDecoder::conceal(std::span<float, kFrameSamples> out) {
  run_decode(codec_->dec, nullptr, 0, out.data(), 0);
}

void VoiceDecoder::save() {
  std::memcpy(codec_->saved.get(), codec_->dec, codec_->size);
}

void VoiceDecoder::restore() {
  std::memcpy(codec_->dec, codec_->saved.get(), codec_->size);
}

}  // namespace volcast::audio
