#!/usr/bin/env bash
# The compiler launcher of both presets when ccache is installed (CMakeLists.txt, VOLCAST_CCACHE):
#   cmake/ccache_launcher.sh COMPILER ARGS...
# Runs the compile through ccache, set up so that a clone in another folder (CI's clean clone)
# hits what a build in this one compiled: paths under the source tree are hashed relative to the
# build folder (base_dir), the build folder's own path is not hashed.
#
# A precompiled header holds the absolute paths of the clone that compiled it, so its bytes differ
# from clone to clone, and every source that uses it would miss. So a precompiled header is
# compiled here and <header>.sum written beside it: its compile's arguments with this clone's
# folder taken out, and the content of every file it read (its depfile). ccache hashes the .sum
# in place of the header for each source that uses it (pch_external_checksum).
set -euo pipefail
src="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
export CCACHE_BASEDIR="$src" CCACHE_NOHASHDIR=1 CCACHE_PCH_EXTSUM=1
export CCACHE_SLOPPINESS=pch_defines,time_macros,include_file_mtime,include_file_ctime

out="" depfile="" pch=0 prev=""
for arg in "$@"; do
  case "$prev" in
    -o) out="$arg" ;;
    -MF) depfile="$arg" ;;
  esac
  case "$arg" in
    -emit-pch) pch=1 ;;                          # Clang (CMake passes -Xclang -emit-pch)
    c++-header) [ "$prev" = -x ] && pch=1 ;;     # GCC (-x c++-header)
  esac
  prev="$arg"
done
if [ "$pch" = 0 ] || [ -z "$out" ] || [ -z "$depfile" ]; then
  exec ccache "$@"
fi

rm -f "$out.sum"
ccache "$@"
{
  printf '%s\n' "${@//"$src"/@}"
  "$1" --version
  # The depfile: "target: dep dep \" lines; each file it read, in order, by content.
  sed -e 's/^[^:]*: *//' -e 's/\\$//' "$depfile" | tr -s ' \t' '\n\n' | sed '/^$/d' |
    while IFS= read -r dep; do
      printf '%s\n' "${dep//"$src"/@}"
      cat -- "$dep"
    done
} | sha256sum > "$out.sum.tmp"
mv "$out.sum.tmp" "$out.sum"
