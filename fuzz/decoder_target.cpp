// Which decoder a fuzz_<kind>_<codec> target fuzzes: its VOLCAST_FUZZ_KIND (depth, color or
// protocol) and VOLCAST_FUZZ_CODEC (the codec name), set per target in fuzz/CMakeLists.txt. The
// fuzzer itself (decoder_fuzzer.cpp) is compiled once for all of them.
#include "decoder_target.hpp"

namespace volcast::fuzz {

const char* const kKind = VOLCAST_FUZZ_KIND;
const char* const kCodec = VOLCAST_FUZZ_CODEC;

}  // namespace volcast::fuzz
