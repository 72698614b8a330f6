#!/usr/bin/env bash
# Hardware-GPU figures in one go, for a machine with a GPU but no Rust toolchain: the evaluator
# bench, the process timings, MCS 10^6 / 10^8 / 10^9 draws on both backends, sensitivity and tail,
# and the GPU-against-CPU integration tests on the real adapter.
#
# Build on a machine with Rust (same processor family), then copy the executables into one folder:
#   cargo bench --no-run && cargo test --release --no-run
#   mkdir -p .devbin && cp target/release/gpu-amcs .devbin/ \
#     && cp target/release/deps/{gpu_throughput,throughput,joint_errors,it}-<hash> .devbin/   (drop the -<hash>)
# and run `BIN=.devbin OUT=/tmp/gpu-figures bash scripts/gpu-hardware-bench.sh` where the GPU is.
# Everything goes to $OUT/log.txt (and the terminal); the last lines are a summary table.
# Optional: GPU_ONLY_STEPS="tests mcs9" runs only the steps named (tests evaluators mcs mcs9
# mcs9cpu sensitivity20 analyses plan discrepancy jointerrors jointcost throughput; all by
# default; jointcost needs the joint_errors bench executable in BIN);
# GPU_BENCH_DEADLINE=seconds.
set -u
BIN=${BIN:-.devbin}
OUT=${OUT:-/tmp/gpu-figures}
mkdir -p "$OUT"
LOG="$OUT/log.txt"
: >"$LOG"
# Report JSONs go to a scratch folder (the log carries what matters from them); the 10^6 and 10^9
# GPU reports are copied to $OUT at the end.
JS=${GPU_BENCH_JSON:-/tmp/gpu-figures-json}
mkdir -p "$JS"
BIN=$(cd "$BIN" && pwd)
export GPU_AMCS_BIN="$BIN/gpu-amcs"
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
T0=$(date +%s)
DEADLINE=${GPU_BENCH_DEADLINE:-1000000}
SUMMARY=()

say() { echo "$*" | tee -a "$LOG"; }
want() { [ -z "${GPU_ONLY_STEPS:-}" ] || [[ " $GPU_ONLY_STEPS " == *" $1 "* ]]; }
left() { echo $((DEADLINE - ($(date +%s) - T0))); }
# step NAME LIMIT_S CMD...: runs CMD under a time limit, output to the log; records wall time.
step() {
    local name=$1 lim=$2
    shift 2
    if [ "$(left)" -lt 5 ]; then
        say "=== $name: skipped (deadline)"
        SUMMARY+=("$name | skipped (deadline)")
        return 0
    fi
    [ "$lim" -gt "$(left)" ] && lim=$(left)
    say "=== $name (limit ${lim} s): $*"
    local s e rc
    s=$(date +%s.%N)
    timeout "$lim" "$@" >>"$LOG" 2>&1
    rc=$?
    e=$(date +%s.%N)
    local wall
    wall=$(awk -v a="$s" -v b="$e" 'BEGIN{printf "%.3f", b-a}')
    say "--- $name: exit $rc, wall $wall s"
    SUMMARY+=("$name | exit $rc | $wall s")
    return $rc
}
# json_brief FILE: draws, seconds, mean, u, backend and notes from a report JSON.
json_brief() {
    python3 - "$1" <<'EOF' 2>/dev/null || echo "(no JSON)"
import json, sys
d = json.load(open(sys.argv[1]))
r = d["result"]
b = r.get("backend", {})
print(f"draws {r['draws']}  seconds {r['seconds']:.4f}  M1 {r['moments']['mean']:.9f}  "
      f"u {r['std_uncertainty']:.9f}  backend {b.get('backend')} ({b.get('adapter')})  "
      f"notes {d.get('notes')}")
EOF
}

