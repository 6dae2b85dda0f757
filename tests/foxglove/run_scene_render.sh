#!/usr/bin/env bash
# ctest driver of foxglove.scene_render: extract scene frames from the recorded session with the
# MCAP project's reader (js/extract_frames.mjs), then draw and check them with matplotlib
# (render_scene.py). Each step has its own time limit and says which step failed, so a step
# that hangs is named in the test output instead of the whole test timing out silently (one CI
# run on a fresh machine timed out at ctest's 300 s with no output). matplotlib's config and
# font cache go into the build tree, so a fresh machine does not depend on a writable $HOME.
# Usage: run_scene_render.sh SRC_DIR NODE_DIR SESSION_MCAP OUT_DIR
set -uo pipefail
src="$1"; node_dir="$2"; session="$3"; out="$4"
step_limit_s=120
mkdir -p "$out/mplconfig"
export MPLCONFIGDIR="$out/mplconfig"
run_step() {
  local name="$1"; shift
  local t0; t0=$(date +%s%N)
  timeout -k 5 "$step_limit_s" "$@"
  local rc=$?
  local dt_ms; dt_ms=$(( ($(date +%s%N) - t0) / 1000000 ))
  if [ "$rc" -eq 124 ] || [ "$rc" -eq 137 ]; then
    echo "FAIL: step '$name' did not finish within ${step_limit_s} s (killed, exit $rc)"
    exit 1
  fi
  echo "step '$name': exit $rc after ${dt_ms} ms"
  [ "$rc" -eq 0 ] || exit 1
}
[ -f "$session" ] || { echo "FAIL: no recorded session at $session"; exit 1; }
cd "$out"
run_step "extract frames (node)" node "$node_dir/extract_frames.mjs" "$session" frames.json 7
run_step "render and check (matplotlib)" /usr/bin/python3 -X faulthandler "$src/render_scene.py" \
    frames.json scene_frame.png
