#!/usr/bin/env python3
"""Convert the ABB IRB 120 laser-tracker data of icelinker/Robot-Calibration-LaserTracker
(Kaveh Kamali, 2018; FARO tracker) into gpu-amcs pose files.

Source: https://github.com/icelinker/Robot-Calibration-LaserTracker
        commit 188abd2d773b26dd32bafe50943c3ab0044a72d8, folder 4-DataProcess/Input/
        measured_joints.txt            1000 rows, q1..q6 in degrees (ABB controller convention)
        measured_SMR_{1,2,3}.txt       1000 rows, x y z in mm, tracker frame, three reflectors on the tool
        measured_base_{1,2,3}.txt      1000 rows, x y z in mm, three reference reflectors on the base,
                                       measured at every pose (a zero row = not found)

SOURCE is either that Input folder (files extracted) or the bare git mirror of the repository
(then the files are read with `git show HEAD:4-DataProcess/Input/...`).

Rows are dropped exactly as the source's own 4-DataProcess/main.py drops them (982 remain):
any of the six reflectors reported as (0,0,0), or a base reflector farther than 0.1 / 7 / 33 mm
from its mean over all 1000 rows (the source's thresholds; its means include the zero rows).
Nothing else is changed: angles stay in degrees (ABB convention = the nominal table's), positions
stay in mm in the tracker frame; the base reflectors are only used for the filter.

Writes poses.csv (header q1..q6,x,y,z) for one end reflector (--reflector, default 1).
Standard library only.
"""
import argparse
import math
import os
import subprocess
import sys

NAMES = ["measured_joints"] + ["measured_SMR_%d" % i for i in (1, 2, 3)] + [
    "measured_base_%d" % i for i in (1, 2, 3)]
GIT_PREFIX = "4-DataProcess/Input/"


def read_source(src, name):
    path = os.path.join(src, name + ".txt")
    if os.path.isfile(path):
        with open(path) as f:
            text = f.read()
    else:
        # a bare git mirror (or any git dir): read the file at HEAD
        text = subprocess.run(["git", "--git-dir", src, "show", "HEAD:" + GIT_PREFIX + name + ".txt"],
                              check=True, capture_output=True, text=True).stdout
    return [[float(v) for v in line.split()] for line in text.splitlines() if line.strip()]


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("source", help="4-DataProcess/Input folder, or the repository's git dir")
    ap.add_argument("-o", "--out", default="poses.csv")
    ap.add_argument("--reflector", type=int, choices=(1, 2, 3), default=1,
                    help="end reflector (SMR) written as x,y,z (default 1)")
    ap.add_argument("--all-reflectors", action="store_true",
                    help="write all three end reflectors, one row each per pose, with a target "
                         "column (SMR1, SMR2, SMR3; SMR1 first: the model's tool)")
    ap.add_argument("--base-references", action="store_true",
                    help="also write the three base reflectors of each pose (target BASE1..3, "
                         "mount base): identify follows tracker drift with them")
    a = ap.parse_args()

    d = {n: read_source(a.source, n) for n in NAMES}
    n = len(d["measured_joints"])
    if any(len(v) != n for v in d.values()):
        sys.exit("files have different row counts")
    bases = [d["measured_base_%d" % i] for i in (1, 2, 3)]
    means = [[sum(r[k] for r in b) / n for k in range(3)] for b in bases]
    limits = (0.1, 7.0, 33.0)
    keep = []
    for i in range(n):
        vecs = [d[nm][i] for nm in NAMES[1:]]
        if any(v == [0.0, 0.0, 0.0] for v in vecs):
            continue
        if any(math.dist(bases[k][i], means[k]) > limits[k] for k in range(3)):
            continue
        keep.append(i)
    if a.all_reflectors:
        with open(a.out, "w") as f:
            f.write("q1,q2,q3,q4,q5,q6,x,y,z,target,mount\n")
            for i in keep:
                q = d["measured_joints"][i]
                for r in (1, 2, 3):
                    xyz = d["measured_SMR_%d" % r][i]
                    f.write(",".join(repr(v) for v in q + xyz) + ",SMR%d,tool\n" % r)
                if a.base_references:
                    for r in (1, 2, 3):
                        xyz = d["measured_base_%d" % r][i]
                        f.write(",".join(repr(v) for v in q + xyz) + ",BASE%d,base\n" % r)
        print("%d of %d poses kept -> %s (3 reflectors each)" % (len(keep), n, a.out), file=sys.stderr)
        return
    smr = d["measured_SMR_%d" % a.reflector]
    with open(a.out, "w") as f:
        f.write("q1,q2,q3,q4,q5,q6,x,y,z\n")
        for i in keep:
            q = d["measured_joints"][i]
            f.write(",".join(repr(v) for v in q + smr[i]) + "\n")
    print("%d of %d rows kept -> %s (reflector %d)" % (len(keep), n, a.out, a.reflector), file=sys.stderr)


if __name__ == "__main__":
    main()
