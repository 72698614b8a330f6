#!/usr/bin/env bash
# Honesty of the identified backlash gaps' σ over many simulated robots (docs/METHOD.md section
# 19.5): per robot seed, `simulate` measures a TX60 with compliance, harmonics and gear backlash
# (scale 1: gaps 0.05, 0.03, 0.02, 0.01, 0.02, 0.02°) at N poses in random order from a tracker
# (the AT960 model, a random placement; each pose's sides recorded), `identify --beyond-geometry`
# fits the gaps, and the script prints each gap's z = (fitted − true) / σ, then the share of the
# gaps within 1.96σ (95 % when the σ are honest) and the RMS of z (1).
#
# usage: scripts/backlash-gaps-coverage.sh [ROBOTS] [POSES]   (defaults 20 and 200)
# The binary is target/release/gpu-amcs (or $GPU_AMCS_BIN); files go to a temporary folder.
set -euo pipefail
robots=${1:-20}
poses=${2:-200}
bin=${GPU_AMCS_BIN:-target/release/gpu-amcs}
work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT
for r in $(seq 1 "$robots"); do
    "$bin" simulate --poses "$poses" --backlash 1 --compliance 1 --harmonics 1 --seed "$r" \
        --robot-seed "$r" -o "$work/p$r.csv" >/dev/null 2>&1
    "$bin" identify "$work/p$r.csv" --beyond-geometry=on --json "$work/p$r.json" >/dev/null 2>&1
done
python3 - "$work" "$robots" <<'PY'
import json, sys
work, robots = sys.argv[1], int(sys.argv[2])
truth = [0.05, 0.03, 0.02, 0.01, 0.02, 0.02]
zs = []
print("robot  z of J1..J6")
for r in range(1, robots + 1):
    v = json.load(open(f"{work}/p{r}.json"))
    b = v["identify"]["runs"][0]["chain"]["beyond_geometry"].get("backlash")
    if not b:
        print(f"{r:5}  no backlash check")
        continue
    z = [(g - t) / s for (g, s), t in zip(b["gap_deg"], truth)]
    zs += z
    print(f"{r:5}  " + " ".join(f"{x:+5.1f}" for x in z))
inside = sum(abs(x) < 1.96 for x in zs)
rms = (sum(x * x for x in zs) / len(zs)) ** 0.5
print(f"{inside} of {len(zs)} gaps within 1.96 sigma ({100 * inside / len(zs):.1f} %), RMS z {rms:.2f}")
for j in range(6):
    zj = zs[j::6]
    print(f"J{j + 1}: RMS z {(sum(x * x for x in zj) / len(zj)) ** 0.5:.2f}, mean z {sum(zj) / len(zj):+.2f}")
PY
