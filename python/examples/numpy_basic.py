"""Plain NumPy: the maximum point error of parameter rows you choose, and the engine's own run.

    python python/examples/numpy_basic.py
"""

import time

import numpy as np

import gpu_amcs

model = gpu_amcs.Model.preset("tx60")  # or Model.from_file("calibrated.toml")
rng = np.random.default_rng(1)
lo, hi = model.limits[:, 0], model.limits[:, 1]
q = rng.uniform(0.5 * lo, 0.5 * hi, size=(50, 6))  # 50 test configurations, degrees

# 100 000 input vectors drawn by NumPy from the model's independent normals: the 33 inputs are
# the 30 MDH parameters (mm, degrees), then the tool point's x, y, z (mm; σ from the model
# file's tool_sigma, 0 for the presets).
params = model.params + model.sigma * rng.standard_normal((100_000, gpu_amcs.N_UNCERTAIN))
t = time.perf_counter()
w = model.max_error(params, q)  # (100000,) mm, the GIL released while it runs
print(f"max_error of {len(w)} rows at {len(q)} points: {time.perf_counter() - t:.3f} s")
print(f"mean w = {w.mean():.5f} mm, 95th percentile = {np.quantile(w, 0.95):.5f} mm, "
      f"P(w < 0.1 mm) = {(w < 0.1).mean():.4f}")

# The same question answered by the engine's adaptive Monte Carlo (GUM S1 §7.9).
res = gpu_amcs.amcs(model, q_deg=q, delta=0.001)
print(res)
print("coverage interval (mm):", res.coverage_interval)
doc = res.to_dict()  # the command line's --json document
print("R(0.1 mm) =", doc["result"]["reliability"][0]["r"])

# A tool point (tracker target) with a spread: the model file's tool_sigma (mm, flange frame;
# docs/METHOD.md §14). Its draws vary the last three of the 33 columns; 30-column rows keep the
# tool at the model's value, so the two show what the tool's spread adds to w.
text = model.to_toml().replace("\ntool = [", "\ntool_sigma = [0.004, 0.002, 0.006]\ntool = [", 1)
tooled = gpu_amcs.Model.from_toml(text)
print("uncertain tool inputs:", [tooled.param_names[i] for i in tooled.free if i >= 30])
X = tooled.draws(100_000, seed=7)  # N × 33, the run's own draws
w_tool, w_fixed = tooled.max_error(X, q), tooled.max_error(X[:, :30], q)
print(f"mean w with the tool's spread {w_tool.mean():.5f} mm, with the tool fixed "
      f"{w_fixed.mean():.5f} mm")
