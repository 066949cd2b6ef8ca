#!/usr/bin/env bash
# shadetrace against Mesa's llvmpipe rendering the same stereo frame (1280x1440 per eye,
# 2048² shadow map, Lambert + Phong + 5x5 PCF + trilinear albedo), back to back at 1 and 2
# threads: ms per frame of forward, tile-pair, amfs and he-2x2 (the presets the speed targets
# name; --presets to choose) beside llvmpipe's frame_ms (bench.py),
# median and min-max of REPS rounds, and the ratios. shadetrace's ms are results.json's
# timing.wall_s: of one replayed frame ("1 frame"), and per frame of a replay of the trace's
# 3 frames ("of 3"), the steady state that llvmpipe's own repeated frames measure (a still
# scene's shadow map rendered once, and at 2 threads two frames in flight). Each round runs
# llvmpipe and then every preset once, and a ratio is the median over rounds of that round's
# shadetrace ms over its llvmpipe ms: a machine that slows down between rounds slows both
# sides of a ratio alike. The kit (bench.py, cam.py) is ../shared/anchors/llvmpipe/ beside
# the repository, or $LLVMPIPE_KIT.
# Usage: [SHADETRACE_BIN=path] scripts/bench-llvmpipe.sh [--reps N] [--presets "P..."] SCENE.glb...
# (single-file GLB works best)
set -euo pipefail
cd "$(dirname "$0")/.."
reps=3
presets="forward tile-pair amfs he-2x2"
usage='usage: scripts/bench-llvmpipe.sh [--reps N] [--presets "P..."] SCENE.glb...'
while [ $# -gt 0 ]; do
  case $1 in
    --reps | --presets)
      [ $# -ge 2 ] || { echo "$1 needs a value; $usage" >&2; exit 2; }
      if [ "$1" = --reps ]; then reps=$2; else presets=$2; fi
      shift 2 ;;
    *) break ;;
  esac
done
[ $# -gt 0 ] || { echo "$usage" >&2; exit 2; }
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
printf '%-18s %7s %-10s %18s %18s %18s %7s %7s\n' scene threads preset "st 1 frame ms" "st ms of 3" \
  "llvmpipe ms" ratio "of 3"
for scene in "$@"; do
  scene=$(realpath "$scene")
  name=$(basename "$scene" | sed 's/\.[^.]*$//')
  flags=$(cd "$work" && python3 "$kit/cam.py" "$scene" | python3 -c "import json,sys; print(json.load(sys.stdin)['capture_flags'])")
  (cd "$work" && "$bin" capture "$scene" -o "$name.strace" --frames 3 $flags --quiet)
  for threads in 1 2; do
    # One line per measurement: round, preset (or llvmpipe), frames replayed, ms per frame.
    : >"$work/times"
    for round in $(seq "$reps"); do
      python3 "$kit/bench.py" "$scene" --threads "$threads" --shaders full --reps 1 --frames 10 --warmup 2 \
        --json "$work/lp.json" >"$work/lp.log" 2>&1 || { cat "$work/lp.log" >&2; exit 1; }
      python3 -c "import json; print($round, 'llvmpipe', 1, json.load(open('$work/lp.json'))['summary'][0]['frame_ms'])" \
        >>"$work/times"
      for preset in $presets; do
        for frames in 1 3; do
          RAYON_NUM_THREADS=$threads "$bin" replay "$work/$name.strace" --preset "$preset" --frames "0..$frames" \
            --no-images --no-reference -q --out "$work/out"
          python3 -c "import json; print($round, '$preset', $frames,
              1e3 * json.load(open('$work/out/results.json'))['timing']['wall_s'] / $frames)" >>"$work/times"
        done
      done
    done
    python3 - "$work/times" "$name" "$threads" $presets <<'SUMMARY'
import statistics, sys
rows = [line.split() for line in open(sys.argv[1])]
ms = {}
for rnd, preset, frames, value in rows:
    ms.setdefault((preset, frames), {})[rnd] = float(value)
lp = ms[("llvmpipe", "1")]
def spread(values):
    v = sorted(values)
    return f"{statistics.median(v):6.0f} ({v[0]:4.0f}-{v[-1]:4.0f})"
def ratio(series):
    return statistics.median(series[r] / lp[r] for r in series)
for preset in sys.argv[4:]:
    one, three = ms[(preset, "1")], ms[(preset, "3")]
    print(f"{sys.argv[2]:<18} {sys.argv[3]:>7} {preset:<10} {spread(one.values())} {spread(three.values())} "
          f"{spread(lp.values())} {ratio(one):7.2f} {ratio(three):7.2f}")
SUMMARY
  done
done
