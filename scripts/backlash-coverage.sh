#!/usr/bin/env bash
# Coverage of a model with backlash over many simulated robots (docs/METHOD.md section 19.5):
# per robot seed, `simulate` measures a TX60 with compliance, harmonics and gear backlash at 500
# poses in random order (10 µm, each pose's sides recorded in s1..s6), the first 300 are
# identified with --beyond-geometry (the gaps fitted to the recorded sides), and `validate`
# checks the last 200 three ways:
#   centre   - without their sides: each joint at the centre of its gap, the model's term for
#              unknown sides drawn (what an analysis does where the sides are not known);
#   drawn    - without their sides, the model file without that term: the sides drawn;
#   recorded - with their sides.
# It prints per robot the share of the 200 inside the predicted 95 % bound and the PIT mean of
# the largest error over 20 poses, then the means over the robots. An honest bound covers 95 % on
# average (one robot: ±3.1 % at 2σ).
#
# usage: scripts/backlash-coverage.sh [ROBOTS] [BACKLASH_SCALE]   (defaults 20 and 1)
# The binary is target/release/gpu-amcs (or $GPU_AMCS_BIN); files go to a temporary folder.
set -euo pipefail
robots=${1:-20}
scale=${2:-1}
bin=${GPU_AMCS_BIN:-target/release/gpu-amcs}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
figures() { # JSON of validate -> "coverage% pit"
    python3 -c 'import json,sys; t=json.load(open(sys.argv[1]))["predictive_check"]["with_term"]; print("%.1f %.2f" % (100*t["coverage_95"], t["pit_max_mean"]))' "$1"
}
printf "%-6s %-16s %-16s %-16s\n" robot "centre (PIT)" "drawn (PIT)" "recorded (PIT)"
all=()
for r in $(seq 1 "$robots"); do
    "$bin" simulate --poses 500 --robot-seed "$((1000 + r))" --seed "$r" --compliance 1 \
        --harmonics 1 --backlash "$scale" --tracker-sigma 0.01 -o "$work/all.csv" >/dev/null 2>&1
    head -301 "$work/all.csv" >"$work/train.csv"
    { head -1 "$work/all.csv"; tail -n +302 "$work/all.csv"; } >"$work/test_s.csv"
    cut -d, -f1-9 "$work/test_s.csv" >"$work/test.csv"
    "$bin" identify "$work/train.csv" --beyond-geometry=on -o "$work/m.toml" -q
    if ! grep -q '^\[joint_errors.backlash_sides_unknown\]' "$work/m.toml"; then
        echo "robot $r: the model kept no backlash; skipped"
        continue
    fi
    # The model without its term for unknown sides (the table runs to the next table that is not
    # its own compensation).
    awk '/^\[joint_errors\.backlash_sides_unknown/ {skip = 1; next}
         /^\[/ {skip = 0} !skip' "$work/m.toml" >"$work/m-drawn.toml"
    "$bin" validate --model "$work/m.toml" "$work/test.csv" --json "$work/c.json" >/dev/null
    "$bin" validate --model "$work/m-drawn.toml" "$work/test.csv" --json "$work/d.json" >/dev/null
    "$bin" validate --model "$work/m.toml" "$work/test_s.csv" --json "$work/s.json" >/dev/null
    c=$(figures "$work/c.json") d=$(figures "$work/d.json") s=$(figures "$work/s.json")
    printf "%-6s %-16s %-16s %-16s\n" "$r" "$c" "$d" "$s"
    all+=("$c $d $s")
done
printf '%s\n' "${all[@]}" | awk '{for (i = 1; i <= NF; i++) s[i] += $i; n++}
    END {if (n) printf "mean of %d robots: centre %.1f %% (PIT %.2f), drawn %.1f %% (%.2f), recorded %.1f %% (%.2f)\n",
        n, s[1]/n, s[2]/n, s[3]/n, s[4]/n, s[5]/n, s[6]/n}'
