#!/usr/bin/env python3
"""Convert the Rokae 6R laser-tracker data of dongjy-s/LM_PyTorch into a gpu-amcs pose file.

Source: https://github.com/dongjy-s/LM_PyTorch  commit e87ba15f454ab23fbfa3e16db524f7557d80b56a
        data/joint_angle.csv  30 lines of Rokae controller RAPID-like text
                              `LOCAL VAR jointtarget jN = j:{q1,...,q6,0}  {EJ ...}`, degrees
        data/laser_pos.csv    30 lines `MotionN  x y z rx ry rz  x y z rx ry rz  d1 d2`
                              (whitespace separated): columns 1-6 the nominal pose, columns 7-12 the
                              laser-tracker measurement (mm, degrees), 13-14 two deviations; the
                              repository's own loader (tools/data_loader.py, config/config.yaml
                              `measurement_columns: [7..12]`) takes columns 7-9 as the measured position.

SOURCE is either the repository's data/ folder (files extracted) or its bare git mirror (then the
files are read with `git show HEAD:data/...`). Line k of joint_angle.csv pairs with line k of
laser_pos.csv (jN <-> MotionN; checked). Angles stay in degrees (the controller's convention is the
MDH table's: data/dh.csv, theta offsets -90 on J2, 180 on J6), positions stay in mm in the tracker
frame. Writes poses.csv with header q1..q6,x,y,z. Standard library only.
"""
import argparse
import os
import re
import subprocess
import sys


def read_source(src, rel):
    path = os.path.join(src, os.path.basename(rel))
    if os.path.isfile(path):
        with open(path, encoding="utf-8", errors="replace") as f:
            return f.read()
    return subprocess.run(["git", "--git-dir", src, "show", "HEAD:" + rel],
                          check=True, capture_output=True).stdout.decode("utf-8", "replace")


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("source", help="the repository's data/ folder, or its git dir")
    ap.add_argument("-o", "--out", default="poses.csv")
    a = ap.parse_args()

    joints = {}
    for line in read_source(a.source, "data/joint_angle.csv").splitlines():
        m = re.search(r"jointtarget\s+j(\d+)\s*=\s*j:\{([^}]*)\}", line)
        if m:
            vals = [float(v) for v in m.group(2).replace("\t", " ").split(",") if v.strip()]
            joints[int(m.group(1))] = vals[:6]
    poses = {}
    for line in read_source(a.source, "data/laser_pos.csv").splitlines():
        parts = line.split()
        if len(parts) == 15 and parts[0].startswith("Motion"):
            poses[int(parts[0][6:])] = [float(v) for v in parts[7:10]]
    if sorted(joints) != sorted(poses):
        sys.exit("joint and position files do not pair: %s vs %s" % (sorted(joints), sorted(poses)))
    with open(a.out, "w") as f:
        f.write("q1,q2,q3,q4,q5,q6,x,y,z\n")
        for k in sorted(joints):
            f.write(",".join(repr(v) for v in joints[k] + poses[k]) + "\n")
    print("%d poses -> %s" % (len(joints), a.out), file=sys.stderr)


if __name__ == "__main__":
    main()
