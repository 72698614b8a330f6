"""gpu_amcs: positioning-accuracy reliability of calibrated serial robots (4 to 7 revolute
joints, such as the six-axis TX60 or the seven-axis KUKA LBR iiwa) by adaptive Monte Carlo.

The engine of the ``gpu-amcs`` command line (Rust; rayon CPU and wgpu GPU evaluators) for
NumPy, OpenTURNS and SALib users:

* ``Model.preset("tx60")``, ``Model.from_file(path)``, ``Model.from_urdf(path)``,
  ``Model.from_toml(text)``; ``model.joints`` (n); ``model.params``, ``model.sigma``,
  ``model.covariance`` (mm, deg) over the model's 5n + 3 uncertain inputs: the 5n MDH
  parameters (theta1 … beta<n>), then the tool point's x, y, z (tool_x, tool_y, tool_z; mm,
  flange frame). ``N_PARAMS`` = 30 and ``N_UNCERTAIN`` = 33 are the six-joint counts; a
  seven-joint model has 35 and 38 (``len(model.param_names)``). Every shape below is the
  model's own: n columns of joint angles, 5n + 3 (or 5n) columns of inputs.
* ``model.fk(q_deg)`` -> (m, 3) tool positions, mm, for q_deg of shape (m, n); (3,) for one
  configuration of n angles (every ``q_deg`` takes a 1-D configuration as one row).
* ``model.max_error(params, q_deg, ...)`` -> (N,) maximum point errors of caller-chosen
  input rows (N × (5n + 3), N × 33 for six joints; N × 5n = the parameters with the tool at
  the model's tool; or the inputs named by ``columns``), or (N, m) with ``per_point=True``,
  without the GIL.
* ``model.draws(n, seed=...)`` -> the input draws (N × (5n + 3)) a run evaluates.
* ``mcs(...)``, ``amcs(...)`` -> ``RunResult``; ``sensitivity(...)`` -> ``SensitivityResult``,
  ``tail(...)`` -> ``TailResult``, ``map(...)`` -> ``MapResult``: keyword arguments spelled as
  the command line's flags, with its defaults; ``.to_dict()`` / ``.to_json()`` are the document
  ``--json`` writes, ``.to_text()`` the table it prints, ``.to_csv()`` / ``.to_pandas()`` the
  CSV ``--csv`` writes (pandas needed for the DataFrame).
* ``compare(...)`` -> ``CompareResult``: MCS against AMCS at each of ``deltas`` as ``gpu-amcs
  compare`` runs them (``.amcs``: δ, draws and MRE % of each AMCS run; ``.to_markdown()`` the
  file ``--markdown`` writes).
* ``plan(...)`` -> ``PlanResult``: the poses to measure for a calibration (``.design``, n
  angles a pose; ``.design_csv()`` as ``gpu-amcs plan --out`` writes it) and the reliability
  they are predicted to give at the task points (``.reliability``, ``.to_dict()`` = the
  ``--json`` document).
* ``identify(sweeps, ...)`` -> ``IdentifyResult``: ``.model`` (``.to_toml()`` is the file
  ``gpu-amcs identify --out`` writes, ``[provenance]`` included), ``.warnings``, ``.to_text()``.
* ``validate(model, measured, nominal=True, ...)`` -> ``ValidationResult``: the positioning
  accuracy as ``gpu-amcs validate`` computes it (the model's own nominal from its
  ``[provenance]``, the nominal geometry with its own placement on tracker data, no silent
  change of frame); ``.to_text()``, ``.to_dict()`` / ``.to_json()`` (the ``--json`` document).
* ``model.salib_problem()`` -> SALib's problem dict (independent normals, ``bounds`` = [mean,
  sd]); ``model.openturns_function(q_deg)`` -> an ``ot.Function`` of the inputs evaluating whole
  samples through ``max_error``.

``thresholds``/``threshold`` take a number or a sequence. ``help()`` shows every default; the
type stubs (``_gpu_amcs.pyi``, ``py.typed``) serve mypy, pyright and editors.

Errors are ``ValueError`` with the command line's one-line message, naming the argument.
"""

from ._gpu_amcs import (  # noqa: F401
    N_PARAMS,
    N_UNCERTAIN,
    CompareResult,
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
    compare,
    identify,
    map,  # noqa: A004 (gpu_amcs.map, the command line's `map`)
    mcs,
    plan,
    presets,
    sensitivity,
    tail,
    validate,
    ValidationResult,
)

__all__ = ["Model", "RunResult", "CompareResult", "SensitivityResult", "TailResult", "MapResult",
           "IdentifyResult", "PlanResult", "adapters", "amcs", "compare", "mcs", "sensitivity", "tail",
           "map", "plan",
           "identify", "validate", "ValidationResult", "presets", "N_PARAMS", "N_UNCERTAIN",
           "__version__"]
