"""Bridges to pandas, SALib and OpenTURNS, behind the methods of the extension's classes
(``RunResult.to_pandas``, ``Model.salib_problem``, ``Model.openturns_function``, …). Each
optional package is imported only when asked for, with an ImportError that says how to install
it when it is missing."""

import io

import numpy as np


def _require(module, package):
    try:
        return __import__(module)
    except ImportError as e:
        raise ImportError(
            f"this needs {package}, which is not installed: pip install {package}"
        ) from e


def frame(csv_text):
    """A CSV document (the command line's ``--csv`` file) as a pandas DataFrame, numbers parsed
    exactly (round trip)."""
    pd = _require("pandas", "pandas")
    # Exact parsing is the default from pandas 3 on, and an option before.
    exact = {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}
    return pd.read_csv(io.StringIO(csv_text), **exact)


def values_frame(values):
    """The draws' maximum point errors as a one-column DataFrame ``w_mm``."""
    pd = _require("pandas", "pandas")
    return pd.DataFrame({"w_mm": np.asarray(values)})


def _independent(model, inputs):
    cov = model.covariance
    if cov is None:
        return
    sub = cov[np.ix_(inputs, inputs)]
    if np.any(sub - np.diag(np.diag(sub))):
        raise ValueError(
            f"model {model.name}: its inputs are correlated (a covariance matrix), and a SALib "
            "problem describes independent inputs; use gpu_amcs.sensitivity (Cholesky "
            "innovations) or Model.draws for the correlated distribution"
        )


def _input_indices(model, inputs):
    names = list(model.param_names)
    if inputs is None:
        if not model.free:
            raise ValueError(f"model {model.name} has no uncertain input (every σ is 0)")
        return list(model.free)
    out = []
    for c in inputs:
        if isinstance(c, str):
            if c not in names:
                raise ValueError(f"inputs: unknown input '{c}' (expected theta1 … "
                                 f"beta{model.joints}, tool_x, tool_y or tool_z)")
            out.append(names.index(c))
        else:
            out.append(int(c))
    return out


def salib_problem(model, inputs=None):
    """SALib's problem dict of the model's uncertain inputs (``model.free`` unless ``inputs``
    names others): each an independent normal with SALib's convention for ``"norm"``,
    ``bounds = [mean, standard deviation]``, in the model file's units (mm, degrees), named as
    ``model.param_names``. Rows sampled from it go straight into
    ``model.max_error(X, q, columns=problem["names"])``."""
    idx = _input_indices(model, inputs)
    sigma = model.sigma
    zero = [model.param_names[i] for i in idx if not sigma[i] > 0]
    if zero:
        raise ValueError(f"inputs: {', '.join(zero)} have σ = 0 (exactly known): "
                         "a normal input needs a spread")
    _independent(model, idx)
    params = model.params
    return {
        "num_vars": len(idx),
        "names": [model.param_names[i] for i in idx],
        "bounds": [[float(params[i]), float(sigma[i])] for i in idx],
        "dists": ["norm"] * len(idx),
    }


def openturns_function(model, q_deg, columns=None, **max_error_kwargs):
    """An ``ot.Function`` of the model's uncertain inputs (``columns``: names or indices; the
    free inputs by default), values in the model file's units, whose output ``w`` is
    ``model.max_error`` of the input rows at the configurations ``q_deg``. Whole samples are
    evaluated in one call (``func_sample``); the keywords (``reference``, ``nominal``,
    ``backend``, ``offsets``) go to ``max_error``."""
    ot = _require("openturns", "openturns")
    names = [model.param_names[i] for i in _input_indices(model, columns)]
    q = np.array(q_deg, dtype=float)
    if "per_point" in max_error_kwargs:
        raise ValueError("per_point: an OpenTURNS function of w has one output")

    def func_sample(x):
        w = model.max_error(np.asarray(x, dtype=float), q, columns=names, **max_error_kwargs)
        return np.asarray(w).reshape(-1, 1)

    def func(x):
        return [float(func_sample([x])[0, 0])]

    f = ot.PythonFunction(len(names), 1, func=func, func_sample=func_sample)
    f.setInputDescription(names)
    f.setOutputDescription(["w"])
    return f
