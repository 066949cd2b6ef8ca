#!/usr/bin/env bash
# Coverage-guided fuzzing (cargo fuzz / libFuzzer) of the trace reader, glTF capture and the
# flythrough parser, SECONDS per target (default 60), seeded from the committed traces and
# fuzz/seeds/. A finding stops the run with libFuzzer's report and a crash file under
# fuzz/artifacts/TARGET/; copy it to fuzz/regressions/TARGET/ and the test suite replays it
# from then on. Needs `cargo fuzz` (cargo install cargo-fuzz) and a nightly toolchain; on a
# stable-only machine RUSTC_BOOTSTRAP=1 lets stable build it without the sanitizer.
# Usage: scripts/fuzz.sh [SECONDS] [TARGET...]
set -euo pipefail
cd "$(dirname "$0")/../fuzz"
seconds=${1:-60}
shift || true
targets=("$@")
[ ${#targets[@]} -gt 0 ] || targets=(trace_reader gltf_import flythrough)
if cargo +nightly --version >/dev/null 2>&1; then
  fuzz=(cargo +nightly fuzz)
  sanitizer=address
else
  fuzz=(env RUSTC_BOOTSTRAP=1 cargo fuzz)
  sanitizer=none
fi
corpus=$(mktemp -d)
trap 'rm -rf "$corpus"' EXIT
for target in "${targets[@]}"; do
  mkdir -p "$corpus/$target"
  case $target in
    trace_reader) cp ../traces/light-room.strace ../traces/depth-stack.strace ../traces/floor.strace "$corpus/$target/" ;;
    *) cp seeds/"$target"/* "$corpus/$target/" ;;
  esac
  [ -d regressions/"$target" ] && cp regressions/"$target"/* "$corpus/$target/" 2>/dev/null || true
  "${fuzz[@]}" build --release --sanitizer "$sanitizer" "$target"
  # 512 MiB of RSS and 10 s per input at most: a bomb or a hang is a finding too.
  log="$corpus/$target.log"
  if ! "${fuzz[@]}" run --release --sanitizer "$sanitizer" "$target" "$corpus/$target" -- \
    -max_total_time="$seconds" -rss_limit_mb=512 -timeout=10 -max_len=1048576 -print_final_stats=1 >"$log" 2>&1; then
    tail -n 60 "$log"
    echo "fuzz target $target found a problem (report above, input under fuzz/artifacts/$target/)" >&2
    exit 1
  fi
  echo "$target: $(grep -E '^stat::number_of_executed_units' "$log" | awk '{print $2}') executions in ${seconds} s," \
    "$(grep -E '^stat::average_exec_per_sec' "$log" | awk '{print $2}')/s, peak RSS $(grep -E '^stat::peak_rss_mb' "$log" | awk '{print $2}') MB, no finding"
done
