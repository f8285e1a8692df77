#!/usr/bin/env bash
# Renders the README's pictures of the default body with `mimic view --screenshot` (offscreen,
# no display needed) into docs/images/. Run after building; the BVH frame needs ../shared/data.
set -euo pipefail
cd "$(dirname "$0")/.."
mimic=${MIMIC_BIN:-build/bin/mimic}
out=docs/images
data=${MIMIC_SHARED_DATA:-../shared/data}
mkdir -p "$out"
shot() { local name=$1; shift; "$mimic" view --screenshot "$out/$name.png" "$@" >/dev/null; echo "wrote $out/$name.png"; }

# The first picture: the body mid-stride.
shot hero --motion walk --time 0.4 --camera three-quarter --size 420x480 --lod 0
# Poses: the relaxed posture, the walk in profile (cameras turn with the avatar), an arm raised.
shot pose-rest --pose rest --size 240x300 --lod 0
shot pose-walk --motion walk --time 0.9 --camera left --size 240x300 --lod 0
shot pose-wave --pose rest --set l_shoulder_abduction=1.2,l_elbow_flexion=1.3 --size 240x300 --lod 0
[ -f "$data/bvh/07_01.bvh" ] && shot pose-bvh --bvh "$data/bvh/07_01.bvh" --frame 120 --camera three-quarter --size 240x300
# The built-in body beside the MakeHuman base mesh it is measured against (grey), front and side.
if [ -f "$data/mesh/makehuman_base_body.obj" ]; then
  for camera in front left; do
    shot "compare-$camera" --pose rest --compare-obj "$data/mesh/makehuman_base_body.obj" --camera "$camera" --size 420x360 --lod 0
  done
fi
# The five scaling presets (mimic scale --preset), framed at one scale so their sizes compare.
presets=$(mktemp -d)
for preset in child adult_female adult_male tall heavy; do
  "$mimic" scale --preset "$preset" --out "$presets/$preset.json" 2>/dev/null
  shot "preset-$preset" --body "$presets/$preset.json" --pose rest --frame-height 1.5 --size 200x300 --lod 0
done
rm -rf "$presets"
# Levels of detail, with the contour rings drawn so the sampling shows.
for lod in 0 1 2 3; do
  shot lod$lod --pose rest --lod $lod --overlay contours --camera three-quarter --size 240x300
done
# The method: skeleton and primitives (muscles by f(t)) inside the translucent body; the rays
# cast for one ring; the contours.
shot method-primitives --pose rest --set l_elbow_flexion=1.8 --overlay skeleton,primitives --see-through --camera three-quarter --size 300x340
shot method-contours --pose rest --overlay contours --lod 2 --camera front --size 300x340
shot method-rays --pose rest --overlay rays --ray-ring 5 --see-through --camera three-quarter --size 300x340
# The shared scene: two tracked participants and three actors in one `mimic run`, watched by
# `mimic view --connect` in a window on a virtual display.
if command -v xvfb-run >/dev/null; then
  log=$(mktemp)
  "$mimic" run --listen 127.0.0.1:0 --source sim:walk --source 'sim:idle?seed=2' --source 'actor:wander?seed=3' \
    --source 'actor:follow?target=3' --source 'actor:greet?seed=5' --duration 25 --quiet >"$log" 2>/dev/null &
  run_pid=$!
  for _ in $(seq 50); do grep -q '^serving on ' "$log" && break; sleep 0.1; done
  endpoint=$(sed -n 's/^serving on //p' "$log" | head -1)
  sleep 8  # let the actors walk off
  xvfb-run -a -s "-screen 0 1024x768x24" "$mimic" view --connect "$endpoint" --frames 30 --no-vsync --no-panel \
    --size 640x360 --capture "$out/scene.png" >/dev/null
  kill "$run_pid" 2>/dev/null || true
  wait "$run_pid" 2>/dev/null || true
  rm -f "$log"
  echo "wrote $out/scene.png"
fi
# A VR headset's three poses: the simulated wearer's head and hands drive the body and its legs
# step (docs/solver.md), the sensors drawn with their axes.
if command -v xvfb-run >/dev/null; then
  xvfb-run -a -s "-screen 0 1024x768x24" "$mimic" view --source 'sim:walk?sensors=3' --overlay sensors --lod 0 --frames 150 \
    --no-vsync --no-panel --size 420x480 --capture "$out/walk-3-sensors.png" >/dev/null
  echo "wrote $out/walk-3-sensors.png"
  # … and running: both feet in the air between two stances.
  xvfb-run -a -s "-screen 0 1024x768x24" "$mimic" view --source 'sim:run?sensors=3' --overlay sensors --lod 0 --frames 190 \
    --no-vsync --no-panel --size 420x480 --camera left --capture "$out/run-3-sensors.png" >/dev/null
  echo "wrote $out/run-3-sensors.png"
fi
# The browser viewer (docs/browser.md): its end-to-end test saves the page as headless Chromium drew it.
if [ -x "$(dirname "$mimic")/mimic_web_tests" ] && command -v chromium >/dev/null; then
  MIMIC_BROWSER_SCREENSHOT="$out/browser.png" "$(dirname "$mimic")/mimic_web_tests" --gtest_filter='BrowserViewer.ShowsTheAvatarMoving*' >/dev/null &&
    echo "wrote $out/browser.png"
fi
du -ch "$out"/*.png | tail -1
