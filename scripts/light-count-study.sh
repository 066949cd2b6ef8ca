#!/usr/bin/env bash
# The light-count study (RTR4 §20.3-20.4): `builtin:light-room?lights=N` for N from 1 to
# 1024 (a 3D grid of lights whose range shrinks as N grows, so a point stays in range of
# about as many), one frame, with forward, forward+, deferred, tiled and clustered: relative shading
# cost, each stage's issued instructions, light-list traffic and G-buffer size per N.
# Usage: scripts/light-count-study.sh [OUT] [replay flags, default --res 640x720]
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-light-count-study}
shift $(( $# >= 1 ? 1 : 0 ))
flags=("$@")
[ ${#flags[@]} -gt 0 ] || flags=(--res 640x720)
cargo build --release --quiet
bin=target/release/shadetrace
mkdir -p "$out"
for n in 1 4 16 64 256 1024; do
  trace="$out/light-room-$n.strace"
  "$bin" capture "builtin:light-room?lights=$n" -o "$trace" --frames 1 --quiet
  "$bin" compare "$trace" --presets forward+,deferred,tiled,clustered --out "$out/n$n" --images none --quiet "${flags[@]}"
done
python3 - "$out" <<'PY'
import csv, json, os, sys
out = sys.argv[1]
rows = []
for n in (1, 4, 16, 64, 256, 1024):
    for r in csv.DictReader(open(os.path.join(out, f"n{n}", "summary.csv"))):
        res = json.load(open(os.path.join(out, f"n{n}", r["preset"], "results.json")))
        frame = res["frames"][0]
        stage = lambda s: sum(v["cost"].get(s, {}).get("alu", 0) + v["cost"].get(s, {}).get("tex", 0) for v in frame["views"])
        rows.append({
            "lights": n, "preset": r["preset"], "relative_cost_pct": float(r["relative_cost_pct"]),
            "issued": int(r["issued"]), "lighting_issued": stage("fine"), "gbuffer_issued": stage("gbuffer"),
            "light_lists_issued": stage("light_lists"), "light_lists_bytes": frame["traffic"].get("light_lists", 0),
            "gbuffer_bytes": frame.get("gbuffer_bytes", 0), "total_bytes": int(r["total_bytes"]),
        })
with open(os.path.join(out, "study.csv"), "w", newline="") as f:
    w = csv.DictWriter(f, fieldnames=list(rows[0]))
    w.writeheader()
    w.writerows(rows)
print(f"{'lights':>6} {'preset':<10} {'rel. cost':>9} {'lighting':>12} {'G-buffer':>11} {'lists':>10} {'list KiB':>9}")
for r in rows:
    print(f"{r['lights']:>6} {r['preset']:<10} {r['relative_cost_pct']:>8.2f}% {r['lighting_issued']:>12,} "
          f"{r['gbuffer_issued']:>11,} {r['light_lists_issued']:>10,} {r['light_lists_bytes'] / 1024:>9.1f}")
print(f"wrote {out}/study.csv")
PY
