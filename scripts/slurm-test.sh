#!/usr/bin/env bash
# A real Slurm on this machine: installs Debian's slurm-wlm and munge if absent, starts
# munged, slurmctld and slurmd on loopback with a one-node config, submits a 4-task job
# array of a small sweep with the script `shadetrace sweep --emit-slurm` writes, waits,
# merges the shards and checks the merged store equals an unsharded local run row for row
# (every column, bit for bit). The local run is also killed with SIGKILL partway and
# re-run, which must redo no finished job. Needs root (CI's fresh machine is); cleans up
# after itself; fails loudly when Slurm cannot start.
#   scripts/slurm-test.sh [SHADETRACE_BINARY]
set -euo pipefail
self=$(realpath "$0")
cd "$(dirname "$self")/.."
repo=$(pwd)
started=$(date +%s)
say() { echo "slurm-test [$(($(date +%s) - started)) s]: $*"; }
fail() { echo "slurm-test: FAILED: $*" >&2; exit 1; }
if [ "$(id -u)" != 0 ]; then
  if command -v sudo >/dev/null && sudo -n true 2>/dev/null; then
    exec sudo -n --preserve-env=PATH,HOME,RUSTUP_HOME,CARGO_HOME "$self" "$@"
  fi
  fail "needs root (it starts munged, slurmctld and slurmd), and sudo -n does not work"
fi

if [ $# -ge 1 ]; then
  bin=$(realpath "$1")
else
  cargo build --release --quiet
  bin=$repo/target/release/shadetrace
fi
if ! command -v slurmctld >/dev/null || ! command -v munged >/dev/null || ! command -v python3 >/dev/null; then
  say "installing slurm-wlm, munge and python3"
  apt-get update -qq >/dev/null
  DEBIAN_FRONTEND=noninteractive apt-get install -y -qq slurm-wlm munge python3 >/dev/null
fi
say "$(slurmctld -V)"

work=$(mktemp -d /tmp/shadetrace-slurm.XXXXXX)
pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill "$pid" 2>/dev/null || true; done
  sleep 1
  for pid in "${pids[@]}"; do kill -9 "$pid" 2>/dev/null || true; done
  wait 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

# munge: a fresh key in the work folder, its socket there too, running as the munge user.
chmod 755 "$work"
mkdir -p "$work/munge"
dd if=/dev/urandom of="$work/munge/munge.key" bs=1024 count=1 status=none
chown -R munge:munge "$work/munge"
chmod 711 "$work/munge"
chmod 400 "$work/munge/munge.key"
socket=$work/munge/munge.socket
runuser -u munge -- munged --foreground --key-file="$work/munge/munge.key" --socket="$socket" \
  --pid-file="$work/munge/munged.pid" --log-file="$work/munge/munged.log" --seed-file="$work/munge/seed" \
  >"$work/munged.out" 2>&1 &
pids+=($!)
for _ in $(seq 50); do [ -S "$socket" ] && break; sleep 0.1; done
[ -S "$socket" ] || fail "munged did not start: $(tail -3 "$work/munged.out" 2>/dev/null)"

# Slurm: one node (this machine, on loopback), one partition, no accounting, no cgroups.
node=$(uname -n | cut -d. -f1)
cpus=$(nproc)
mkdir -p "$work/state" "$work/spool"
export SLURM_CONF=$work/slurm.conf
cat >"$SLURM_CONF" <<EOF
ClusterName=shadetrace-ci
SlurmctldHost=$node(127.0.0.1)
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$socket
CredType=cred/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
SlurmctldPort=16817
SlurmdPort=16818
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
MpiDefault=none
ReturnToService=2
NodeName=$node NodeAddr=127.0.0.1 CPUs=$cpus State=UNKNOWN
PartitionName=ci Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
slurmctld -D -i >"$work/slurmctld.out" 2>&1 &
pids+=($!)
slurmd -D >"$work/slurmd.out" 2>&1 &
pids+=($!)
state=
for _ in $(seq 60); do
  state=$(sinfo -h -o %T 2>/dev/null | head -1 || true)
  [ "$state" = idle ] && break
  sleep 1
done
if [ "$state" != idle ]; then
  tail -5 "$work/slurmctld.log" "$work/slurmd.log" >&2 || true
  fail "the node did not come up (state '$state')"
fi
say "slurmctld and slurmd up, node $node idle with $cpus CPUs"

# A 2-trace x 3-preset x 4-point sweep, small enough for CI.
cat >"$work/spec.toml" <<EOF
traces = ["$repo/traces/floor.strace", "$repo/traces/spheres.strace"]
presets = ["forward", "tile-pair", "amfs"]
frames = "0..2"
[options]
res = "160x180"
[grid]
tile = [8, 16]
texture-cache-kb = [8, 32]
EOF
"$bin" sweep "$work/spec.toml" --out "$work/array" --emit-slurm 4
job=$(sbatch --parsable --wait "$work/array/sweep.sbatch") || {
  cat "$work"/array/slurm-*.log >&2 || true
  fail "the job array failed"
}
say "job array $job finished: $(ls "$work/array" | grep -c '^shard-') shard stores"
"$bin" merge "$work"/array/shard-*.db -o "$work/array/merged"

# The same sweep unsharded, killed with SIGKILL once some jobs are in, then re-run.
"$bin" sweep "$work/spec.toml" --out "$work/local" --quiet &
sweep=$!
killed=no
for _ in $(seq 400); do
  if ! kill -0 "$sweep" 2>/dev/null; then break; fi
  done_jobs=$(python3 -c "import sqlite3,sys; print(sqlite3.connect(sys.argv[1]).execute('select count(*) from jobs').fetchone()[0])" "$work/local/sweep.db" 2>/dev/null || echo 0)
  if [ "$done_jobs" -ge 3 ]; then kill -9 "$sweep"; killed=yes; break; fi
  sleep 0.05
done
wait "$sweep" 2>/dev/null || true
resumed=$("$bin" sweep "$work/spec.toml" --out "$work/local")
say "killed: $killed; re-run: $resumed"
if [ "$killed" = yes ]; then
  echo "$resumed" | grep -Eq 'ran [0-9]+ jobs .* [1-9][0-9]* were already in' || fail "the re-run redid finished jobs"
fi

python3 - "$work/array/merged/sweep.db" "$work/local/sweep.db" <<'PY'
import sqlite3, sys
def rows(path, table, key):
    con = sqlite3.connect(path)
    cur = con.execute(f"select * from {table} order by {key}")
    names = [d[0] for d in cur.description]
    # Columns a store lacks are NULL in the other: compare what is set.
    return [{n: v for n, v in zip(names, r) if v is not None and n != "wall_s"} for r in cur]
for table, key in (("frames", "job, frame, eye"), ("jobs", "job")):
    merged, local = rows(sys.argv[1], table, key), rows(sys.argv[2], table, key)
    if merged != local:
        diff = next((i for i, (a, b) in enumerate(zip(merged, local)) if a != b), min(len(merged), len(local)))
        sys.exit(f"{table}: merged and local differ ({len(merged)} vs {len(local)} rows; first at row {diff})")
    print(f"{table}: {len(merged)} rows, merged shards equal the local run")
if len(rows(sys.argv[1], "jobs", "job")) != 24:
    sys.exit("expected 24 jobs (2 traces x 3 presets x 4 points)")
PY
say "passed"
