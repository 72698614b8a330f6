"""gpu_amcs: positioning-accuracy reliability of calibrated 6R robots by adaptive Monte Carlo.

The engine of the ``gpu-amcs`` command line (Rust; rayon CPU and wgpu GPU evaluators) for
NumPy, OpenTURNS and SALib users:

* ``Model.preset("tx60")``, ``Model.from_file(path)``, ``Model.from_urdf(path)``,
  ``Model.from_toml(text)``; ``model.params``, ``model.sigma``, ``model.covariance`` (mm, deg)
  over the ``N_UNCERTAIN`` = 33 uncertain inputs: the 30 MDH parameters (theta1 … beta6), then
  the tool point's x, y, z (tool_x, tool_y, tool_z; mm, flange frame).
* ``model.fk(q_deg)`` -> (m, 3) tool positions, mm.
* ``model.max_error(params, q_deg, ...)`` -> (N,) maximum point errors of caller-chosen
  input rows (N × 33; N × 30 = the parameters with the tool at the model's tool; or the
  inputs named by ``columns``), or (N, m) with ``per_point=True``, without the GIL.
* ``model.draws(n, seed=...)`` -> the input draws (N × 33) a run evaluates.
* ``mcs(...)``, ``amcs(...)`` -> ``RunResult``; ``.to_dict()`` is the command line's JSON.

Errors are ``ValueError`` with the command line's one-line message, naming the argument.
"""

from ._gpu_amcs import (  # noqa: F401
    N_PARAMS,
    N_UNCERTAIN,
    Model,
    RunResult,
    __version__,
    adapters,
    amcs,
    mcs,
    presets,
)

__all__ = ["Model", "RunResult", "adapters", "amcs", "mcs", "presets", "N_PARAMS", "N_UNCERTAIN",
           "__version__"]
