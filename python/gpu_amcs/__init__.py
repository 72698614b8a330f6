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
* ``mcs(...)``, ``amcs(...)`` -> ``RunResult``; ``sensitivity(...)`` -> ``SensitivityResult``,
  ``tail(...)`` -> ``TailResult``, ``map(...)`` -> ``MapResult``: keyword arguments spelled as
  the command line's flags, with its defaults; ``.to_dict()`` / ``.to_json()`` are the document
  ``--json`` writes, ``.to_text()`` the table it prints, ``.to_csv()`` / ``.to_pandas()`` the
  CSV ``--csv`` writes (pandas needed for the DataFrame).
* ``plan(...)`` -> ``PlanResult``: the poses to measure for a calibration (``.design``,
  ``.design_csv()`` as ``gpu-amcs plan --out`` writes it) and the reliability they are predicted
  to give at the task points (``.reliability``, ``.to_dict()`` = the ``--json`` document).
* ``identify(sweeps, ...)`` -> ``IdentifyResult``: ``.model`` (``.to_toml()`` is the file
  ``gpu-amcs identify --out`` writes), ``.warnings``, ``.to_text()``.
* ``model.salib_problem()`` -> SALib's problem dict (independent normals, ``bounds`` = [mean,
  sd]); ``model.openturns_function(q_deg)`` -> an ``ot.Function`` of the inputs evaluating whole
  samples through ``max_error``.

Errors are ``ValueError`` with the command line's one-line message, naming the argument.
"""

from ._gpu_amcs import (  # noqa: F401
    N_PARAMS,
    N_UNCERTAIN,
    IdentifyResult,
    MapResult,
    Model,
    PlanResult,
    RunResult,
    SensitivityResult,
    TailResult,
    __version__,
    adapters,
    amcs,
    identify,
    map,  # noqa: A004 (gpu_amcs.map, the command line's `map`)
    mcs,
    plan,
    presets,
    sensitivity,
    tail,
)

__all__ = ["Model", "RunResult", "SensitivityResult", "TailResult", "MapResult",
           "IdentifyResult", "PlanResult", "adapters", "amcs", "mcs", "sensitivity", "tail",
           "map", "plan",
           "identify", "presets", "N_PARAMS", "N_UNCERTAIN", "__version__"]
