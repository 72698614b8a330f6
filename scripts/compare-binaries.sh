#!/usr/bin/env bash
# compare-binaries.sh: proves that a refactor changed no output byte, timings aside.
#
# Usage: scripts/compare-binaries.sh OLD_BIN NEW_BIN [WORKDIR]
#
# Runs the same list of gpu-amcs commands with OLD_BIN in WORKDIR/old and with NEW_BIN in
# WORKDIR/new (WORKDIR defaults to a fresh `mktemp -d`; old/ and new/ must not exist yet), each
# with its scratch folder as the working directory and relative file names only, so that the
# paths the outputs mention are the same on both sides. Every case writes into its own folder
# NAME/: stdout.txt, stderr.txt, exit-status and the files the command writes (JSON, CSV, TOML,
# HTML, SVG, design and data CSVs). A case that needs an earlier case's file (a simulated data
# set, an identified or calibrated model) reads the one its own binary wrote, so each side is a
# complete, independent chain: simulate -> identify -> mcs/sensitivity on the identified model.
#
# Then, case by case, it compares the two folders: the same file names, and every file byte for
# byte after the normalisation below. It prints one line per case, `same` or `DIFFERS` (with a
# short diff excerpt), and exits 1 if any case differs (2 on a usage error).
#
# The cases (cases() below; six joints: the TX60 preset; seven: the iiwa14 preset, whose σ are
# all 0, and the iiwa14 calibrated by `calibrate`, on which every analysis runs), all with
# --backend cpu and fixed seeds: calibrate; the main job (AMCS, 50 points, δ = 0.01 mm, JSON,
# CSV, HTML); mcs (10^5 draws); sensitivity (N = 8192); tail (subset simulation); map (10 × 10
# cells of the xz plane, 2000 draws); simulate sweeps -> identify, simulate 60 poses in a tracker
# frame -> identify (model TOML, JSON, CSV); mcs and sensitivity on each identified model in the
# measurement frame and with --frame base; plan (10 or 12 poses of 200 candidates, 10^4 draws).
#
# The normalisation strips wall-clock times and nothing else. They were found by running every
# case twice with one binary and diffing the raw outputs, and by reading where the code measures
# time (std::time::Instant in crates/core and src/cmd). Each time is replaced by `<TIME>` in
# place, so the rest of its line is still compared:
#   JSON    the values of the keys "seconds" (amcs, mcs, tail, plan reports), "ik_seconds" and
#           "eval_seconds" (map), "calibration_seconds" (study; no case writes it today).
#   stdout  "(converged, 0.004 s)" / "(fixed number of draws, 0.02 s)" on the `draws` line;
#           tail's "evaluations of w in 0.12 s"; map's "; IK 0.05 s, evaluation 0.01 s"; plan's
#           "design ... poses of ... candidates ..., 0.16 s"; calibrate's "N runs identified in 0.48 s".
#   HTML    the "run time" entries ("0.004 s"; map: "inverse kinematics 0.05 s, evaluation 0.01 s").
#   stderr  the progress bar is not drawn (stderr is a file, not a terminal), but a run whose
#           extrapolated elapsed time exceeds 10 s prints "LABEL: estimated ~N s for ..."; whether
#           that line appears at all depends on the machine's load, so such lines are dropped
#           whole. The rest of stderr (notes, warnings, "wrote ..." lines) is compared.
# CSV, SVG and TOML outputs hold no time and are compared as they are. The results themselves do
# not depend on time or thread count (every seed is fixed, the CPU backend is forced), so two
# runs of one binary agree exactly: `scripts/compare-binaries.sh BIN BIN` is the check that
# these filters are enough. Run both binaries on the same machine: the text reports name the
# number of CPU threads.
#
# IGNORE_COVARIANCE_BLOCKS=1 (environment): also drop lines matching `^blocks = \[` from every
# TOML output before comparing. Model files written by the new binary may carry one extra line
# `blocks = [...]` inside their [covariance] table, on purpose; the old binary does not write it,
# so without this switch every model TOML with a covariance (calibrate, identify) would differ by
# that one line. Only that line is dropped: the rest of each model file is still compared, and
# the analyses that read the models back (amcs/mcs/sensitivity/tail/map/plan on the calibrated
# iiwa14, mcs and sensitivity on the identified models) are compared in full, so a model that
# reads back differently is still caught.
#
# Runtime: 10-15 s per binary on this project's 2-core machine with release binaries (39 cases;
# the script prints the time of each side). CASE_TIMEOUT (default 300 s) bounds one command.
# Examples:
#   scripts/compare-binaries.sh /tmp/gpu-amcs-old target/release/gpu-amcs
#   IGNORE_COVARIANCE_BLOCKS=1 scripts/compare-binaries.sh /tmp/gpu-amcs-old target/release/gpu-amcs /tmp/cmp
set -euo pipefail

