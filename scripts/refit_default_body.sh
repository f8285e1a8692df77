#!/usr/bin/env bash
# Regenerates the built-in body's table of fitted overrides (avatar/src/default_body_fit.cpp):
# the authored body (avatar/src/default_body.cpp) fitted to the MakeHuman base mesh in
# ../shared/data/mesh with its rigid parts (head, hands, feet) held as authored. Run it after
# changing the authored body, then rebuild and update the figures that move (docs/fit.md).
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --build build --target mimic
build/bin/mimic fit --emit-default avatar/src/default_body_fit.cpp --samples 22000 --iterations 40 \
  --hold neck_base,neck_mid,neck_top,l_trapezius,l_clavicle_ridge,upper_chest,upper_back,l_hip_side \
  --out build/default_body_fitted.json
clang-format -i avatar/src/default_body_fit.cpp
cmake --build build --target mimic
build/bin/mimic compare
