#pragma once
// The shared real data (../shared/data beside the repository), from one source that
// bench/CMakeLists.txt generates: no other compile names the clone's folder (ccache shares them).
namespace volcast::bench {
const char* data_dir();
}  // namespace volcast::bench
