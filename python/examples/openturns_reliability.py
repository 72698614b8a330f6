"""OpenTURNS: probability that the maximum point error exceeds a threshold, by Monte Carlo and
by subset sampling, with the engine as the model (`ot.PythonFunction(..., func_sample=...)`).
The same Monte Carlo through a pure-Python (vectorised NumPy) model is timed for comparison.

    pip install openturns && python python/examples/openturns_reliability.py [draws, default 20000]
"""

import sys
import time

import numpy as np
import openturns as ot

import gpu_amcs
from gpu_amcs import numpy_fk

model = gpu_amcs.Model.preset("tx60")
free = model.free
rng = np.random.default_rng(1)
q = rng.uniform(0.5 * model.limits[:, 0], 0.5 * model.limits[:, 1], size=(50, 6))
threshold = 0.15  # mm: failure is w > 0.15 mm
draws = int(sys.argv[1]) if len(sys.argv) > 1 else 20_000

# Input: independent normals N(value, σ) of the free inputs (mm, degrees; the tool's x, y, z
# are among them when the model file gives a tool_sigma).
X = ot.JointDistribution([ot.Normal(model.params[i], model.sigma[i]) for i in free])
X.setDescription([model.param_names[i] for i in free])


def engine(sample):
    """Rows of free input values -> w (mm), all rows in one call to the engine."""
    return model.max_error(np.asarray(sample), q, columns=free)[:, None]


reference = numpy_fk.fk(model.params[None, :], q)[0]  # the model's own positions


def pure_python(sample):
    """The same model in NumPy (vectorised 4×4 products), for the timing comparison."""
    full = np.tile(model.params, (len(sample), 1))
    full[:, free] = np.asarray(sample)
    return numpy_fk.max_error(full, q, reference)[:, None]


def probability(func, n, seed=1):
    """P(w > threshold) by crude Monte Carlo in blocks of 10 000 (OpenTURNS calls func_sample
    once per block)."""
    ot.RandomGenerator.SetSeed(seed)
    g = ot.PythonFunction(len(free), 1, func_sample=func)
    event = ot.ThresholdEvent(ot.CompositeRandomVector(g, ot.RandomVector(X)), ot.Greater(),
                              threshold)
    algo = ot.ProbabilitySimulationAlgorithm(event, ot.MonteCarloExperiment())
    algo.setBlockSize(10_000)
    algo.setMaximumOuterSampling(max(1, n // 10_000))
    algo.setMaximumCoefficientOfVariation(0.0)  # run all the draws asked for
    t = time.perf_counter()
    algo.run()
    r = algo.getResult()
    return r.getProbabilityEstimate(), r.getCoefficientOfVariation(), time.perf_counter() - t


p, cov, t_engine = probability(engine, draws)
print(f"Monte Carlo, engine:       P(w > {threshold} mm) = {p:.5f} (c.o.v. {cov:.3f}), "
      f"{draws} draws in {t_engine:.2f} s")
p2, cov2, t_py = probability(pure_python, draws)
print(f"Monte Carlo, NumPy model:  P(w > {threshold} mm) = {p2:.5f} (c.o.v. {cov2:.3f}), "
      f"{draws} draws in {t_py:.2f} s ({t_py / t_engine:.0f}x the engine's time)")
# Same draws, same model: only a draw within rounding of the threshold could count differently.
assert abs(p - p2) * draws <= 2, (p, p2)

# A rarer event by subset sampling (Au & Beck 2001), still through the engine.
ot.RandomGenerator.SetSeed(2)
g = ot.PythonFunction(len(free), 1, func_sample=engine)
rare = 0.3
event = ot.ThresholdEvent(ot.CompositeRandomVector(g, ot.RandomVector(X)), ot.Greater(), rare)
ss = ot.SubsetSampling(event)
ss.setBlockSize(10_000)
ss.setMaximumOuterSampling(1)
t = time.perf_counter()
ss.run()
r = ss.getResult()
print(f"Subset sampling, engine:   P(w > {rare} mm) = {r.getProbabilityEstimate():.3e} "
      f"(c.o.v. {r.getCoefficientOfVariation():.2f}), {ss.getStepsNumber()} levels, "
      f"{time.perf_counter() - t:.2f} s")
