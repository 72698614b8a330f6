#!/usr/bin/env bash
# End-to-end test of deploy/slurm on a real Slurm: installs Slurm and munge from Debian's
# packages (when missing), starts a single-node cluster on this machine (munged, slurmctld and
# slurmd on localhost; a minimal slurm.conf in a scratch directory, no cgroup.conf), submits
# deploy/slurm/mcs-array.sbatch as an array of 4 tasks and mcs-merge.sbatch as a job depending
# on it, waits, and compares the merged report with a one-machine run of the same draws:
# threshold counts (R) and min/max identical, M1–M4 within 1e-12 relative, the coverage interval
# within the histogram's bound. Prints PASS or FAIL (exit 1). Needs root (or sudo), apt-get and
# python3. Only the daemons it started are stopped at the end.
#   DRAWS (default 400000), POINTS (default 10), GPU_AMCS (default target/release/gpu-amcs,
#   built when missing), SLURM_PORT (default 16817; slurmd uses the next port).
set -euo pipefail
cd "$(dirname "$0")/.."
repo=$PWD
draws="${DRAWS:-400000}"
points="${POINTS:-10}"
tasks=4
port="${SLURM_PORT:-16817}"
start=$(date +%s)
SUDO=""
[ "$(id -u)" = 0 ] || SUDO="sudo"

say() { echo "== $*"; }
as_munge() {
  if [ "$(id -u)" = 0 ]; then runuser -u munge -- "$@"; else sudo -u munge "$@"; fi
}
fail() {
  echo "FAIL: $*"
  exit 1
}

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null ||
  ! command -v sbatch >/dev/null || ! command -v munged >/dev/null; then
  say "installing slurmctld, slurmd, slurm-client and munge (Debian packages)"
  $SUDO apt-get update -qq
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq --no-install-recommends \
    slurmctld slurmd slurm-client munge >/dev/null
fi
command -v python3 >/dev/null || fail "python3 is needed to compare the reports"

bin="${GPU_AMCS:-${CARGO_TARGET_DIR:-$repo/target}/release/gpu-amcs}"
if [ ! -x "$bin" ]; then
  say "building $bin"
  cargo build --release --quiet
fi
bin="$(cd "$(dirname "$bin")" && pwd)/$(basename "$bin")"

work="$(mktemp -d /tmp/slurm-local.XXXXXX)"
chmod 755 "$work"
mkdir -p "$work/ctld" "$work/slurmd" "$work/out" "$work/munge"
passed=0
cleanup() {
  for pidfile in "$work/slurmd.pid" "$work/slurmctld.pid" "$work/munge/munged.pid"; do
    if [ -s "$pidfile" ]; then
      $SUDO kill "$(cat "$pidfile")" 2>/dev/null || true
    fi
  done
  if [ "$passed" = 1 ]; then
    sleep 1
    $SUDO rm -rf "$work"
  else
    echo "logs and files kept in $work"
  fi
}
trap cleanup EXIT

say "munge: a key of its own and a daemon on a socket in $work"
$SUDO chown munge:munge "$work/munge"
as_munge mungekey --create --keyfile="$work/munge/munge.key" --force
as_munge munged --key-file="$work/munge/munge.key" \
  --socket="$work/munge/munge.socket" --pid-file="$work/munge/munged.pid" \
  --log-file="$work/munge/munged.log" --seed-file="$work/munge/munged.seed"
munge --socket="$work/munge/munge.socket" -n | unmunge --socket="$work/munge/munge.socket" \
  >/dev/null || fail "munge does not round-trip a credential"

host="$(hostname -s)"
export SLURM_CONF="$work/slurm.conf"
cat >"$SLURM_CONF" <<CONF
ClusterName=localtest
SlurmctldHost=$host(127.0.0.1)
SlurmctldPort=$port
SlurmdPort=$((port + 1))
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge/munge.socket
CredType=cred/munge
StateSaveLocation=$work/ctld
SlurmdSpoolDir=$work/slurmd
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
MpiDefault=none
ReturnToService=2
SchedulerType=sched/backfill
NodeName=$host NodeAddr=127.0.0.1 CPUs=$(nproc) State=UNKNOWN
PartitionName=local Nodes=$host Default=YES MaxTime=INFINITE State=UP
CONF

say "slurmctld and slurmd on localhost (ports $port, $((port + 1)))"
$SUDO env SLURM_CONF="$SLURM_CONF" slurmctld -i
$SUDO env SLURM_CONF="$SLURM_CONF" slurmd
for _ in $(seq 60); do
  state="$(sinfo -h -o %T 2>/dev/null | head -n 1)"
  [ "$state" = idle ] && break
  sleep 1
done
[ "$state" = idle ] || fail "the node is not idle after 60 s (state '$state'; see $work/slurmd.log)"

say "sbatch: an array of $tasks shards of $draws draws, then the merge"
export GPU_AMCS="$bin" DRAWS="$draws" OUTDIR="$work/out" XDG_RUNTIME_DIR="${XDG_RUNTIME_DIR:-/tmp}"
export MCS_ARGS="--points $points --backend cpu"
cd "$work/out"
array="$(sbatch --parsable --array=0-$((tasks - 1)) "$repo/deploy/slurm/mcs-array.sbatch")"
merge="$(sbatch --parsable --dependency="afterok:${array%%;*}" "$repo/deploy/slurm/mcs-merge.sbatch")"
echo "submitted array job ${array%%;*} and merge job ${merge%%;*}"
for _ in $(seq 600); do
  [ -z "$(squeue -h -j "${array%%;*},${merge%%;*}" 2>/dev/null)" ] && break
  sleep 1
done
[ -s run.json ] || fail "no merged report (logs: $(ls "$work"/out/*.log 2>/dev/null | tr '\n' ' '))"
ls shard-*.json | sed 's/^/  /'

say "one-machine run of the same $draws draws"
"$bin" mcs --draws "$draws" $MCS_ARGS -q --json one.json
compare() {
  python3 - run.json one.json <<'PY'
import json, sys
m, e = (json.load(open(f))["result"] for f in sys.argv[1:3])
h = 1e-6  # histogram bin width of a summary, mm (crates/core/src/mc/summary/)
problems = [k for k in ("draws", "reliability", "min", "max") if m[k] != e[k]]
for k in ("mean", "variance", "skewness", "kurtosis"):
    x, y = m["moments"][k], e["moments"][k]
    if abs(x - y) > 1e-12 * abs(y):
        problems.append(f"{k} {x} vs {y}")
width = lambda r: r["coverage_interval"]["high"] - r["coverage_interval"]["low"]
if abs(width(m) - width(e)) > 2 * h:
    problems.append(f"interval width {width(m)} vs {width(e)}")
print(f"  merged: {m['draws']} draws, mean {m['moments']['mean']:.12g} mm, "
      f"R(0.1) {m['reliability'][0]['r']}, interval {m['coverage_interval']}")
print(f"  single: {e['draws']} draws, mean {e['moments']['mean']:.12g} mm, "
      f"R(0.1) {e['reliability'][0]['r']}, interval {e['coverage_interval']}")
if problems:
    print("  differ: " + "; ".join(problems))
    sys.exit(1)
PY
}
compare || fail "the merged report differs from the one-machine run"
passed=1
echo "PASS: $tasks Slurm array tasks merged = one-machine run ($draws draws, $(($(date +%s) - start)) s)"