usage() {
    sed -n '4p' "$0" | sed 's/^# //' >&2
    exit 2
}
[[ $# -ge 2 && $# -le 3 ]] || usage
for b in "$1" "$2"; do
    [[ -x $b && -f $b ]] || { echo "error: $b is not an executable file" >&2; exit 2; }
done
OLD_BIN=$(realpath "$1")
NEW_BIN=$(realpath "$2")
WORKDIR=${3:-$(mktemp -d "${TMPDIR:-/tmp}/compare-binaries.XXXXXX")}
mkdir -p "$WORKDIR"
WORKDIR=$(realpath "$WORKDIR")
for side in old new; do
    if [[ -e $WORKDIR/$side ]]; then
        echo "error: $WORKDIR/$side exists already; remove it or name another WORKDIR" >&2
        exit 2
    fi
done
IGNORE_COVARIANCE_BLOCKS=${IGNORE_COVARIANCE_BLOCKS:-0}
CASE_TIMEOUT=${CASE_TIMEOUT:-300} # seconds per command; a hung command is a failed case

# ---------------------------------------------------------------------------------------------
# The cases. `run NAME ARGS...` runs "$BIN" ARGS with the scratch folder as working directory,
# stdout/stderr/exit status into NAME/; outputs are named NAME/... by the arguments themselves.

run() {
    local name=$1 rc=0
    shift
    mkdir -p "$name"
    timeout "$CASE_TIMEOUT" "$BIN" "$@" </dev/null >"$name/stdout.txt" 2>"$name/stderr.txt" || rc=$?
    echo "$rc" >"$name/exit-status"
    echo "$name" >>"$CASE_LIST"
}

cases() {
    local cpu=(--backend cpu --seed 2025)
    local m

    # calibrate, first: the seven-joint analyses run on the calibrated iiwa14 (the iiwa14
    # preset's σ are all 0, which sensitivity and tail refuse)
    run calibrate-tx60 calibrate --preset tx60 --seed 1 --robot-seed 2025 --out calibrate-tx60/model.toml
    run calibrate-iiwa14 calibrate --preset iiwa14 --seed 1 --robot-seed 2025 --out calibrate-iiwa14/model.toml

    # the main job (AMCS): TX60 preset; iiwa14 preset (σ = 0: the "carries no uncertainty"
    # note); the calibrated iiwa14
    run amcs-tx60 --preset tx60 --points 50 --delta 0.01 "${cpu[@]}" --json amcs-tx60/main.json \
        --csv amcs-tx60/csv --html amcs-tx60/html
    run amcs-iiwa14-preset --preset iiwa14 --points 50 --delta 0.01 "${cpu[@]}" --json amcs-iiwa14-preset/main.json
    run amcs-iiwa14 --model calibrate-iiwa14/model.toml --points 50 --delta 0.01 "${cpu[@]}" \
        --json amcs-iiwa14/main.json --csv amcs-iiwa14/csv

    # mcs, 10^5 draws
    run mcs-tx60 mcs --preset tx60 --draws 100000 "${cpu[@]}" --json mcs-tx60/mcs.json --csv mcs-tx60/csv
    run mcs-iiwa14 mcs --model calibrate-iiwa14/model.toml --draws 100000 "${cpu[@]}" --json mcs-iiwa14/mcs.json

    # sensitivity (N = 8192 base samples, 300 bootstrap resamples)
    run sensitivity-tx60 sensitivity --preset tx60 --draws 8192 --thresholds 0.1,0.2 "${cpu[@]}" \
        --bootstrap-seed 1 --json sensitivity-tx60/sensitivity.json --csv sensitivity-tx60/csv
    run sensitivity-iiwa14 sensitivity --model calibrate-iiwa14/model.toml --draws 8192 --thresholds 0.3,0.5 \
        "${cpu[@]}" --bootstrap-seed 1 --json sensitivity-iiwa14/sensitivity.json

    # tail (subset simulation)
    run tail-tx60 tail --preset tx60 --threshold 0.2,0.3 "${cpu[@]}" --json tail-tx60/tail.json \
        --csv tail-tx60/csv --html tail-tx60/html
    run tail-iiwa14 tail --model calibrate-iiwa14/model.toml --threshold 1.0,1.5 "${cpu[@]}" \
        --json tail-iiwa14/tail.json

    # map, 10 × 10 cells of the xz plane, 2000 draws
    run map-tx60 map --preset tx60 --plane xz --at 0 --cells 10,10 --draws 2000 "${cpu[@]}" \
        --json map-tx60/map.json --csv map-tx60/csv --html map-tx60/html
    run map-iiwa14 map --model calibrate-iiwa14/model.toml --plane xz --at 0 --cells 10,10 --draws 2000 \
        "${cpu[@]}" --json map-iiwa14/map.json --csv map-iiwa14/csv

    # identify: from sweeps (20 runs, base frame, placement identified all the same) and from
    # 60 poses in a tracker frame (README "From tracker data to reliability")
    for m in tx60 iiwa14; do
        run simulate-sweeps-$m simulate --preset $m --seed 1 --robot-seed 2025 --out simulate-sweeps-$m/sweeps.csv
        run identify-sweeps-$m identify --preset $m simulate-sweeps-$m/sweeps.csv --seed 1 \
            --out identify-sweeps-$m/model.toml --json identify-sweeps-$m/identify.json --csv identify-sweeps-$m/csv
        run simulate-poses-$m simulate --preset $m --poses 60 --seed 3 --out simulate-poses-$m/poses.csv \
            --truth-out simulate-poses-$m/truth.toml
        run identify-poses-$m identify --preset $m simulate-poses-$m/poses.csv --seed 1 \
            --out identify-poses-$m/model.toml --json identify-poses-$m/identify.json --csv identify-poses-$m/csv
    done

    # mcs and sensitivity on the identified models, in the measurement frame (the default: the
    # identified base placement is drawn too) and in the robot's base frame
    for m in tx60 iiwa14; do
        for src in poses sweeps; do
            local model=identify-$src-$m/model.toml
            for frame in measurement base; do
                run mcs-id$src-$m-$frame mcs --model $model --frame $frame --draws 100000 "${cpu[@]}" \
                    --json mcs-id$src-$m-$frame/mcs.json
                run sensitivity-id$src-$m-$frame sensitivity --model $model --frame $frame --draws 4096 \
                    "${cpu[@]}" --bootstrap-seed 1 --json sensitivity-id$src-$m-$frame/sensitivity.json
            done
        done
    done

    # plan: 10 poses (12 for the seven-joint arm: 31 inputs) of 200 candidates, 10^4 draws
    run plan-tx60 plan --preset tx60 --poses 10 --candidates 200 --draws 10000 "${cpu[@]}" \
        --out plan-tx60/design.csv --json plan-tx60/plan.json --csv plan-tx60/csv --html plan-tx60/html
    run plan-iiwa14 plan --model calibrate-iiwa14/model.toml --poses 12 --candidates 200 --draws 10000 \
        "${cpu[@]}" --out plan-iiwa14/design.csv --json plan-iiwa14/plan.json
}

# ---------------------------------------------------------------------------------------------
# Normalisation: wall-clock times to <TIME>, by file type (see the header for each pattern).

T='<TIME>'
NUM='[0-9]+(\.[0-9]+)?([eE][-+]?[0-9]+)?'

normalise() { # FILE -> stdout
    local f=$1
    case $f in
    *.json)
        sed -E "s/\"(seconds|ik_seconds|eval_seconds|calibration_seconds)\": *$NUM/\"\1\": $T/g" "$f"
        ;;
    */stderr.txt)
        # whole line: whether it is printed at all depends on the machine's speed
        grep -Ev ': estimated ~[0-9]+ s for ' "$f" || true
        ;;
    */stdout.txt)
        sed -E \
            -e "s/^(draws .*\((converged|NOT CONVERGED[^,]*|fixed number of draws), )$NUM s\)$/\1$T s)/" \
            -e "s/^(cost +[0-9]+ evaluations of w in )$NUM s$/\1$T s/" \
            -e "s/(; IK )$NUM s, evaluation $NUM s$/\1$T s, evaluation $T s/" \
            -e "s/^(design +[0-9]+ poses of .*, )$NUM s$/\1$T s/" \
            -e "s/^([0-9]+ runs identified in )$NUM s /\1$T s /" \
            "$f"
        ;;
    *.html)
        sed -E \
            -e "s#(>run time</(dt|th)>(<dd>|<td>))$NUM s<#\1$T s<#g" \
            -e "s#(>run time</(dt|th)>(<dd>|<td>))inverse kinematics $NUM s, evaluation $NUM s<#\1inverse kinematics $T s, evaluation $T s<#g" \
            "$f"
        ;;
    *.toml)
        if [[ $IGNORE_COVARIANCE_BLOCKS == 1 ]]; then
            grep -Ev '^blocks = \[' "$f" || true
        else
            cat "$f"
        fi
        ;;
    *)
        cat "$f"
        ;;
    esac
}

