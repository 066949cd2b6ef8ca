#!/usr/bin/env bash
# Hybrid reprojection (Wißmann et al. 2020) against Plain Stereo on our traces: per trace and
# resolution (HD and 4K per eye by default), `visbuffer` (Plain Stereo: a deferred pipeline
# whose pixels are forward's), `repro-rt` and `repro-reraster`: the share of right-view
# pixels reprojected and ray traced (mean and max over the frames), grid triangles, the
# cost of both views and of the right view relative to Plain Stereo (the paper's speed-up,
# in instructions), DRAM traffic and geometry work (triangles through the vertex stage)
# relative to it, and the right view's SSIM against forward.
# Then the grid against θΔ on the first trace at the first resolution.
# Usage: scripts/repro-study.sh OUT TRACE... [-- replay flags, default --frames 0..4]
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 2 ] || { echo "usage: $0 OUT TRACE... [-- replay flags]" >&2; exit 2; }
out=$1
shift
traces=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do traces+=("$1"); shift; done
[ "${1:-}" = "--" ] && shift
flags=("$@")
[ ${#flags[@]} -gt 0 ] || flags=(--frames 0..4)
resolutions=${REPRO_RESOLUTIONS:-"1920x1080 3840x2160"}
cargo build --release --quiet
bin=target/release/shadetrace
mkdir -p "$out"
for trace in "${traces[@]}"; do
  name=$(basename "$trace" .strace)
  for res in $resolutions; do
    "$bin" compare "$trace" --presets visbuffer,repro-rt,repro-reraster --out "$out/$name-$res" \
      --images none --quiet --res "$res" "${flags[@]}"
  done
done
first=${traces[0]}
first_res=${resolutions%% *}
for t in 0.25 0.5 1 2 4; do
  "$bin" replay "$first" --preset repro-rt --out "$out/theta-$t" --no-images --no-reference --quiet \
    --res "$first_res" --parallax-threshold "$t" "${flags[@]}"
done
python3 - "$out" "$first_res" "$resolutions" "${traces[@]}" <<'PY'
import json, os, sys
out, first_res, resolutions, traces = sys.argv[1], sys.argv[2], sys.argv[3].split(), sys.argv[4:]
load = lambda *p: json.load(open(os.path.join(out, *p, "results.json")))
issued = lambda view: sum(s["alu"] + s["tex"] for s in view["cost"].values() if isinstance(s, dict) and "alu" in s)
print(f"{'trace':<22} {'res':<10} {'preset':<15} {'repro %':>8} {'holes %':>8} {'max %':>6} {'grid tris':>10}"
      f" {'frame x':>8} {'right x':>8} {'DRAM x':>7} {'geom x':>7} {'SSIM R':>8}")
for trace in traces:
    name = os.path.basename(trace).removesuffix(".strace")
    for res in resolutions:
        base = load(f"{name}-{res}", "visbuffer")
        cost = lambda r, v=None: sum(issued(f["views"][v]) if v is not None else issued(f["views"][0]) + issued(f["views"][1]) for f in r["frames"])
        dram = lambda r: sum(sum(f["traffic"].values()) for f in r["frames"])
        # Geometry work: triangles through the vertex stage, both views.
        geom = lambda r: sum(v["vertex"]["triangles_in"] for f in r["frames"] for v in f["views"])
        for preset in ("repro-rt", "repro-reraster"):
            r = load(f"{name}-{res}", preset)
            px = r["eye_width"] * r["eye_height"]
            st = [f["reprojection"] for f in r["frames"]]
            holes = [100 * s["hole_pixels"] / px for s in st]
            repro = sum(100 * s["reprojected_pixels"] / px for s in st) / len(st)
            tris = sum(s["grid_triangles"] for s in st) / len(st)
            ssim = min(f["views"][1]["quality"]["ssim"] or 0 for f in r["frames"])
            print(f"{name:<22} {res:<10} {preset:<15} {repro:>8.2f} {sum(holes) / len(holes):>8.2f} {max(holes):>6.2f} "
                  f"{tris:>10.0f} {cost(base) / cost(r):>7.2f}x {cost(base, 1) / cost(r, 1):>7.2f}x "
                  f"{dram(base) / dram(r):>6.2f}x {geom(base) / max(geom(r), 1):>6.2f}x {ssim:>8.5f}")
print(f"\ngrid against θΔ ({os.path.basename(traces[0])}, {first_res}, repro-rt, mean per frame)")
print(f"{'θΔ arcmin':>10} {'cells over':>10} {'tessellated':>11} {'grid tris':>10} {'discarded':>9} {'holes %':>8}")
for t in ("0.25", "0.5", "1", "2", "4"):
    r = load(f"theta-{t}")
    st = [f["reprojection"] for f in r["frames"]]
    n = len(st)
    px = r["eye_width"] * r["eye_height"]
    mean = lambda k: sum(s[k] for s in st) / n
    print(f"{t:>10} {mean('cells_over_threshold'):>10.0f} {mean('cells_tessellated'):>11.0f} {mean('grid_triangles'):>10.0f} "
          f"{mean('grid_triangles_discarded'):>9.0f} {100 * mean('hole_pixels') / px:>8.2f}")
PY
