#!/usr/bin/env bash
# Renders reports in headless Chromium and checks that they draw, as a person would see them:
# the demo's (the main job of the README on a fresh machine, written to OUT) and any report
# folders given after it (e.g. a `compare` of a real scene):
#   scripts/check-report.sh [OUT] [REPORT_DIR...]
# Installs Debian's chromium if absent.
set -euo pipefail
cd "$(dirname "$0")/.."
out=${1:-/tmp/demo-check}
shift || true
if ! command -v chromium >/dev/null; then
  apt-get update -qq && apt-get install -y -qq chromium >/dev/null
fi
profile=$(mktemp -d)
trap 'rm -rf "$profile"' EXIT
browse() {
  chromium --headless --no-sandbox --disable-gpu --disable-quic --no-first-run \
    --disable-background-networking --disable-component-update --disable-sync \
    --user-data-dir="$profile" "$@" 2>/dev/null
}

# check DIR MAX_BYTES: the checks on DIR/index.html.
check() {
  local dir=$1 max_bytes=$2
  browse --window-size=1400,3000 --screenshot="$dir/screenshot.png" "file://$(realpath "$dir")/index.html"
  local size
  size=$(stat -c %s "$dir/screenshot.png")
  # A blank page renders to a few KB; stereo images, heat maps and plots take hundreds.
  if [ "$size" -lt 100000 ]; then
    echo "$dir: screenshot is only $size bytes: the report did not render" >&2
    return 1
  fi
  grep -q 'data:image/png;base64,' "$dir/index.html"
  grep -q '<svg' "$dir/index.html"
  if grep -Eq '(src|href)="https?://' "$dir/index.html"; then
    echo "$dir: report references external resources" >&2
    return 1
  fi
  # Every local link resolves (thumbnails link to full-size PNGs, figures to their SVG and
  # PNG files, tables to results.json).
  python3 - "$dir" <<'PY'
import os, re, sys
out = sys.argv[1]
html = open(os.path.join(out, "index.html")).read()
links = [h for h in re.findall(r'href="([^"#][^"]*)"', html) if not h.startswith("data:")]
broken = [h for h in links if not os.path.exists(os.path.join(out, h))]
if broken:
    sys.exit(f"{out}: {len(broken)} of {len(links)} links are broken, e.g. {broken[:3]}")
figures = [h for h in links if h.endswith(".svg")]
if not figures:
    sys.exit(f"{out}: no figure files linked")
print(f"{out}: {len(links)} links resolve, {len(figures)} figures")
PY
  # The page stays small enough to open and mail: thumbnails, not full-size pictures.
  local html_size
  html_size=$(stat -c %s "$dir/index.html")
  if [ "$html_size" -gt "$max_bytes" ]; then
    echo "$dir: index.html is $html_size bytes, more than $max_bytes" >&2
    return 1
  fi
  # Laid out by the browser: every image decodes, the page is at most 40,000 px tall (it was
  # 60,000 with full-width pictures) and no wider than the window. A copy of the page beside it
  # (for its relative links) gets a script that writes what it measured into the DOM.
  local probe="$dir/.layout-probe.html" layout
  sed 's|</body>|<script>window.onload=()=>{const b=[...document.images].filter(i=>!i.complete\|\|i.naturalWidth==0).length;document.body.dataset.layout=`height=${document.documentElement.scrollHeight} width=${document.documentElement.scrollWidth} images=${document.images.length} broken=${b}`}</script></body>|' \
    "$dir/index.html" >"$probe"
  layout=$(browse --window-size=1400,1000 --virtual-time-budget=10000 --dump-dom "file://$(realpath "$probe")" |
    grep -o 'data-layout="[^"]*"' | head -1 || true)
  rm -f "$probe"
  python3 - "$dir" "$layout" <<'PY'
import re, sys
out, m = sys.argv[1], dict(re.findall(r"(\w+)=(\d+)", sys.argv[2]))
if not m:
    sys.exit(f"{out}: the browser measured nothing")
height, width, images, broken = (int(m[k]) for k in ("height", "width", "images", "broken"))
if broken or images == 0:
    sys.exit(f"{out}: {broken} of {images} images did not decode")
if height > 40000:
    sys.exit(f"{out}: the page is {height} px tall, more than 40,000")
if width > 1400:
    sys.exit(f"{out}: the page is {width} px wide, wider than the 1400 px window")
print(f"{out}: laid out {width}x{height} px, {images} images decode")
PY
  echo "$dir: report renders: $dir/screenshot.png ($size bytes), index.html $html_size bytes"
}

cargo run --release --quiet -- demo --out "$out" --quiet
check "$out" $((3 << 20))
for dir in "$@"; do
  check "$dir" $((4 << 20))
done
