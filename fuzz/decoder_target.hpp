#pragma once
// The decoder a decoder_fuzzer.cpp target fuzzes (decoder_target.cpp, one per target).

namespace volcast::fuzz {

extern const char* const kKind;   ///< "depth", "color" or "protocol"
extern const char* const kCodec;  ///< a codec name of that kind's table ("messages": protocol)

}  // namespace volcast::fuzz
