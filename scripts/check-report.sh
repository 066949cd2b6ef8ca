#!/usr/bin/env bash
# Renders the demo report in headless Chromium and checks that it draws: the main job of the
# README on a fresh machine, seen as a person would see it. Installs Debian's chromium if absent.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/demo-check}
if ! command -v chromium >/dev/null; then
  apt-get update -qq && apt-get install -y -qq chromium >/dev/null
fi
cargo run --release --quiet -- demo --out "$out" --quiet
profile=$(mktemp -d)
chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
  --disable-background-networking --disable-component-update --disable-sync \
  --user-data-dir="$profile" --window-size=1400,3000 \
  --screenshot="$out/screenshot.png" "file://$(realpath "$out")/index.html" 2>/dev/null
size=$(stat -c %s "$out/screenshot.png")
# A blank page renders to a few KB; stereo images, heat maps and plots take hundreds.
if [ "$size" -lt 100000 ]; then
  echo "screenshot is only $size bytes: the report did not render" >&2
  exit 1
fi
grep -q 'data:image/png;base64,' "$out/index.html"
grep -q '<svg' "$out/index.html"
if grep -Eq '(src|href)="https?://' "$out/index.html"; then
  echo "report references external resources" >&2
  exit 1
fi
# Every local link resolves (thumbnails link to full-size PNGs, tables to results.json).
python3 - "$out" <<'PY'
import os, re, sys
out = sys.argv[1]
html = open(os.path.join(out, "index.html")).read()
links = [h for h in re.findall(r'href="([^"#][^"]*)"', html) if not h.startswith("data:")]
broken = [h for h in links if not os.path.exists(os.path.join(out, h))]
if broken:
    sys.exit(f"{len(broken)} of {len(links)} links are broken, e.g. {broken[:3]}")
print(f"{len(links)} links resolve")
PY
# The page stays small enough to open and mail: thumbnails, not full-size pictures.
html_size=$(stat -c %s "$out/index.html")
if [ "$html_size" -gt $((3 << 20)) ]; then
  echo "index.html is $html_size bytes, more than 3 MiB" >&2
  exit 1
fi
# Laid out by the browser: every image decodes, the page is at most 40,000 px tall (it was
# 60,000 with full-width pictures) and no wider than the window. A copy of the page beside it
# (for its relative links) gets a script that writes what it measured into the DOM.
probe="$out/.layout-probe.html"
trap 'rm -f "$probe"' EXIT
sed 's|</body>|<script>window.onload=()=>{const b=[...document.images].filter(i=>!i.complete\|\|i.naturalWidth==0).length;document.body.dataset.layout=`height=${document.documentElement.scrollHeight} width=${document.documentElement.scrollWidth} images=${document.images.length} broken=${b}`}</script></body>|' \
  "$out/index.html" >"$probe"
layout=$(chromium --headless --no-sandbox --disable-gpu --no-first-run --disable-background-networking \
  --disable-component-update --disable-sync --user-data-dir="$profile" --window-size=1400,1000 \
  --virtual-time-budget=10000 --dump-dom "file://$(realpath "$probe")" 2>/dev/null |
  grep -o 'data-layout="[^"]*"' | head -1)
echo "layout: $layout"
python3 - "$layout" <<'PY'
import re, sys
m = dict(re.findall(r"(\w+)=(\d+)", sys.argv[1]))
if not m:
    sys.exit("the browser measured nothing")
height, width, images, broken = (int(m[k]) for k in ("height", "width", "images", "broken"))
if broken or images == 0:
    sys.exit(f"{broken} of {images} images did not decode")
if height > 40000:
    sys.exit(f"the page is {height} px tall, more than 40,000")
if width > 1400:
    sys.exit(f"the page is {width} px wide, wider than the 1400 px window")
PY
echo "report renders: $out/screenshot.png ($size bytes), index.html $html_size bytes"