# The Vulkan loader (carried as .deb files in .gl when the machine has none) and the driver.
# (libvulkan1 with libglvnd0, libglx0 and friends: NVIDIA's Vulkan driver loads through GLVND.)
if [ -d .gl ]; then
    for f in .gl/*.deb; do dpkg -x "$f" /; done
    ldconfig
fi
say "machine: $(nproc) cores, $(awk '/MemTotal/{print $2/1048576 " GiB"}' /proc/meminfo)"
command -v nvidia-smi >/dev/null && nvidia-smi --query-gpu=name,driver_version,memory.total,clocks.max.sm --format=csv 2>&1 | tee -a "$LOG"
probe() { "$GPU_AMCS_BIN" --points 5 --backend gpu --quiet >>"$LOG" 2>&1; }
if ! probe; then
    say "no GPU adapter with the default loader paths; looking for an NVIDIA Vulkan driver file"
    icd=$(find /usr/local/nvidia /usr/share/vulkan /etc/vulkan -name 'nvidia_icd*.json' 2>/dev/null | head -1)
    say "driver file: ${icd:-none}"
    if [ -n "$icd" ]; then
        export VK_DRIVER_FILES="$icd" VK_ICD_FILENAMES="$icd"
    fi
    probe || {
        say "still no GPU adapter: stopping"
        ldconfig -p | grep -i -E 'vulkan|GLX|GLdispatch' | tee -a "$LOG"
        VK_LOADER_DEBUG=error,warn,driver probe
        tail -n 40 "$LOG"
        exit 3
    }
fi
"$GPU_AMCS_BIN" --points 50 --backend gpu 2>&1 | grep -E '^(backend|note)' | tee -a "$LOG"

if want evaluators; then
    GPU_BENCH_REPS=5 step "bench gpu_throughput" 180 "$BIN/gpu_throughput"
fi
if want mcs; then
    for backend in gpu cpu; do
        for rep in 1 2 3; do
            step "mcs 1e6 $backend #$rep" 60 "$GPU_AMCS_BIN" mcs --points 50 --draws 1000000 \
                --backend "$backend" -q --json "$JS/mcs6-$backend.json"
            say "    $(json_brief "$JS/mcs6-$backend.json")"
        done
    done
    step "main job gpu" 30 "$GPU_AMCS_BIN" --points 50 --delta 0.01 --backend gpu -q \
        --json "$JS/amcs-gpu.json"
    say "    $(json_brief "$JS/amcs-gpu.json")"
    for backend in gpu cpu; do
        step "mcs 1e8 $backend" 120 "$GPU_AMCS_BIN" mcs --points 50 --draws 100000000 \
            --backend "$backend" -q --json "$JS/mcs8-$backend.json"
        say "    $(json_brief "$JS/mcs8-$backend.json")"
    done
fi
if want mcs9; then
    step "mcs 1e9 gpu (summary mode)" 300 "$GPU_AMCS_BIN" mcs --points 50 --draws 1000000000 \
        --memory-limit 1GiB --backend gpu -q --json "$JS/mcs9-gpu.json"
    say "    $(json_brief "$JS/mcs9-gpu.json")"
fi
if want tests; then
    # The GPU-against-CPU agreement tests, now on the real adapter (CI=true: no skipping): the
    # gpu:: module and every test named for the GPU (joint errors, backlash, sensitivity, tail).
    CI=true step "tests: it gpu" 240 "$BIN/it" gpu --test-threads 4
fi
if want mcs9cpu; then
    step "mcs 1e9 cpu (summary mode)" 200 "$GPU_AMCS_BIN" mcs --points 50 --draws 1000000000 \
        --memory-limit 1GiB --backend cpu -q --json "$JS/mcs9-cpu.json"
    say "    $(json_brief "$JS/mcs9-cpu.json")"
fi
if want sensitivity20; then
    for backend in gpu cpu; do
        step "sensitivity 2^20 $backend" 120 "$GPU_AMCS_BIN" sensitivity --points 50 \
            --draws 1048576 --backend "$backend" -q --json "$JS/sens20-$backend.json"
    done
fi
if want analyses; then
    for backend in gpu cpu; do
        step "sensitivity $backend" 120 "$GPU_AMCS_BIN" sensitivity --points 50 \
            --backend "$backend" -q --json "$JS/sens-$backend.json"
        step "tail 0.3 $backend" 120 "$GPU_AMCS_BIN" tail --threshold 0.3 \
            --backend "$backend" -q --json "$JS/tail-$backend.json"
    done
fi
if want plan; then
    # The calibration planner: 30 of 2000 candidates, its prediction with 10^6 draws of the
    # planned model on each backend.
    for backend in gpu cpu; do
        step "plan 30 of 2000, 1e6 prediction draws, $backend" 120 "$GPU_AMCS_BIN" plan \
            --points 50 --poses 30 --tracker-sigma 0.01 --draws 1000000 --backend "$backend" \
            -q --out "$JS/design-$backend.csv" --json "$JS/plan-$backend.json"
        say "    $(grep -o '"seconds": [0-9.e-]*' "$JS/plan-$backend.json" | head -1)"
    done
fi
if want discrepancy; then
    # The model-discrepancy term (Method §18) on each backend: a TX60 identified from 60
    # simulated poses without a stated noise carries one; mcs 10^6 × 50 with and without it.
    "$GPU_AMCS_BIN" simulate --poses 60 --seed 3 -o "$JS/disc-poses.csv" >/dev/null 2>&1
    "$GPU_AMCS_BIN" identify "$JS/disc-poses.csv" -o "$JS/disc-model.toml" -q
    for backend in gpu cpu; do
        for term in with without; do
            flag=(); [ "$term" = without ] && flag=(--no-discrepancy)
            for rep in 1 2 3; do
                step "mcs 1e6 $backend, identified model, $term the term #$rep" 60 \
                    "$GPU_AMCS_BIN" mcs --model "$JS/disc-model.toml" --points 50 \
                    --draws 1000000 --backend "$backend" "${flag[@]}" -q \
                    --json "$JS/disc-$backend-$term.json"
                say "    $(json_brief "$JS/disc-$backend-$term.json")"
            done
        done
    done
fi
if want jointerrors; then
    # Joint errors beyond geometry (Method §19.2) on each backend: a TX60 with compliance and
    # harmonics identified from 200 simulated poses with --beyond-geometry and =off; mcs
    # 10^6 × 50 of each model (the first draws the joint errors, the second has none).
    "$GPU_AMCS_BIN" simulate --poses 200 --seed 3 --tracker-sigma 0.01 --compliance 1 \
        --harmonics 1 -o "$JS/je-poses.csv" >/dev/null 2>&1
    "$GPU_AMCS_BIN" identify "$JS/je-poses.csv" --tracker-sigma 0.01 --beyond-geometry \
        -o "$JS/je-with.toml" -q
    "$GPU_AMCS_BIN" identify "$JS/je-poses.csv" --tracker-sigma 0.01 --beyond-geometry=off \
        -o "$JS/je-without.toml" -q
    for backend in gpu cpu; do
        for term in with without; do
            for rep in 1 2 3; do
                step "mcs 1e6 $backend, $term joint errors #$rep" 60 \
                    "$GPU_AMCS_BIN" mcs --model "$JS/je-$term.toml" --points 50 \
                    --draws 1000000 --backend "$backend" -q --json "$JS/je-$backend-$term.json"
                say "    $(json_brief "$JS/je-$backend-$term.json")"
            done
        done
    done
fi
if want jointcost && [ -x "$BIN/joint_errors" ]; then
    # The joint errors' and the backlash's cost in the evaluators, GPU rows first.
    BENCH_ONLY=cost BENCH_REPS=7 step "bench joint_errors (cost)" 240 "$BIN/joint_errors"
fi
if want throughput; then
    BENCH_REPS=5 step "bench throughput" 240 "$BIN/throughput"
fi

cp "$JS/mcs6-gpu.json" "$JS/mcs9-gpu.json" "$OUT/" 2>/dev/null
say ""
say "=== summary ($(($(date +%s) - T0)) s in all)"
for l in "${SUMMARY[@]}"; do say "$l"; done
