#!/usr/bin/env bash
# Installs the third-party glTF/VRM readers some tests load Mimic's files with (npm, pinned):
# the Khronos glTF validator, three.js and @pixiv/three-vrm. Not a build dependency: without
# them those tests skip and say why. Default folder: build/node (where the tests look first;
# MIMIC_NODE_MODULES points elsewhere).
#   scripts/node_tools.sh [DIR]
set -euo pipefail
cd "$(dirname "$0")/.."
dir=${1:-build/node}
command -v npm >/dev/null || { echo "node_tools: npm not found (Debian: apt-get install nodejs npm)" >&2; exit 1; }
mkdir -p "$dir"
npm install --prefix "$dir" --no-audit --no-fund --no-save --loglevel=error \
  three@0.187.0 @pixiv/three-vrm@3.5.5 gltf-validator@2.0.0-dev.3.10
echo "node_tools: glTF validator, three.js and three-vrm in $dir/node_modules"
