#!/usr/bin/env bash
# The tile-pair paper's Fig. 9: the spheres scene captured at several subdivision levels,
# relative shading cost and SSIM (min and per view) of per-pixel, he-2x2, tile-pair-he, amfs,
# texel and tile-pair at each (the tile-pair paper's configuration: DYNAMIC4x4, static corner
# samples for tile-pair and tile-pair-he, tile-pair scheduling, no small-triangle path for
# tile-pair), plus `tile-pair-2x2`: tile-pair at COARSE2x2 with coverage-bbox samples.
# Usage: scripts/tessellation-study.sh [OUT] [replay flags, e.g. --res 640x720]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-tessellation-study}
shift $(( $# >= 1 ? 1 : 0 ))
cargo build --release --quiet
bin=target/release/shadetrace
mkdir -p "$out"
echo "subdiv,quads_per_patch_edge,preset,relative_cost_pct,min_ssim,left_ssim,right_ssim" > "$out/study.csv"
# One row per preset of a compare run: cost and SSIM from summary.csv, per-view SSIM from
# each preset's results.json.
rows() {
  local dir=$1 label=$2 level=$3
  tail -n +2 "$dir/summary.csv" | while IFS=, read -r preset rest; do
    [ -n "$label" ] && [ "$preset" = forward ] && continue
    cost=$(echo "$preset,$rest" | cut -d, -f9)
    ssim=$(echo "$preset,$rest" | cut -d, -f11)
    views=$(python3 -c "import json,sys; v=json.load(open(sys.argv[1])); print(','.join(str(x['quality']['ssim']) for x in v['frames'][0]['views']))" "$dir/$preset/results.json")
    echo "$level,$((1 << level)),${label:-$preset},$cost,$ssim,$views"
  done >> "$out/study.csv"
}
for level in 1 2 3 4 5; do
  trace="$out/spheres-$level.strace"
  "$bin" capture "builtin:spheres?subdiv=$level" -o "$trace" --quiet
  "$bin" compare "$trace" --presets forward,he-2x2,tile-pair-he,amfs,texel,tile-pair --frames 0 --out "$out/level$level" --quiet "$@"
  rows "$out/level$level" "" "$level"
  "$bin" compare "$trace" --presets tile-pair --frames 0 --out "$out/level$level-2x2" --quiet \
    --coarse-mode 2x2 --sampling coverage-bbox --small-triangle true "$@"
  rows "$out/level$level-2x2" tile-pair-2x2 "$level"
done
column -s, -t < "$out/study.csv"
echo "wrote $out/study.csv"
