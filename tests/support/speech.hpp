#pragma once
// Measuring speech that went through a voice path, for tests: real recorded voices (shared
// data, speech/), where one signal sits in another (cross-correlation), how alike they are
// (normalised cross-correlation), energies and level ratios.
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <fstream>
#include <span>
#include <string>
#include <vector>

#include "support/test_data.hpp"
#include "volcast/audio/voice_format.hpp"
#include "volcast/audio/wav.hpp"

namespace volcast::test {

/// A real recorded voice: shared data speech/<name>.wav (48 kHz mono).
inline std::vector<float> speech(const std::string& name) {
  return audio::read_voice(data_dir() / "speech" / (name + ".wav"));
}

/// Phrases one after another, each after `gap_s` of silence; `starts` gets each phrase's first
/// sample.
inline std::vector<float> phrases(const std::vector<std::string>& names, double gap_s,
                                  std::vector<size_t>* starts = nullptr) {
  std::vector<float> out;
  for (const std::string& n : names) {
    out.resize(out.size() + static_cast<size_t>(gap_s * audio::kSampleRate), 0.0f);
    if (starts) starts->push_back(out.size());
    const std::vector<float> s = speech(n);
    out.insert(out.end(), s.begin(), s.end());
  }
  out.resize(out.size() + static_cast<size_t>(gap_s * audio::kSampleRate), 0.0f);
  return out;
}

/// Writes mono 48 kHz `samples` to `path` (a microphone file).
inline std::filesystem::path write_voice(const std::filesystem::path& path,
                                         const std::vector<float>& samples) {
  audio::Pcm pcm;
  pcm.samples = samples;
  audio::write_wav(path, pcm);
  return path;
}

/// Channel `channel` of interleaved `pcm`.
inline std::vector<float> channel(const audio::Pcm& pcm, int channel) {
  std::vector<float> out(pcm.frames());
  for (size_t i = 0; i < out.size(); ++i)
    out[i] = pcm.samples[i * size_t(pcm.channels) + size_t(channel)];
  return out;
}

/// Normalised cross-correlation of `a` with `b` starting at b[offset] (over a's length, or
/// what of b there is).
inline double ncc(std::span<const float> a, std::span<const float> b, std::ptrdiff_t offset) {
  double ab = 0, aa = 0, bb = 0;
  for (size_t i = 0; i < a.size(); ++i) {
    const std::ptrdiff_t j = offset + std::ptrdiff_t(i);
    if (j < 0 || j >= std::ptrdiff_t(b.size())) continue;
    ab += double(a[i]) * b[size_t(j)];
    aa += double(a[i]) * a[i];
    bb += double(b[size_t(j)]) * b[size_t(j)];
  }
  return aa > 0 && bb > 0 ? ab / std::sqrt(aa * bb) : 0;
}

struct Alignment {
  std::ptrdiff_t offset = 0;  ///< where `a` begins in `b` (samples)
  double correlation = 0;     ///< normalised, at that offset
};

/// `x` summed over runs of 12 samples: 4 kHz, the band below about 2 kHz (telephone speech).
inline std::vector<float> decimate(std::span<const float> x) {
  std::vector<float> out(x.size() / 12);
  for (size_t i = 0; i < out.size(); ++i) {
    float s = 0;
    for (size_t k = 0; k < 12; ++k) s += x[i * 12 + k];
    out[i] = s;
  }
  return out;
}

/// Where `a` sits best in `b` within offsets [from, to], compared below about 2 kHz (decimate):
/// what stays of speech through processing that reshapes its upper bands (an echo canceller's
/// band split and noise suppressor).
inline Alignment align_band(std::span<const float> a, std::span<const float> b, std::ptrdiff_t from,
                            std::ptrdiff_t to) {
  const std::vector<float> da = decimate(a), db = decimate(b);
  Alignment best{from, -2};
  for (std::ptrdiff_t o = from / 12; o <= to / 12; ++o)
    if (const double c = ncc(da, db, o); c > best.correlation) best = {o * 12, c};
  return best;
}

/// Where `a` sits best in `b` within offsets [from, to]: align_band's coarse search, then every
/// sample around the best.
inline Alignment align(std::span<const float> a, std::span<const float> b, std::ptrdiff_t from,
                       std::ptrdiff_t to) {
  const Alignment coarse = align_band(a, b, from, to);
  Alignment best{coarse.offset, -2};
  for (std::ptrdiff_t o = coarse.offset - 24; o <= coarse.offset + 24; ++o)
    if (const double c = ncc(a, b, o); c > best.correlation) best = {o, c};
  return best;
}

/// `a`'s words: the runs of sound between silences of at least `gap` samples (20 ms windows
/// under 1 % of the phrase's peak RMS), as [begin, end) sample ranges.
inline std::vector<std::pair<size_t, size_t>> words(std::span<const float> a, size_t gap = 4800) {
  constexpr size_t w = 960;
  std::vector<double> rms;
  double peak = 0;
  for (size_t i = 0; i + w <= a.size(); i += w) {
    double e = 0;
    for (size_t k = 0; k < w; ++k) e += double(a[i + k]) * a[i + k];
    rms.push_back(std::sqrt(e / w));
    peak = std::max(peak, rms.back());
  }
  std::vector<std::pair<size_t, size_t>> out;
  size_t quiet = 0;
  for (size_t j = 0; j < rms.size(); ++j) {
    if (rms[j] < 0.01 * peak) {
      ++quiet;
      continue;
    }
    if (out.empty() || quiet * w >= gap)
      out.push_back({j * w, (j + 1) * w});
    else
      out.back().second = (j + 1) * w;
    quiet = 0;
  }
  return out;
}

/// How much of `a` came through in `b` where the path may have paused it: `a` cut into pieces
/// of `piece` samples (100 ms), each aligned on its own within ±`slack` samples (225 ms: the
/// longest pause a playout buffer inserts when it resumes a stall, 200 ms, and a frame) of where
/// the piece before it was found (the first: of `offset`), their correlations averaged weighted by
/// the pieces' energy (pieces under 1 % of the mean energy, silence, are left out). A playout
/// buffer that lets a stalled stream resume (a pause inside a word, the rest shifted) keeps this
/// high; one that conceals what came late lowers it.
inline double resumed_correlation(std::span<const float> a, std::span<const float> b,
                                  std::ptrdiff_t offset, size_t piece = 4800,
                                  std::ptrdiff_t slack = 10800) {
  double mean_energy = 0;
  for (const float x : a) mean_energy += double(x) * x;
  mean_energy /= double(std::max<size_t>(a.size(), 1));
  double sum = 0, weight = 0;
  std::ptrdiff_t shift = 0;  // where the last piece was found, relative to where it was said
  for (size_t at = 0; at + piece <= a.size(); at += piece) {
    const std::span<const float> p = a.subspan(at, piece);
    double e = 0;
    for (const float x : p) e += double(x) * x;
    e /= double(piece);
    if (e < 0.01 * mean_energy) continue;
    const std::ptrdiff_t expected = offset + std::ptrdiff_t(at) + shift;
    const Alignment found = align(p, b, expected - slack, expected + slack);
    shift = found.offset - offset - std::ptrdiff_t(at);
    sum += e * found.correlation;
    weight += e;
  }
  return weight > 0 ? sum / weight : 0;
}

/// How well `phrase` came through a live voice path into `heard`, found within offsets
/// [from, to]: as a whole (align), and in pieces of 100 ms (resumed_correlation from where the
/// whole was found). A loaded machine may stall the path: the playout buffer then resumes the
/// stream where it stopped, a pause inside the phrase that shifts the rest of it, and the whole
/// matches less while each piece still matches. An echo canceller's band split shifts bands of
/// different pitch by up to a millisecond against each other, which the pieces allow for too.
struct Hearing {
  Alignment whole;
  double resumed = 0;
  /// What a test holds to a bound: the better of the two.
  double correlation() const { return std::max(whole.correlation, resumed); }
};

inline Hearing hear(std::span<const float> phrase, std::span<const float> heard,
                    std::ptrdiff_t from, std::ptrdiff_t to) {
  Hearing h;
  h.whole = align(phrase, heard, from, to);
  h.resumed = resumed_correlation(phrase, heard, h.whole.offset);
  return h;
}

/// What a listener's loudspeaker played of one speaker, put back on the speaker's time line by
/// its played log (voice::VoiceConfig::played_log): `samples` n x 960 on are what it played of the
/// speaker's frame n (its microphone's samples n x 960 on), from its packet, FEC or concealment;
/// zeros where it played none of it (silence, and the pauses a playout buffer inserts when a
/// stalled path resumes). `from_packet[n]`: frame n was played from its own packet or from FEC,
/// not concealed. However a loaded machine or a path delayed and paused the voice, a phrase said
/// at microphone sample m lands at m here, give or take the codec's delay: nothing is searched.
struct AsSaid {
  std::vector<float> samples;
  std::vector<uint8_t> from_packet;
};

/// AsSaid from `heard` (the loudspeaker's mono samples) and the played log, for `speaker`'s id.
inline AsSaid heard_as_said(std::span<const float> heard, const std::filesystem::path& played_log,
                            uint32_t speaker) {
  constexpr size_t n = audio::kFrameSamples;
  AsSaid out;
  std::ifstream in(played_log);
  unsigned long long block = 0;
  uint32_t id = 0, frame = 0;
  char how = 0;
  while (in >> block >> id >> how >> frame) {
    if (id != speaker || how == 's' || (block + 1) * n > heard.size()) continue;
    if (out.from_packet.size() <= frame) {
      out.samples.resize((size_t(frame) + 1) * n, 0.0f);
      out.from_packet.resize(size_t(frame) + 1, 0);
    }
    std::copy_n(heard.begin() + std::ptrdiff_t(block * n), n,
                out.samples.begin() + std::ptrdiff_t(size_t(frame) * n));
    out.from_packet[frame] = how == 'p' || how == 'f';
  }
  return out;
}

/// AsSaid from what a browser page played (`heard`: a channel of its heard.wav, or both mixed) and
/// its played log (drive.mjs's heard_played.tsv, voice.js Voice.heardLog: per 128-sample quantum
/// a speaker played audio in, the quantum's first sample in `heard`, the speaker's id, and the
/// speaker's sample there), for `speaker`'s id. The page conceals nothing: `from_packet` marks
/// the speaker's frames it played audio of, a frame it never had stays silent and counted out.
inline AsSaid page_heard_as_said(std::span<const float> heard,
                                 const std::filesystem::path& played_log, uint32_t speaker) {
  constexpr size_t quantum = 128, n = audio::kFrameSamples;
  AsSaid out;
  std::ifstream in(played_log);
  long long at = 0, sample = 0;
  uint32_t id = 0;
  while (in >> at >> id >> sample) {
    if (id != speaker || at < 0 || sample < 0 || size_t(at) + quantum > heard.size()) continue;
    const size_t end = size_t(sample) + quantum, frames = (end + n - 1) / n;
    if (out.samples.size() < frames * n) out.samples.resize(frames * n, 0.0f);
    if (out.from_packet.size() < frames) out.from_packet.resize(frames, 0);
    std::copy_n(heard.begin() + at, quantum, out.samples.begin() + sample);
    for (size_t f = size_t(sample) / n; f < frames; ++f) out.from_packet[f] = 1;
  }
  return out;
}

/// The mouth-to-ear latency, in ms, at which a listener played each of `speaker`'s frames from
/// its packet or FEC, by its played log: the frame's block on the loudspeaker file's time line
/// minus where the frame was said (`mic_start_us`: the speaker's first sample on that time line,
/// µs). Index: frame number; NaN where a frame was not played from a packet.
inline std::vector<double> played_latencies_ms(const std::filesystem::path& played_log,
                                               uint32_t speaker, int64_t mic_start_us) {
  constexpr double frame_ms = 1000.0 * double(audio::kFrameSamples) / audio::kSampleRate;
  std::vector<double> out;
  std::ifstream in(played_log);
  unsigned long long block = 0;
  uint32_t id = 0, frame = 0;
  char how = 0;
  while (in >> block >> id >> how >> frame) {
    if (id != speaker || (how != 'p' && how != 'f')) continue;
    if (out.size() <= frame) out.resize(size_t(frame) + 1, std::nan(""));
    out[frame] = (double(block) - double(frame)) * frame_ms - double(mic_start_us) / 1000.0;
  }
  return out;
}

/// How well `phrase`, said at microphone sample `said_at`, came through to `as_said`: placed
/// where it lands within 30 ms (the codec's and the resampler's delay), its correlation there over
/// the frames played from packets. A frame a loaded machine's late packet left to concealment is
/// counted out (`concealed`, in frames), not as a different sound: what was played from packets
/// must be what was said.
struct Heard {
  Alignment at;            ///< the whole phrase, concealment included
  double correlation = 0;  ///< over the frames played from packets
  size_t frames = 0;       ///< the phrase's frames played from packets
  size_t concealed = 0;    ///< the phrase's frames played otherwise (concealed or not at all)
};

/// `below_2khz`: placed and compared below about 2 kHz (align_band), for a path whose band split
/// (an echo canceller's) shifts bands of different pitch against each other.
inline Heard heard_where_said(std::span<const float> phrase, const AsSaid& as_said, size_t said_at,
                              bool below_2khz = false) {
  constexpr size_t n = audio::kFrameSamples;
  const auto at = std::ptrdiff_t(said_at);
  Heard h;
  h.at = below_2khz ? align_band(phrase, as_said.samples, at - 1440, at + 1440)
                    : align(phrase, as_said.samples, at - 1440, at + 1440);
  // Compared at `step` samples a value: 12 (decimate's runs) below 2 kHz.
  const size_t step = below_2khz ? 12 : 1;
  const std::vector<float> a =
      below_2khz ? decimate(phrase) : std::vector<float>(phrase.begin(), phrase.end());
  const std::vector<float> b = below_2khz ? decimate(as_said.samples) : std::vector<float>();
  const std::span<const float> heard = below_2khz ? std::span<const float>(b) : as_said.samples;
  const std::ptrdiff_t offset = h.at.offset / std::ptrdiff_t(step);
  double ab = 0, aa = 0, bb = 0;
  size_t last_frame = SIZE_MAX;
  for (size_t i = 0; i < a.size(); ++i) {
    const std::ptrdiff_t j = offset + std::ptrdiff_t(i);
    if (j < 0) continue;
    const size_t frame = size_t(j) * step / n;
    const bool played = frame < as_said.from_packet.size() && as_said.from_packet[frame] &&
                        size_t(j) < heard.size();
    if (frame != last_frame) {
      last_frame = frame;
      ++(played ? h.frames : h.concealed);
    }
    if (!played) continue;
    ab += double(a[i]) * heard[size_t(j)];
    aa += double(a[i]) * a[i];
    bb += double(heard[size_t(j)]) * heard[size_t(j)];
  }
  h.correlation = aa > 0 && bb > 0 ? ab / std::sqrt(aa * bb) : 0;
  return h;
}

/// Mean square of x[from, from + n).
inline double energy(std::span<const float> x, size_t from, size_t n) {
  double e = 0;
  size_t count = 0;
  for (size_t i = from; i < std::min(x.size(), from + n); ++i, ++count) e += double(x[i]) * x[i];
  return count ? e / double(count) : 0;
}

inline double db(double ratio) {
  return 10 * std::log10(std::max(ratio, 1e-20));
}

/// Interaural delay: the lag (samples, within ±max_lag) at which `right` best matches `left`;
/// positive when the right ear hears it later (the source is on the left).
inline int interaural_lag(std::span<const float> left, std::span<const float> right, size_t from,
                          size_t n, int max_lag = 48) {
  int best = 0;
  double best_c = -2;
  if (from >= left.size()) return 0;
  const std::span<const float> l = left.subspan(from, std::min(n, left.size() - from));
  for (int lag = -max_lag; lag <= max_lag; ++lag)
    if (const double c = ncc(l, right, std::ptrdiff_t(from) + lag); c > best_c) {
      best_c = c;
      best = lag;
    }
  return best;
}

}  // namespace volcast::test