# ---------------------------------------------------------------------------------------------
# Run both sides.

for side in old new; do
    if [[ $side == old ]]; then BIN=$OLD_BIN; else BIN=$NEW_BIN; fi
    mkdir -p "$WORKDIR/$side"
    CASE_LIST=$WORKDIR/$side.cases
    : >"$CASE_LIST"
    start=$SECONDS
    (
        cd "$WORKDIR/$side" || exit 2
        cases
    )
    echo "ran $(wc -l <"$CASE_LIST") cases with $side binary $BIN in $((SECONDS - start)) s" >&2
done

# ---------------------------------------------------------------------------------------------
# Compare, case by case.

norm_old=$WORKDIR/.norm-old
norm_new=$WORKDIR/.norm-new
differs=0

# compare LABEL FILES_OLD FILES_NEW: the two lists of paths (relative to old/ and new/) must be
# equal, and every file in both must be equal after normalise.
compare() {
    local label=$1 files_old=$2 files_new=$3 excerpt="" f n=0
    if [[ $files_old != "$files_new" ]]; then
        excerpt+=$({ diff <(sed '/^$/d' <<<"$files_old") <(sed '/^$/d' <<<"$files_new") || true; } | grep '^[<>]' |
            sed 's/^</  only in old:/; s/^>/  only in new:/' | head -n 10)$'\n'
    fi
    while read -r f; do
        [[ -n $f && -f $WORKDIR/old/$f && -f $WORKDIR/new/$f ]] || continue
        normalise "$WORKDIR/old/$f" >"$norm_old"
        normalise "$WORKDIR/new/$f" >"$norm_new"
        if ! cmp -s "$norm_old" "$norm_new"; then
            n=$((n + 1))
            if ((n <= 3)); then # the first lines of the first three files' diffs
                excerpt+="  $f:"$'\n'
                excerpt+=$({ diff -a -U0 "$norm_old" "$norm_new" || true; } | sed -n '3,8p' |
                    cut -c1-160 | sed 's/^/    /')$'\n'
            fi
        fi
    done <<<"$files_old"
    ((n <= 3)) || excerpt+="  ... and $((n - 3)) more files differ"$'\n'
    if [[ -z $excerpt ]]; then
        printf 'same     %s\n' "$label"
    else
        differs=1
        printf 'DIFFERS  %s\n%s' "$label" "$excerpt"
    fi
}

