// SpatialMixer on OpenAL Soft's loopback device (ALC_SOFT_loopback, ALC_SOFT_HRTF,
// ALC_EXT_thread_local_context; OpenAL Soft 1.19's extension docs in /usr/include/AL/alext.h).
#include "volcast/audio/spatial_mixer.hpp"

#define AL_ALEXT_PROTOTYPES
#include <AL/al.h>
#include <AL/alc.h>
#include <AL/alext.h>

#include <algorithm>
#include <array>
#include <cstring>
#include <mutex>
#include <vector>

#include "volcast/core/error.hpp"

namespace volcast::audio {
namespace {

constexpr int kAlBuffers = 3;   // per voice: two queued in OpenAL, one spare
constexpr int kPlayFrames = 2;  // frames a voice keeps queued in OpenAL while it plays

// Makes `context` this thread's OpenAL context for the scope, then restores the previous one, so
// that mixers on one thread or many never touch each other's state.
class ContextScope {
 public:
  explicit ContextScope(ALCcontext* context) : previous_(alcGetThreadContext()) {
    alcSetThreadContext(context);
  }
  ~ContextScope() { alcSetThreadContext(previous_); }
  ContextScope(const ContextScope&) = delete;
  ContextScope& operator=(const ContextScope&) = delete;

 private:
  ALCcontext* previous_;
};

// One voice: an OpenAL source, its buffers and the frames pushed but not yet given to OpenAL.
struct Voice {
  bool used = false;
  uint32_t id = 0;
  ALuint source = 0;
  std::array<ALuint, kAlBuffers> buffers{};
  std::array<ALuint, kAlBuffers> free_buffers{};
  int free_count = 0;
  int in_al = 0;               // buffers queued on the source, not yet unqueued
  std::vector<float> pending;  // ring of kMaxQueuedFrames frames
  int pending_head = 0;
  int pending_count = 0;
  int waited = 0;  // renders a stopped voice has waited with one frame
};

std::string status_words(ALCint status) {
  switch (status) {
    case ALC_HRTF_DISABLED_SOFT:
      return "disabled";
    case ALC_HRTF_ENABLED_SOFT:
      return "enabled";
    case ALC_HRTF_DENIED_SOFT:
      return "denied";
    case ALC_HRTF_REQUIRED_SOFT:
      return "required";
    case ALC_HRTF_HEADPHONES_DETECTED_SOFT:
      return "headphones detected";
    case ALC_HRTF_UNSUPPORTED_FORMAT_SOFT:
      return "unsupported format";
    default:
      return "unknown (" + std::to_string(status) + ")";
  }
}

// The index of the HRTF data set made for 48 kHz among those the device lists, or -1 (then
// OpenAL Soft picks its default).
ALCint hrtf_48k_index(ALCdevice* device) {
  ALCint count = 0;
  alcGetIntegerv(device, ALC_NUM_HRTF_SPECIFIERS_SOFT, 1, &count);
  for (ALCint i = 0; i < count; ++i) {
    const ALCchar* name = alcGetStringiSOFT(device, ALC_HRTF_SPECIFIER_SOFT, i);
    if (name != nullptr && std::strstr(name, "48000") != nullptr) return i;
  }
  return -1;
}

void check_al(const char* what) {
  const ALenum error = alGetError();
  if (error != AL_NO_ERROR) {
    throw Error(std::string("OpenAL: ") + what + " failed (error 0x" + std::to_string(error) + ")");
  }
}

}  // namespace

struct SpatialMixer::Impl {
  SpatialConfig config;
  mutable std::mutex mutex;
  ALCdevice* device = nullptr;
  ALCcontext* context = nullptr;
  std::vector<Voice> voices;

  Impl() = default;
  Impl(const Impl&) = delete;
  Impl& operator=(const Impl&) = delete;
  ~Impl();

  Voice* find(uint32_t id) {
    for (Voice& voice : voices) {
      if (voice.used && voice.id == id) return &voice;
    }
    return nullptr;
  }

