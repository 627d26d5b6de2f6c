# volcast_codec must neither link nor include FFmpeg (it is to be built to WASM). Run by ctest:
#   cmake -DPURE=<exe linked against volcast_codec + volcast_core only>
#         -DVIDEO=<exe linked against volcast_codec_video> -DSOURCES=<src/codec> -P this file
# PURE must need no libav*/libsw* shared library; VIDEO must (so the check can see FFmpeg at all).
# (Debian's GCC links --as-needed except under sanitizers, so in release builds this catches
# FFmpeg symbols used by volcast_codec; tests/CMakeLists.txt checks its link line at configure
# time, and the include scan below catches FFmpeg headers.)
foreach(var PURE VIDEO SOURCES)
  if(NOT ${var})
    message(FATAL_ERROR "check_codec_pure: -D${var}=... is required")
  endif()
endforeach()

function(needed_libraries exe out)
  execute_process(COMMAND readelf -d "${exe}" OUTPUT_VARIABLE dynamic RESULT_VARIABLE rc)
  if(NOT rc EQUAL 0)
    message(FATAL_ERROR "check_codec_pure: readelf -d ${exe} failed")
  endif()
  string(REGEX MATCHALL "Shared library: \\[[^]]+\\]" needed "${dynamic}")
  set(${out} "${needed}" PARENT_SCOPE)
endfunction()

needed_libraries("${VIDEO}" video_needed)
if(NOT video_needed MATCHES "libavcodec")
  message(FATAL_ERROR "check_codec_pure: ${VIDEO} does not need libavcodec, so this check cannot "
                      "tell whether volcast_codec does (linker drops unused libraries?)")
endif()
needed_libraries("${PURE}" pure_needed)
if(pure_needed MATCHES "lib(avcodec|avformat|avutil|swscale|swresample)")
  message(FATAL_ERROR "check_codec_pure: volcast_codec links FFmpeg: ${pure_needed}")
endif()

file(GLOB_RECURSE sources "${SOURCES}/*.cpp" "${SOURCES}/*.hpp" "${SOURCES}/*.h")
foreach(f ${sources})
  file(STRINGS "${f}" includes REGEX "^[ \t]*#[ \t]*include[ \t]*[<\"](libav|libsw|libpostproc)")
  if(includes)
    message(FATAL_ERROR "check_codec_pure: ${f} includes FFmpeg: ${includes}")
  endif()
endforeach()
message(STATUS "volcast_codec links and includes no FFmpeg (${pure_needed})")
