#!/usr/bin/env bash
# Regenerates the built-in body's table of fitted overrides (avatar/src/default_body_fit.cpp):
# the authored body (avatar/src/default_body.cpp) fitted to the MakeHuman base mesh in
# ../shared/data/mesh with its rigid parts (head, hands, feet) held as authored, both sides fitted
# as mirror images, the tape girths held with the surface (twice the default weight). The refit starts
# from the built-in body as it stands (the authored body with the table before, its skeleton
# already fitted): it refines the table rather than fitting anew, so the figures other tests
# hold on the body (fold counts, sections) move only as far as the fit moves it. Besides the rigid
# parts it holds the neck's and shoulder girdle's primitives and the hips' sides (fitted, they
# made junction rings zigzag) and the upper arm's muscles and the shoulder's cap (refitted, they
# made the realtime skin fold more at the shoulder's limits), docs/fit.md. Run it after changing
# the authored body, then rebuild and update the figures that move (docs/fit.md).
set -euo pipefail
cd "$(dirname "$0")/.."
cmake --build build --target mimic
build/bin/mimic fit --emit-default avatar/src/default_body_fit.cpp --from-built-in --no-skeleton \
  --samples 22000 --iterations 40 --girth-weight 0.1 \
  --hold neck_base,neck_mid,neck_top,l_trapezius,l_clavicle_ridge,upper_chest,upper_back,l_hip_side,l_biceps,l_triceps,l_shoulder_cap,l_deltoid,l_lat_lower \
  --out build/default_body_fitted.json
clang-format -i avatar/src/default_body_fit.cpp
cmake --build build --target mimic
build/bin/mimic compare
