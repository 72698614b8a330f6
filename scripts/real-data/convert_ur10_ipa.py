#!/usr/bin/env python3
"""Convert the UR10 laser-tracker data of christianlandgraf/ipa-robot-accuracy (Fraunhofer IPA;
Landgraf et al., CASE 2021; MIT licence) into gpu-amcs pose files.

Source: https://github.com/christianlandgraf/ipa-robot-accuracy
        commit 507fba69bdaf6c43c2faf306e70a7e37c5e39b89
        Series_B/measurements_joint_configurations.csv (default; also works for Series_C/D/A files)
        `;`-separated, decimal comma. Columns used: shoulder_pan_joint ... wrist_3_joint (rad, the
        UR controller's joint angles), measurement_x/y/z (mm: the origin of the Leica T-Mac probe on
        the flange, in the laser tracker's frame) and, where present, measurement_std_x/y/z (mm,
        the tracker's standard deviation of that measurement).

SOURCE is the csv file itself, or the repository's bare git mirror (then --series picks the file,
read with `git show HEAD:...`). Joint angles are converted rad -> deg (UR convention, q = 0 is the
DH zero: no offsets), positions stay in mm in the tracker frame. Timestamps and temperature are
dropped (the timestamps are stored rounded to 6 digits and cannot order the rows).

Writes OUT (header q1..q6,x,y,z) and, with --sigma-out and std columns present, a second file
with sx,sy,sz from measurement_std_*. Standard library only.
"""
import argparse
import math
import os
import subprocess
import sys

SERIES = {
    "A": "Series_A/measurements_grid.csv",
    "B": "Series_B/measurements_joint_configurations.csv",
    "C": "Series_C/measurements_random_poses.csv",
    "D": "Series_D/measurements_iso_cubes.csv",
}
JOINTS = ["shoulder_pan_joint", "shoulder_lift_joint", "elbow_joint",
          "wrist_1_joint", "wrist_2_joint", "wrist_3_joint"]


def read_source(src, series):
    if os.path.isfile(src):
        with open(src, encoding="utf-8", errors="replace") as f:
            return f.read()
    return subprocess.run(["git", "--git-dir", src, "show", "HEAD:" + SERIES[series]],
                          check=True, capture_output=True).stdout.decode("utf-8", "replace")


def num(s):
    return float(s.replace(",", "."))


def fmt(v, nd):
    s = "%.*f" % (nd, v)
    s = s.rstrip("0").rstrip(".") if "." in s else s
    return "0" if s in ("-0", "") else s


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("source", help="a Series_*/measurements_*.csv file, or the repository's git dir")
    ap.add_argument("--series", choices=sorted(SERIES), default="B")
    ap.add_argument("-o", "--out", default="poses.csv")
    ap.add_argument("--sigma-out", help="also write this file with sx,sy,sz (measurement_std_*)")
    a = ap.parse_args()

    lines = [l for l in read_source(a.source, a.series).splitlines() if l.strip()]
    head = lines[0].split(";")
    ji = [head.index(n) for n in JOINTS]
    mi = [head.index("measurement_" + c) for c in "xyz"]
    si = [head.index("measurement_std_" + c) for c in "xyz"] if "measurement_std_x" in head else None
    rows = []
    for l in lines[1:]:
        c = l.split(";")
        q = [math.degrees(num(c[i])) for i in ji]
        p = [num(c[i]) for i in mi]
        s = [num(c[i]) for i in si] if si else None
        rows.append((q, p, s))
    # q to 1e-7 deg (the source's radians carry ~1e-6 rad), positions as given (1e-5 mm or better)
    with open(a.out, "w") as f:
        f.write("q1,q2,q3,q4,q5,q6,x,y,z\n")
        for q, p, _ in rows:
            f.write(",".join([fmt(v, 7) for v in q] + [repr(v) for v in p]) + "\n")
    if a.sigma_out:
        if not si:
            sys.exit("this series has no measurement_std_* columns")
        with open(a.sigma_out, "w") as f:
            f.write("q1,q2,q3,q4,q5,q6,x,y,z,sx,sy,sz\n")
            for q, p, s in rows:
                f.write(",".join([fmt(v, 7) for v in q] + [repr(v) for v in p + s]) + "\n")
    print("%d poses -> %s" % (len(rows), a.out), file=sys.stderr)


if __name__ == "__main__":
    main()
