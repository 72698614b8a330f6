"""SALib: Sobol' indices of the maximum point error with respect to the free inputs (the MDH
parameters with nonzero σ, and the tool point's x, y, z when the model gives them a spread).

SALib samples the parameter matrix (Saltelli's scheme, `SALib.sample.sobol.sample`, the
successor of the deprecated `saltelli.sample`), `max_error` evaluates every row at once, and
`sobol.analyze` estimates first-order and total indices.

    pip install SALib && python python/examples/salib_sobol.py
"""

import time

import numpy as np
from SALib.analyze import sobol as sobol_analyze
from SALib.sample import sobol as sobol_sample

import gpu_amcs

model = gpu_amcs.Model.preset("tx60")
free = model.free  # inputs with nonzero σ (indices of the 33; 30–32 are the tool)
names = [model.param_names[i] for i in free]
rng = np.random.default_rng(1)
q = rng.uniform(0.5 * model.limits[:, 0], 0.5 * model.limits[:, 1], size=(50, 6))

# Independent normals N(value, σ) per free input (SALib's "norm": bounds = [mean, sd]).
problem = {
    "num_vars": len(free),
    "names": names,
    "bounds": [[model.params[i], model.sigma[i]] for i in free],
    "dists": ["norm"] * len(free),
}
X = sobol_sample.sample(problem, 2**12, calc_second_order=False, seed=1)
t = time.perf_counter()
Y = model.max_error(X, q, columns=free)  # the other inputs stay at the model's values
print(f"{len(X)} rows × {len(q)} points evaluated in {time.perf_counter() - t:.3f} s")
Si = sobol_analyze.analyze(problem, Y, calc_second_order=False, seed=1)
order = np.argsort(Si["ST"])[::-1]
print(f"{'parameter':>10} {'S1':>8} {'ST':>8}")
for k in order[:8]:
    print(f"{names[k]:>10} {Si['S1'][k]:8.3f} {Si['ST'][k]:8.3f}")
