#pragma once
// Where the tests find the shared data and what the build made: absolute paths of this clone and
// build, compiled into one generated source (tests/CMakeLists.txt: volcast_test_paths), so that
// no other compile names the clone's folder and ccache shares the rest between clones.

namespace volcast::test::paths {

const char* data();       ///< the shared real data, ../shared/data beside the repository
const char* volcast();    ///< the volcast executable of this build
const char* mock_xr();    ///< the mock OpenXR runtime (a module the loader loads)
const char* fake_k4a();   ///< the stand-in libk4a over the real recording
const char* web_root();   ///< the browser viewer as `volcast serve --web` serves it
const char* web_tests();  ///< web/test: the Node drivers of the browser tests

}  // namespace volcast::test::paths
