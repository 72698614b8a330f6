"""Signatures as help() and inspect show them, the type stubs shipped with the package, and the
scalar and one-configuration forms NumPy users pass (issue 34)."""

import importlib.resources
import inspect
import pydoc

import numpy as np
import pytest

import gpu_amcs
from conftest import without_timing

FUNCTIONS = [gpu_amcs.mcs, gpu_amcs.amcs, gpu_amcs.compare, gpu_amcs.sensitivity, gpu_amcs.tail,
             gpu_amcs.map, gpu_amcs.plan, gpu_amcs.identify, gpu_amcs.validate,
             gpu_amcs.adapters, gpu_amcs.presets]
CLASSES = [gpu_amcs.Model, gpu_amcs.RunResult, gpu_amcs.CompareResult, gpu_amcs.SensitivityResult,
           gpu_amcs.TailResult,
           gpu_amcs.MapResult, gpu_amcs.PlanResult, gpu_amcs.IdentifyResult,
           gpu_amcs.ValidationResult]
# The keywords every analysis on test points shares (the command line's problem flags).
PROBLEM = dict(preset=None, points=50, q_deg=None, points_file=None, points_seed=1,
               box_center=None, box_size=None, seed=2025, reference="calibrated", nominal=None,
               backend="auto", adapter=None, memory_limit=None, frame="measurement",
               discrepancy=True, payload_kg=None, payload_sigma_kg=0.0, payload_com=None,
               sides=None)
DEFAULT_THRESHOLDS = (0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8)


def callables():
    yield from FUNCTIONS
    for cls in CLASSES:
        for name, member in vars(cls).items():
            if callable(member) and (not name.startswith("_") or name == "__repr__"):
                yield getattr(cls, name)


def test_signatures_show_the_defaults_not_ellipsis():
    for f in callables():
        sig = inspect.signature(f)
        for p in sig.parameters.values():
            assert p.default is not Ellipsis, f"{f.__qualname__}({p.name}=...)"


def test_help_shows_real_defaults():
    text = pydoc.render_doc(gpu_amcs.amcs, renderer=pydoc.plaintext)
    assert "Ellipsis" not in text
    assert "batch=10000" in text and "max_draws=10000000" in text
    assert "interval='shortest'" in text and "backend='auto'" in text
    sig = inspect.signature(gpu_amcs.amcs)
    assert sig.parameters["delta"].default is None  # 0.01 unless ndig is given
    assert sig.parameters["thresholds"].default == DEFAULT_THRESHOLDS
    for name, default in PROBLEM.items():
        for f in (gpu_amcs.mcs, gpu_amcs.amcs, gpu_amcs.compare, gpu_amcs.sensitivity,
                  gpu_amcs.tail, gpu_amcs.plan):
            assert inspect.signature(f).parameters[name].default == default, (f, name)
    assert inspect.signature(gpu_amcs.mcs).parameters["draws"].default == 1_000_000
    assert inspect.signature(gpu_amcs.sensitivity).parameters["draws"].default == 8192
    assert inspect.signature(gpu_amcs.tail).parameters["method"].default == "subset"
    assert inspect.signature(gpu_amcs.map).parameters["thresholds"].default == DEFAULT_THRESHOLDS
    assert inspect.signature(gpu_amcs.plan).parameters["threshold"].default == (0.02, 0.03, 0.05)
    ident = inspect.signature(gpu_amcs.identify).parameters
    assert ident["preset"].default == "tx60" and ident["fit"].default == "commanded"
    assert ident["fix"].default is None and ident["uncertainty"].default == "linearised"


def test_signature_defaults_are_the_ones_used():
    """The defaults help() shows are what a call without the keyword gets."""
    q = np.zeros((1, 6))
    res = gpu_amcs.mcs(q_deg=q, draws=2000, backend="cpu").to_dict()
    shown = inspect.signature(gpu_amcs.mcs).parameters
    assert tuple(r["threshold"] for r in res["result"]["reliability"]) == \
        shown["thresholds"].default
    assert res["seed"] == shown["seed"].default
    # The preset identify defaults to is the one every analysis takes without a model.
    default = inspect.signature(gpu_amcs.identify).parameters["preset"].default
    assert res["model"] == gpu_amcs.Model.preset(default).name


