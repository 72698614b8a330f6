"""max_error on N parameter rows × 50 points against the command line's MCS of N draws × 50
points (its reported `seconds`: drawing and evaluating), both on the same backend.

    python python/benchmarks/max_error_vs_cli.py [N] [backend]   # default 1000000 cpu

The target (issue 14): max_error within 1.5x of the command line's time. The parameter rows
are made by NumPy beforehand and not timed (a caller's sampler makes them).
"""

import json
import os
import pathlib
import subprocess
import sys
import tempfile
import time

import numpy as np

import gpu_amcs

REPO = pathlib.Path(__file__).resolve().parents[2]
n = int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000
backend = sys.argv[2] if len(sys.argv) > 2 else "cpu"
exe = os.environ.get("GPU_AMCS_BIN") or str(
    pathlib.Path(os.environ.get("CARGO_TARGET_DIR", REPO / "target")) / "release" / "gpu-amcs")

model = gpu_amcs.Model.preset("tx60")
# The command line's 50 generated points, so both evaluate the same problem.
with tempfile.TemporaryDirectory() as d:
    subprocess.run([exe, "points", "50", "--out", f"{d}/p.csv"], check=True, capture_output=True)
    q = np.loadtxt(f"{d}/p.csv", delimiter=",", skiprows=1)
params = model.draws(n, seed=2025)

runs = 3
t_py = []
for _ in range(runs):
    t = time.perf_counter()
    w = model.max_error(params, q, backend=backend)
    t_py.append(time.perf_counter() - t)

t_cli = []
with tempfile.TemporaryDirectory() as d:
    for _ in range(runs):
        subprocess.run([exe, "mcs", "--draws", str(n), "--points", "50", "--backend", backend,
                        "--json", f"{d}/r.json", "--quiet"], check=True)
        t_cli.append(json.loads(pathlib.Path(f"{d}/r.json").read_text())["result"]["seconds"])

best_py, best_cli = min(t_py), min(t_cli)
print(f"max_error {n} x 50 ({backend}): best of {runs} {best_py:.3f} s  (all: "
      + ", ".join(f"{x:.3f}" for x in t_py) + ")")
print(f"CLI mcs   {n} x 50 ({backend}): best of {runs} {best_cli:.3f} s  (all: "
      + ", ".join(f"{x:.3f}" for x in t_cli) + ")")
print(f"ratio {best_py / best_cli:.2f} (target <= 1.5)")
