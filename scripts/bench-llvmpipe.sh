#!/usr/bin/env bash
# shadetrace against Mesa's llvmpipe rendering the same stereo frame (1280x1440 per eye,
# 2048² shadow map, Lambert + Phong + 5x5 PCF + trilinear albedo), back to back at 1 and 2
# threads: ms per frame of forward, tile-pair and amfs beside llvmpipe's frame_ms (bench.py,
# median and min-max of its repetitions), and the ratios of the medians. shadetrace's ms are
# results.json's timing.wall_s, median and min-max of REPS runs: of one replayed frame
# ("1 frame"), and per frame of a replay of the trace's 3 frames ("of 3"), the steady state
# that llvmpipe's own repeated frames measure (a still scene's shadow map rendered once, and
# at 2 threads two frames in flight). The kit (bench.py, cam.py) is
# ../shared/anchors/llvmpipe/ beside the repository, or $LLVMPIPE_KIT.
# Usage: [SHADETRACE_BIN=path] scripts/bench-llvmpipe.sh [--reps N] SCENE.glb...
# (single-file GLB works best)
set -euo pipefail
cd "$(dirname "$0")/.."
reps=3
if [ "${1:-}" = "--reps" ]; then reps=$2; shift 2; fi
[ $# -gt 0 ] || { echo "usage: scripts/bench-llvmpipe.sh [--reps N] SCENE.glb..." >&2; exit 2; }
kit=${LLVMPIPE_KIT:-../shared/anchors/llvmpipe}
[ -f "$kit/bench.py" ] || { echo "$kit/bench.py not found (set LLVMPIPE_KIT)" >&2; exit 2; }
kit=$(realpath "$kit")
# What the kit needs: Debian's Mesa (root only) and PyPI's moderngl.
if ! python3 -c "import moderngl, numpy" 2>/dev/null; then
  if [ "$(id -u)" = 0 ]; then apt-get install -y -q libgl1-mesa-dri libegl1 libegl-mesa0 >/dev/null; fi
  pip install -q moderngl glcontext numpy trimesh
fi
# SHADETRACE_BIN measures another build (e.g. a before/after pair) against the same anchor.
if [ -z "${SHADETRACE_BIN:-}" ]; then cargo build --release --quiet; fi
bin=$(realpath "${SHADETRACE_BIN:-target/release/shadetrace}")
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
# "median min max" of numbers, one per line.
spread() { sort -n | awk '{a[NR]=$1} END {print a[int((NR+1)/2)], a[1], a[NR]}'; }
printf '%-18s %7s %-10s %18s %18s %18s %7s %7s\n' scene threads preset "st 1 frame ms" "st ms of 3" \
  "llvmpipe ms" ratio "of 3"
for scene in "$@"; do
  scene=$(realpath "$scene")
  name=$(basename "$scene" | sed 's/\.[^.]*$//')
  flags=$(cd "$work" && python3 "$kit/cam.py" "$scene" | python3 -c "import json,sys; print(json.load(sys.stdin)['capture_flags'])")
  (cd "$work" && "$bin" capture "$scene" -o "$name.strace" --frames 3 $flags --quiet)
  for threads in 1 2; do
    python3 "$kit/bench.py" "$scene" --threads "$threads" --shaders full --reps "$reps" --frames 10 --warmup 2 \
      --json "$work/lp.json" >"$work/lp.log" 2>&1 || { cat "$work/lp.log" >&2; exit 1; }
    read -r lp lp_min lp_max < <(python3 -c "import json; s = json.load(open('$work/lp.json'))['summary'][0]
print(s['frame_ms'], s['frame_ms_min'], s['frame_ms_max'])")
    for preset in forward tile-pair amfs; do
      # "median min max" ms per frame of REPS replays of frames $1 ($2 of them).
      timed() {
        for _ in $(seq "$reps"); do
          RAYON_NUM_THREADS=$threads "$bin" replay "$work/$name.strace" --preset "$preset" --frames "$1" --no-images \
            --no-reference -q --out "$work/out"
          python3 -c "import json; print(1e3 * json.load(open('$work/out/results.json'))['timing']['wall_s'] / $2)"
        done | spread
      }
      read -r ms ms_min ms_max < <(timed 0 1)
      read -r steady steady_min steady_max < <(timed 0..3 3)
      printf '%-18s %7s %-10s %6.0f (%4.0f-%4.0f) %6.0f (%4.0f-%4.0f) %6.0f (%4.0f-%4.0f) %7.2f %7.2f\n' \
        "$name" "$threads" "$preset" "$ms" "$ms_min" "$ms_max" "$steady" "$steady_min" "$steady_max" \
        "$lp" "$lp_min" "$lp_max" "$(echo "$ms / $lp" | bc -l)" "$(echo "$steady / $lp" | bc -l)"
    done
  done
done