class NotAValue:
    """A value no keyword takes: a call with it fails before any work."""


@pytest.mark.parametrize("f", FUNCTIONS[:9], ids=lambda f: f.__name__)
def test_every_keyword_shown_is_taken(f):
    """Each name the signature shows is a keyword the function takes (no drift between the
    text signature and the Rust one): an unknown keyword is a TypeError naming it."""
    with pytest.raises(TypeError, match="unexpected keyword argument 'no_such_keyword'"):
        f(no_such_keyword=1)
    for p in inspect.signature(f).parameters.values():
        if p.kind is not p.KEYWORD_ONLY:
            continue
        with pytest.raises((TypeError, ValueError)) as e:
            f(**{p.name: NotAValue()})
        assert "unexpected keyword" not in str(e.value), (f.__name__, p.name)


def test_stubs_and_py_typed_are_installed():
    pkg = importlib.resources.files("gpu_amcs")
    assert (pkg / "py.typed").is_file()
    stub = (pkg / "_gpu_amcs.pyi").read_text()
    for name in gpu_amcs.__all__:
        assert name in stub, name


def result(run):
    """A run's result document without its timing."""
    return without_timing(run.to_dict()["result"])


def test_a_scalar_threshold_is_one_threshold():
    q = np.zeros((2, 6))
    kw = dict(q_deg=q, backend="cpu")
    for f, extra in ((gpu_amcs.mcs, dict(draws=2000)),
                     (gpu_amcs.amcs, dict(batch=2000, max_draws=4000, delta=1.0))):
        listed = result(f(thresholds=[0.3], **kw, **extra))
        assert [r["threshold"] for r in listed["reliability"]] == [0.3]
        # A number, a NumPy scalar, a 0-D and a 1-D array are the same threshold.
        for one in (0.3, np.float64(0.3), np.array(0.3), np.array([0.3])):
            assert result(f(thresholds=one, **kw, **extra)) == listed, one
    s1 = gpu_amcs.sensitivity(thresholds=0.3, draws=64, bootstrap=100, **kw)
    s2 = gpu_amcs.sensitivity(thresholds=[0.3], draws=64, bootstrap=100, **kw)
    assert without_timing(s1.to_dict()) == without_timing(s2.to_dict())
    m1 = gpu_amcs.map(thresholds=0.3, cells=[2, 2, 2], draws=100, backend="cpu")
    m2 = gpu_amcs.map(thresholds=np.array([0.3]), cells=[2, 2, 2], draws=100, backend="cpu")
    assert m1.reliability == m2.reliability and len(m1.reliability) == 1
    p = gpu_amcs.plan(threshold=0.03, q_deg=q, poses=12, candidates=200, draws=200,
                      backend="cpu")
    assert [t for t, _ in p.reliability] == [0.03]
    with pytest.raises(ValueError, match=r"^thresholds: expected a number or a 1-D sequence"):
        gpu_amcs.mcs(thresholds="0.3", **kw, draws=2000)
    with pytest.raises(ValueError, match=r"^thresholds: expected a number or a 1-D sequence"):
        gpu_amcs.mcs(thresholds=[[0.3]], **kw, draws=2000)


def test_one_configuration_may_be_one_dimensional():
    model = gpu_amcs.Model.preset("tx60")
    q = np.array([10.0, -20.0, 90.0, 5.0, 30.0, -15.0])
    p = model.fk(q)
    assert p.shape == (3,)
    np.testing.assert_array_equal(p, model.fk(q[None, :])[0])
    np.testing.assert_array_equal(model.fk(list(q)), p)
    X = model.draws(50, seed=3)
    np.testing.assert_array_equal(model.max_error(X, q, backend="cpu"),
                                  model.max_error(X, q[None, :], backend="cpu"))
    a = gpu_amcs.mcs(q_deg=q, draws=2000, backend="cpu").to_dict()
    b = gpu_amcs.mcs(q_deg=q[None, :], draws=2000, backend="cpu").to_dict()
    assert without_timing(a) == without_timing(b) and a["points"] == 1
    with pytest.raises(ValueError, match=r"^q_deg: expected .*\(6,\).*got shape \(5,\)"):
        model.fk(q[:5])
