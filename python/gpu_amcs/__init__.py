"""gpu_amcs: positioning-accuracy reliability of calibrated 6R robots by adaptive Monte Carlo.

The engine of the ``gpu-amcs`` command line (Rust; rayon CPU and wgpu GPU evaluators) for
NumPy, OpenTURNS and SALib users:

* ``Model.preset("tx60")``, ``Model.from_file(path)``, ``Model.from_urdf(path)``,
  ``Model.from_toml(text)``; ``model.params``, ``model.sigma``, ``model.covariance`` (mm, deg).
* ``model.fk(q_deg)`` -> (m, 3) tool positions, mm.
* ``model.max_error(params, q_deg, ...)`` -> (N,) maximum point errors of caller-chosen
  parameter rows (or (N, m) with ``per_point=True``), without the GIL.
* ``model.draws(n, seed=...)`` -> the parameter draws a run evaluates.
* ``mcs(...)``, ``amcs(...)`` -> ``RunResult``; ``.to_dict()`` is the command line's JSON.

Errors are ``ValueError`` with the command line's one-line message, naming the argument.
"""

from ._gpu_amcs import (  # noqa: F401
    Model,
    RunResult,
    __version__,
    adapters,
    amcs,
    mcs,
    presets,
)

__all__ = ["Model", "RunResult", "adapters", "amcs", "mcs", "presets", "__version__"]
