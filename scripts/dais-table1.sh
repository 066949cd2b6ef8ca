#!/usr/bin/env bash
# DAIS Table 1 (Schied and Dachsbacher 2015) on our traces: one frame at 3840x2160 with 8x
# MSAA of `deferred`, `dais`, `dais-list` and `dais-multirate`; memory per view in MiB (the
# paper's "MB" are MiB: its 1265.62 is 3840 x 2160 x 8 x 20 bytes), the triangle buffer,
# the memoization cache's hits and redundant stores, relative shading cost, DRAM traffic per
# view and SSIM.
# Usage: scripts/dais-table1.sh OUT TRACE... [-- replay flags]
set -euo pipefail
cd "$(dirname "$0")/.."
[ $# -ge 2 ] || { echo "usage: $0 OUT TRACE... [-- replay flags]" >&2; exit 2; }
out=$1
shift
traces=()
while [ $# -gt 0 ] && [ "$1" != "--" ]; do traces+=("$1"); shift; done
[ "${1:-}" = "--" ] && shift
flags=("$@")
[ ${#flags[@]} -gt 0 ] || flags=(--res 3840x2160 --msaa 8 --frames 0)
cargo build --release --quiet
bin=target/release/shadetrace
mkdir -p "$out"
for trace in "${traces[@]}"; do
  name=$(basename "$trace" .strace)
  "$bin" compare "$trace" --presets deferred,dais,dais-list,dais-multirate --out "$out/$name" \
    --images none --quiet "${flags[@]}"
done
python3 - "$out" "${traces[@]}" <<'PY'
import json, os, sys
out, traces = sys.argv[1], sys.argv[2:]
mib = lambda b: b / 2 / 2**20  # both views -> one view, MiB
paper = {"deferred": 1265.62, "dais": 509.09, "dais-list": 293.50, "dais-multirate": 782.00}
print(f"{'trace':<22} {'preset':<15} {'total MiB':>10} {'% deferred':>10} {'paper %':>8} {'tri buf MiB':>11}"
      f" {'list MiB':>8} {'samples MiB':>11} {'hit %':>7} {'redund.':>8} {'cost %':>7} {'DRAM MiB':>9} {'min SSIM':>9}")
for trace in traces:
    name = os.path.basename(trace).removesuffix(".strace")
    base = None
    for preset in ("deferred", "dais", "dais-list", "dais-multirate"):
        r = json.load(open(os.path.join(out, name, preset, "results.json")))
        f = r["frames"][0]
        d = f.get("dais")
        total = f["gbuffer_bytes"] if d is None else d["total_bytes"]
        base = base or total
        tri = d["triangle_buffer_bytes"] if d else 0
        nodes = (d.get("list_nodes") or 0) * 8 if d else 0
        samples = (d.get("shading_samples") or 0) * 12 if d else 0
        hits = 100 * d["memo_hits"] / max(d["memo_lookups"], 1) if d else float("nan")
        red = d["redundant_stores"] if d else 0
        cost = 100 * (r["total"].get("relative_cost") or float("nan"))
        ssim = r["total"].get("min_ssim") or float("nan")
        dram = sum(f["traffic"].values())
        print(f"{name:<22} {preset:<15} {mib(total):>10.2f} {100 * total / base:>9.1f}% "
              f"{100 * paper[preset] / paper['deferred']:>7.1f}% {mib(tri):>11.3f} {mib(nodes):>8.2f} "
              f"{mib(samples):>11.2f} {hits:>7.2f} {red:>8} {cost:>6.1f}% {mib(dram):>9.1f} {ssim:>9.6f}")
PY
