#!/usr/bin/env python3
"""Add backlash side columns s1..sn to a pose file measured in the order of its rows.

Each joint's side at a pose is the direction it moved to get there from the previous row
(1: moving positive, -1: negative, 0: the first row, or a joint that did not move). Run it on the
whole file, before splitting it into training and held-out poses: a split keeps each pose's side,
while the order of a subset does not give it (docs/METHOD.md section 19.5).

usage: scripts/real-data/sides_from_order.py POSES.csv > WITH_SIDES.csv
"""
import csv
import sys


def main() -> int:
    if len(sys.argv) != 2:
        print(__doc__.strip().splitlines()[-1], file=sys.stderr)
        return 2
    with open(sys.argv[1], newline="", encoding="utf-8-sig") as f:
        rows = list(csv.reader(f))
    if not rows:
        print(f"{sys.argv[1]}: empty file", file=sys.stderr)
        return 1
    header = [h.strip() for h in rows[0]]
    q = [i for i, h in enumerate(header) if h.lower().startswith("q") and h[1:2].isdigit()]
    if any(h.lower().startswith("s") and h[1:].isdigit() for h in header):
        print(f"{sys.argv[1]}: already has side columns", file=sys.stderr)
        return 1
    if not q:
        print(f"{sys.argv[1]}: no q1..qn columns", file=sys.stderr)
        return 1
    out = csv.writer(sys.stdout, lineterminator="\n")
    out.writerow(header + [f"s{j + 1}" for j in range(len(q))])
    prev = None
    for line, r in enumerate(rows[1:], start=2):
        try:
            angles = [float(r[i]) for i in q]
        except (ValueError, IndexError):
            print(f"{sys.argv[1]}: line {line}: a q column is not a number", file=sys.stderr)
            return 1
        sides = [0] * len(q) if prev is None else [
            (a > b) - (a < b) if abs(a - b) >= 1e-9 else 0 for a, b in zip(angles, prev)
        ]
        out.writerow(r + [str(s) for s in sides])
        prev = angles
    return 0


if __name__ == "__main__":
    sys.exit(main())
