#!/usr/bin/env bash
# Installs Volcast's build and run dependencies from Debian 12 packages, only those missing.
set -euo pipefail
packages=(
  build-essential cmake ninja-build pkg-config
  libgtest-dev libgmock-dev libbenchmark-dev
  libeigen3-dev libspdlog-dev libcli11-dev nlohmann-json3-dev libasio-dev libssl-dev
  libavformat-dev libavcodec-dev libavutil-dev libswscale-dev libavfilter-dev libturbojpeg0-dev libpng-dev zlib1g-dev
  libzstd-dev liblz4-dev
  libepoxy-dev libegl-dev libegl-mesa0 libgl1-mesa-dri
  libglfw3-dev libxrandr-dev libimgui-dev libopenxr-dev xvfb xauth
  libopen3d-dev libnanoflann-dev
  clang-14 libclang-rt-14-dev lld ccache stress-ng
  libwebsocketpp-dev emscripten chromium nodejs
  libassimp-dev libvtk9-dev libdcmtk-dev libmatroska-dev
  libnats-dev nats-server
  libicu-dev
  libopus-dev libspeexdsp-dev libopenal-dev libopenal-data libwebrtc-audio-processing-dev
  libsndfile1-dev portaudio19-dev espeak-ng sox
)
missing=()
for p in "${packages[@]}"; do
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
done
if ((${#missing[@]})); then
  echo "install-deps: installing ${missing[*]}"
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  "${sudo_cmd[@]}" apt-get update -qq
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends "${missing[@]}"
else
  echo "install-deps: all packages present"
fi
# npm for the browser tests' packages (web/test): Debian's, unless a Node.js that brings its own
# npm is installed already.
if ! command -v npm > /dev/null; then
  sudo_cmd=()
  [ "$(id -u)" -eq 0 ] || sudo_cmd=(sudo)
  DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -qq --no-install-recommends npm
fi