  void open();
  void create_voices();
  void reset(Voice& voice);
  void feed(Voice& voice);
  void queue_one(Voice& voice);
};

SpatialMixer::Impl::~Impl() {
  if (context != nullptr) {
    {
      const ContextScope scope(context);
      for (Voice& voice : voices) {
        if (voice.source == 0) continue;
        alSourceStop(voice.source);
        alSourcei(voice.source, AL_BUFFER, 0);
        alDeleteSources(1, &voice.source);
        alDeleteBuffers(kAlBuffers, voice.buffers.data());
      }
    }
    alcDestroyContext(context);
  }
  if (device != nullptr) alcCloseDevice(device);
}

void SpatialMixer::Impl::open() {
  if (alcIsExtensionPresent(nullptr, "ALC_SOFT_loopback") != ALC_TRUE) {
    throw Error("OpenAL: the ALC_SOFT_loopback extension is missing (OpenAL Soft is required)");
  }
  if (alcIsExtensionPresent(nullptr, "ALC_EXT_thread_local_context") != ALC_TRUE) {
    throw Error("OpenAL: the ALC_EXT_thread_local_context extension is missing");
  }
  device = alcLoopbackOpenDeviceSOFT(nullptr);
  if (device == nullptr) throw Error("OpenAL: cannot open a loopback device");
  if (alcIsRenderFormatSupportedSOFT(device, kSampleRate, ALC_STEREO_SOFT, ALC_FLOAT_SOFT) !=
      ALC_TRUE) {
    throw Error("OpenAL: the loopback device refuses float stereo at 48 kHz");
  }
  std::vector<ALCint> attributes = {ALC_FORMAT_CHANNELS_SOFT,
                                    ALC_STEREO_SOFT,
                                    ALC_FORMAT_TYPE_SOFT,
                                    ALC_FLOAT_SOFT,
                                    ALC_FREQUENCY,
                                    kSampleRate,
                                    ALC_MONO_SOURCES,
                                    config.max_sources,
                                    ALC_STEREO_SOURCES,
                                    0,
                                    ALC_OUTPUT_LIMITER_SOFT,
                                    ALC_TRUE,
                                    ALC_HRTF_SOFT,
                                    config.hrtf ? ALC_TRUE : ALC_FALSE};
  if (config.hrtf) {
    const ALCint index = hrtf_48k_index(device);
    if (index >= 0) attributes.insert(attributes.end(), {ALC_HRTF_ID_SOFT, index});
  }
  attributes.push_back(0);
  context = alcCreateContext(device, attributes.data());
  if (context == nullptr) {
    throw Error("OpenAL: cannot create a context on the loopback device (ALC error 0x" +
                std::to_string(alcGetError(device)) + ")");
  }
}

void SpatialMixer::Impl::create_voices() {
  const ContextScope scope(context);
  alDistanceModel(AL_INVERSE_DISTANCE_CLAMPED);
  check_al("alDistanceModel");
  voices.resize(static_cast<size_t>(config.max_sources));
  for (Voice& voice : voices) {
    alGenSources(1, &voice.source);
    check_al("alGenSources");
    alGenBuffers(kAlBuffers, voice.buffers.data());
    check_al("alGenBuffers");
    alSourcef(voice.source, AL_REFERENCE_DISTANCE, config.reference_distance_m);
    alSourcef(voice.source, AL_ROLLOFF_FACTOR, config.rolloff);
    alSourcef(voice.source, AL_MAX_DISTANCE, config.max_distance_m);
    alSourcei(voice.source, AL_SOURCE_RELATIVE, AL_FALSE);
    check_al("alSource (distance model)");
    voice.pending.assign(static_cast<size_t>(kMaxQueuedFrames) * kFrameSamples, 0.0f);
    reset(voice);
  }
}

// Stops the voice's source, takes back its buffers and forgets its frames. Context current.
void SpatialMixer::Impl::reset(Voice& voice) {
  alSourceStop(voice.source);
  alSourcei(voice.source, AL_BUFFER, 0);
  voice.free_buffers = voice.buffers;
  voice.free_count = kAlBuffers;
  voice.in_al = 0;
  voice.pending_head = 0;
  voice.pending_count = 0;
  voice.waited = 0;
}

// Moves the oldest pending frame into a free OpenAL buffer queued on the source. Context current.
void SpatialMixer::Impl::queue_one(Voice& voice) {
  const ALuint buffer = voice.free_buffers[static_cast<size_t>(--voice.free_count)];
  const float* frame =
      voice.pending.data() + static_cast<size_t>(voice.pending_head) * kFrameSamples;
  alBufferData(buffer, AL_FORMAT_MONO_FLOAT32, frame,
               static_cast<ALsizei>(kFrameSamples * sizeof(float)), kSampleRate);
  alSourceQueueBuffers(voice.source, 1, &buffer);
  voice.pending_head = (voice.pending_head + 1) % kMaxQueuedFrames;
  --voice.pending_count;
  ++voice.in_al;
}

// Before a render: takes back played buffers and keeps kPlayFrames frames queued on a playing
// voice; starts a stopped one once it has two frames (or one that has waited a frame).
void SpatialMixer::Impl::feed(Voice& voice) {
  ALint processed = 0;
  alGetSourcei(voice.source, AL_BUFFERS_PROCESSED, &processed);
  for (ALint i = 0; i < processed && voice.in_al > 0; ++i) {
    ALuint buffer = 0;
    alSourceUnqueueBuffers(voice.source, 1, &buffer);
    voice.free_buffers[static_cast<size_t>(voice.free_count++)] = buffer;
    --voice.in_al;
  }
  ALint state = AL_STOPPED;
  alGetSourcei(voice.source, AL_SOURCE_STATE, &state);
  const bool playing = state == AL_PLAYING && voice.in_al > 0;
  if (!playing) {
    const int available = voice.in_al + voice.pending_count;
    if (available == 0) return;
    if (available < kPlayFrames && voice.waited++ == 0) return;
    voice.waited = 0;
  }
  while (voice.in_al < kPlayFrames && voice.pending_count > 0 && voice.free_count > 0) {
    queue_one(voice);
  }
  if (!playing && voice.in_al > 0) alSourcePlay(voice.source);
}

SpatialMixer::SpatialMixer(SpatialConfig config) : impl_(std::make_unique<Impl>()) {
  if (config.max_sources < 1 || config.max_sources > 256) {
    throw Error("SpatialMixer: max_sources must be 1..256, not " +
                std::to_string(config.max_sources));
  }
  impl_->config = config;
  impl_->open();  // on a throw, ~Impl closes what was opened
  impl_->create_voices();
}

SpatialMixer::~SpatialMixer() = default;

void SpatialMixer::set_listener(const Eigen::Vector3f& room_position,
                                const Eigen::Quaternionf& room_from_head) {
  const Eigen::Matrix3f rotation = room_from_head.normalized().toRotationMatrix();
  const Eigen::Vector3f at = -rotation.col(2);  // the head looks down its -z
  const Eigen::Vector3f up = rotation.col(1);
  const std::array<ALfloat, 6> orientation = {at.x(), at.y(), at.z(), up.x(), up.y(), up.z()};
  const std::lock_guard lock(impl_->mutex);
  const ContextScope scope(impl_->context);
  alListener3f(AL_POSITION, room_position.x(), room_position.y(), room_position.z());
  alListenerfv(AL_ORIENTATION, orientation.data());
}

void SpatialMixer::set_source(uint32_t id, const Eigen::Vector3f& room_position, float gain) {
  const std::lock_guard lock(impl_->mutex);
  Voice* voice = impl_->find(id);
  if (voice == nullptr) {
    auto free = std::find_if(impl_->voices.begin(), impl_->voices.end(),
                             [](const Voice& v) { return !v.used; });
    if (free == impl_->voices.end()) {
      throw Error("SpatialMixer: cannot place voice " + std::to_string(id) + ": all " +
                  std::to_string(impl_->config.max_sources) + " sources are in use");
    }
    voice = &*free;
    voice->used = true;
    voice->id = id;
  }
  const ContextScope scope(impl_->context);
  alSource3f(voice->source, AL_POSITION, room_position.x(), room_position.y(), room_position.z());
  alSourcef(voice->source, AL_GAIN, std::max(gain, 0.0f));
}

void SpatialMixer::remove_source(uint32_t id) {
  const std::lock_guard lock(impl_->mutex);
  Voice* voice = impl_->find(id);
  if (voice == nullptr) return;
  const ContextScope scope(impl_->context);
  impl_->reset(*voice);
  voice->used = false;
}

void SpatialMixer::push(uint32_t id, std::span<const float, kFrameSamples> mono) {
  const std::lock_guard lock(impl_->mutex);
  Voice* voice = impl_->find(id);
  if (voice == nullptr) {
    throw Error("SpatialMixer: push for voice " + std::to_string(id) +
                ", which set_source() has not placed");
  }
  if (voice->pending_count > 0 && voice->in_al + voice->pending_count >= kMaxQueuedFrames) {
    voice->pending_head = (voice->pending_head + 1) % kMaxQueuedFrames;  // drop the oldest
    --voice->pending_count;
  }
  const int slot = (voice->pending_head + voice->pending_count) % kMaxQueuedFrames;
  std::copy(mono.begin(), mono.end(),
            voice->pending.begin() +
                static_cast<std::ptrdiff_t>(slot) * static_cast<std::ptrdiff_t>(kFrameSamples));
  ++voice->pending_count;
}

void SpatialMixer::render(std::span<float, 2 * kFrameSamples> stereo_out) {
  const std::lock_guard lock(impl_->mutex);
  {
    const ContextScope scope(impl_->context);
    for (Voice& voice : impl_->voices) {
      if (voice.used) impl_->feed(voice);
    }
  }
  alcRenderSamplesSOFT(impl_->device, stereo_out.data(), static_cast<ALCsizei>(kFrameSamples));
}

bool SpatialMixer::hrtf() const {
  const std::lock_guard lock(impl_->mutex);
  ALCint enabled = ALC_FALSE;
  alcGetIntegerv(impl_->device, ALC_HRTF_SOFT, 1, &enabled);
  return enabled == ALC_TRUE;
}

std::string SpatialMixer::hrtf_name() const {
  const std::lock_guard lock(impl_->mutex);
  ALCint enabled = ALC_FALSE;
  alcGetIntegerv(impl_->device, ALC_HRTF_SOFT, 1, &enabled);
  if (enabled != ALC_TRUE) return "";
  const ALCchar* name = alcGetString(impl_->device, ALC_HRTF_SPECIFIER_SOFT);
  return name != nullptr ? name : "";
}

std::string SpatialMixer::hrtf_status() const {
  const std::lock_guard lock(impl_->mutex);
  ALCint status = 0;
  alcGetIntegerv(impl_->device, ALC_HRTF_STATUS_SOFT, 1, &status);
  return status_words(status);
}

}  // namespace volcast::audio
