#!/usr/bin/env bash
# Honesty of the reliability on real measurements (issue 32, docs/guide/honesty.md): split a
# pose file into training and held-out poses (every K-th pose held out, K = 5 by default: 80/20),
# identify on the training poses, and check the identified model's predicted error distribution
# against the held-out measurements (`validate`'s predictive check), with and without the
# model's discrepancy term.
#
# usage: scripts/real-data/coverage.sh POSES.csv NOMINAL [K] [extra identify flags...]
#   e.g. scripts/real-data/coverage.sh data/real/ur10-ipa/poses.csv data/real/ur10-ipa/ur10_dh.csv
# The binary is target/release/gpu-amcs (or $GPU_AMCS_BIN); results go to a temporary folder.
# SIDES_FROM_ORDER=1 first writes each pose's backlash sides (s1..sn) from the order of the whole
# file (scripts/real-data/sides_from_order.py), so that the training and held-out poses keep them:
# identify fits the gaps to them and validate predicts each held-out pose with its side (with
# --beyond-geometry; docs/METHOD.md section 19.5).
set -euo pipefail
data=$1
nominal=$2
k=${3:-5}
shift $(($# < 3 ? $# : 3))
bin=${GPU_AMCS_BIN:-target/release/gpu-amcs}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
if [ "${SIDES_FROM_ORDER:-0}" = 1 ]; then
    python3 "$(dirname "$0")/sides_from_order.py" "$data" >"$work/sided.csv"
    data="$work/sided.csv"
fi
awk -v k="$k" -v out="$work" 'NR == 1 { print > (out "/train.csv"); print > (out "/test.csv"); next }
    { if ((NR - 1) % k == 0) print > (out "/test.csv"); else print > (out "/train.csv") }' "$data"
echo "data: $data ($(($(wc -l < "$work/train.csv") - 1)) training, $(($(wc -l < "$work/test.csv") - 1)) held-out poses: every ${k}th)"
"$bin" identify "$work/train.csv" --nominal "$nominal" -o "$work/model.toml" "$@" 2>&1 |
    grep -E "residuals:|noise:|lack of fit|discrepancy term|compensation|self-check" || true
"$bin" validate --model "$work/model.toml" "$work/test.csv"
