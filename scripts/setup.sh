#!/usr/bin/env bash
# Installs every Debian package Mimic needs to build, test and run. This file is the one place
# the dependency list lives. Idempotent and non-interactive; run as root (or with sudo).
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git
  libglm-dev                       # math
  libboost-dev libboost-system-dev # Asio: serial ports and networking
  libexpected-dev                  # Result<T> = tl::expected
  nlohmann-json3-dev               # body model / calibration files
  libhidapi-dev libusb-1.0-0-dev   # USB devices
  libglfw3-dev libgl-dev           # viewer: window and input, OpenGL
  libegl-dev libegl-mesa0 libglx-mesa0 libgl1-mesa-dri  # viewer: offscreen rendering (EGL
                                   # surfaceless) and windows, both on Mesa llvmpipe
  libimgui-dev libpng-dev          # viewer: overlays and panels (Dear ImGui), screenshots (PNG)
  libgtest-dev libgmock-dev googletest libbenchmark-dev
  xvfb liblo-tools                 # viewer under a virtual display; OSC peer for interop tests
  clang libclang-rt-14-dev         # the second compiler CI builds with; libFuzzer and sanitizers
  libnats-dev nats-server          # broker transport (mimic run --nats, mimic relay); tests start brokers
  libcli11-dev zlib1g-dev          # command-line parsing and usage text; CRC-32
  libcgal-dev                      # exact self-intersection of the skin (mimic intersect, tests only)
  universal-ctags clang-format     # the size rules (scripts/check_structure.sh) and the tree's format
  nodejs npm                       # tests load the glTF/VRM exports with third-party readers
  emscripten                       # the browser viewer's skin: the C++ realtime skin as WebAssembly
  chromium                         # the browser viewer's tests: the page in headless Chromium
)

# Those readers come from npm (scripts/node_tools.sh, pinned; into build/node where the tests
# look). Optional: without the registry the tests that need them skip and say why.
node_tools() {
  if [ "${MIMIC_SKIP_NODE_TOOLS:-0}" != 1 ] && command -v npm >/dev/null; then
    scripts/node_tools.sh build/node || echo "setup: npm packages not installed (the VRM/validator tests will skip)"
  fi
}
cd "$(dirname "$0")/.."

missing=()
for p in "${packages[@]}"; do
  # A Node.js from outside Debian (NodeSource's, as some machine images carry) bundles its own
  # npm, and Debian's npm package cannot be installed beside it: a working npm is enough.
  if [ "$p" = npm ] && command -v npm >/dev/null; then continue; fi
  dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q 'install ok installed' || missing+=("$p")
done
if [ ${#missing[@]} -eq 0 ]; then
  echo "setup: all ${#packages[@]} packages present"
  node_tools
  exit 0
fi
SUDO=""
[ "$(id -u)" -eq 0 ] || SUDO="sudo"
echo "setup: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${missing[@]}"
node_tools