# files SIDE [CASE]: the files of one case (all when CASE is empty), relative to SIDE's folder
files() {
    (cd "$WORKDIR/$1" && find ${2:+"$2"} -type f 2>/dev/null | sed 's#^\./##' | LC_ALL=C sort) || true
}

if ! cmp -s "$WORKDIR/old.cases" "$WORKDIR/new.cases"; then
    echo "DIFFERS  case list (the two sides ran different cases)"
    differs=1
fi
while read -r name; do
    compare "$name" "$(files old "$name")" "$(files new "$name")"
done <"$WORKDIR/old.cases"
# Anything written outside the case folders (there should be nothing) is compared as well.
outside() { files "$1" | awk -F/ 'NR == FNR { c[$0] = 1; next } !($1 in c)' "$WORKDIR/old.cases" -; }
stray_old=$(outside old)
stray_new=$(outside new)
if [[ -n $stray_old$stray_new ]]; then
    compare "(files outside the case folders)" "$stray_old" "$stray_new"
fi
rm -f "$norm_old" "$norm_new"

failed=$(cd "$WORKDIR/old" && grep -Lx 0 */exit-status | sed 's#/exit-status##' | tr '\n' ' ') || true
[[ -z $failed ]] || echo "note: these cases exited nonzero with the old binary: $failed" >&2
echo "outputs kept in $WORKDIR" >&2
if [[ $differs == 1 ]]; then
    echo "RESULT: outputs DIFFER" >&2
    exit 1
fi
echo "RESULT: all $(wc -l <"$WORKDIR/old.cases") cases the same" >&2
