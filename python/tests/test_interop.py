"""pandas, SALib and OpenTURNS: DataFrames equal to the command line's CSV files, SALib's
problem dict from the model's σ, an OpenTURNS function equal to max_error. Each test skips,
saying why, when its optional package is missing (CI installs them all)."""

import builtins
import io

import numpy as np
import pytest

import gpu_amcs
from conftest import with_tool_sigma


def read_csv(pd, text):
    """pandas' exact (round-trip) float parsing: an option before pandas 3, the default since."""
    kw = {} if int(pd.__version__.split(".")[0]) >= 3 else {"float_precision": "round_trip"}
    return pd.read_csv(io.StringIO(text), **kw)


def points(model, n=6, seed=4):
    rng = np.random.default_rng(seed)
    return rng.uniform(0.5 * model.limits[:, 0], 0.5 * model.limits[:, 1], size=(n, 6))


def test_run_to_pandas_equals_the_cli_csv(cli, tmp_path):
    pd = pytest.importorskip("pandas", reason="pandas is not installed (pip install pandas)")
    csv = tmp_path / "csv"
    r = cli("--points", 6, "--delta", 0.02, "--backend", "cpu", "--csv", csv, "--quiet")
    assert r.returncode == 0, r.stderr
    res = gpu_amcs.amcs(points=6, delta=0.02, backend="cpu")
    for table in ["reliability", "cdf", "pdf", "trace"]:
        assert res.to_csv(table) == (csv / f"{table}.csv").read_text()
        want = read_csv(pd, (csv / f"{table}.csv").read_text())
        pd.testing.assert_frame_equal(res.to_pandas(table), want)
    rel = res.to_pandas()
    assert list(rel.columns) == ["threshold_mm", "reliability", "ci_low", "ci_high"]
    assert rel["reliability"].tolist() == [x["r"] for x in res.to_dict()["result"]["reliability"]]
    values = res.to_pandas("values")
    assert list(values.columns) == ["w_mm"] and len(values) == res.draws
    np.testing.assert_array_equal(values["w_mm"].to_numpy(), res.values)
    with pytest.raises(ValueError, match="table: unknown table 'cfd'"):
        res.to_pandas("cfd")


def test_analysis_frames(cli, tmp_path):
    pd = pytest.importorskip("pandas", reason="pandas is not installed (pip install pandas)")
    sens = gpu_amcs.sensitivity(points=3, draws=128, backend="cpu")
    df = sens.to_pandas()
    w_inputs = df[(df["quantity"] == "w") & (df["level"] == "input")]
    assert w_inputs["name"].tolist() == [n for n, _ in sens.first_order]
    assert w_inputs["first_order"].tolist() == [v for _, v in sens.first_order]
    tail = gpu_amcs.tail(points=3, threshold=[0.1, 0.12], max_evaluations=20000, backend="cpu")
    assert tail.to_pandas()["p_f"].tolist() == tail.p_f
    m = gpu_amcs.map(plane="xy", at=200, cells=[3, 3], draws=100, backend="cpu")
    mf = m.to_pandas()
    assert len(mf) == m.cells == 9 and int(mf["reachable"].sum()) == m.reached
    assert isinstance(mf, pd.DataFrame)


def test_to_pandas_without_pandas_is_a_clear_import_error(monkeypatch):
    real = builtins.__import__

    def no_pandas(name, *args, **kwargs):
        if name == "pandas":
            raise ImportError("No module named 'pandas'")
        return real(name, *args, **kwargs)

    monkeypatch.setattr(builtins, "__import__", no_pandas)
    res = gpu_amcs.mcs(points=3, draws=5000, backend="cpu")
    with pytest.raises(ImportError, match="needs pandas.*pip install pandas"):
        res.to_pandas()


def test_salib_problem_is_the_models_sigma():
    m = gpu_amcs.Model.preset("tx60")
    p = m.salib_problem()
    free = m.free
    assert p["num_vars"] == len(free) == len(p["names"]) == len(p["bounds"]) == len(p["dists"])
    assert p["names"] == [m.param_names[i] for i in free]
    assert p["dists"] == ["norm"] * len(free)
    # SALib's convention for "norm": bounds = [mean, standard deviation].
    np.testing.assert_array_equal([b[0] for b in p["bounds"]], m.params[free])
    np.testing.assert_array_equal([b[1] for b in p["bounds"]], m.sigma[free])
    assert all(s > 0 for _, s in p["bounds"])
    a2 = m.param_names.index("a2")
    chosen = m.salib_problem(inputs=["a2", 0])
    assert chosen["names"] == ["a2", "theta1"]
    assert chosen["bounds"][0] == [m.params[a2], m.sigma[a2]] and m.sigma[a2] > 0
    with pytest.raises(ValueError, match="has no uncertain input"):
        gpu_amcs.Model.preset("ur5e").salib_problem()
    # The tool's spread makes the tool coordinates inputs.
    t = with_tool_sigma(m, [0.01, 0.0, 0.02]).salib_problem()
    assert t["names"][-2:] == ["tool_x", "tool_z"]
    assert t["bounds"][-1] == [m.params[32], 0.02]
    assert m.sigma[30] == 0  # the TX60's tool point is exactly known
    with pytest.raises(ValueError, match="tool_x have σ = 0"):
        m.salib_problem(inputs=["theta1", "tool_x"])


def test_salib_problem_refuses_correlated_inputs():
    m = gpu_amcs.Model.preset("tx60")
    s = m.sigma[:30]
    cov = np.diag(s**2)
    cov[0, 1] = cov[1, 0] = 0.5 * s[0] * s[1]
    corr = with_tool_sigma(m, [0.0, 0.0, 0.0], covariance=cov)
    with pytest.raises(ValueError, match="correlated"):
        corr.salib_problem()
    # A covariance without correlation among the chosen inputs is fine.
    assert corr.salib_problem(inputs=["a2", "d3"])["num_vars"] == 2


def test_salib_samples_the_models_distribution():
    pytest.importorskip("SALib", reason="SALib is not installed (pip install SALib)")
    from SALib.analyze import sobol as sobol_analyze
    from SALib.sample import sobol as sobol_sample

    m = gpu_amcs.Model.preset("tx60")
    p = m.salib_problem()
    X = sobol_sample.sample(p, 2**10, calc_second_order=False, seed=1)
    assert X.shape == (2**10 * (p["num_vars"] + 2), p["num_vars"])
    mean, sd = np.array(p["bounds"]).T
    np.testing.assert_allclose(X.mean(axis=0), mean, atol=0.05 * sd.max())
    np.testing.assert_allclose(X.std(axis=0), sd, rtol=0.05)
    q = points(m)
    Y = m.max_error(X, q, columns=p["names"])
    assert Y.shape == (len(X),) and np.all(Y > 0)
    Si = sobol_analyze.analyze(p, Y, calc_second_order=False, seed=1)
    assert len(Si["ST"]) == p["num_vars"] and np.nansum(Si["ST"]) > 0.5


def test_openturns_function_is_max_error():
    ot = pytest.importorskip("openturns", reason="openturns is not installed "
                             "(pip install openturns)")
    m = gpu_amcs.Model.preset("tx60")
    q = points(m, n=5)
    f = m.openturns_function(q, backend="cpu")
    names = [m.param_names[i] for i in m.free]
    assert isinstance(f, ot.Function)
    assert f.getInputDimension() == len(names) and f.getOutputDimension() == 1
    assert list(f.getInputDescription()) == names
    assert list(f.getOutputDescription()) == ["w"]
    rows = m.draws(300, seed=3)[:, m.free]
    want = m.max_error(rows, q, columns=names, backend="cpu")
    got = np.array(f(ot.Sample(rows))).ravel()
    np.testing.assert_array_equal(got, want)
    assert f(ot.Point(rows[7]))[0] == want[7]
    # At the model's own values the calibrated reference gives w = 0.
    assert f(ot.Point(m.params[m.free]))[0] == pytest.approx(0.0, abs=1e-9)
    # Chosen columns and the nominal reference go to max_error.
    g = m.openturns_function(q, columns=["theta1", 3], reference="nominal", backend="cpu")
    rows2 = m.draws(50, seed=4)[:, [0, 3]]
    np.testing.assert_array_equal(
        np.array(g(ot.Sample(rows2))).ravel(),
        m.max_error(rows2, q, columns=[0, 3], reference="nominal", backend="cpu"))
    with pytest.raises(ValueError, match="per_point"):
        m.openturns_function(q, per_point=True)
    with pytest.raises(ValueError, match="has no uncertain input"):
        gpu_amcs.Model.preset("ur5e").openturns_function(q)


def test_openturns_function_in_a_reliability_analysis():
    ot = pytest.importorskip("openturns", reason="openturns is not installed "
                             "(pip install openturns)")
    m = gpu_amcs.Model.preset("tx60")
    p = m.salib_problem()
    q = points(m, n=8)
    f = m.openturns_function(q, backend="cpu")
    dist = ot.JointDistribution([ot.Normal(mu, s) for mu, s in p["bounds"]])
    Y = f(dist.getSample(2000))
    w = np.array(Y).ravel()
    assert w.shape == (2000,) and np.all(w > 0)
    # The same spread as the run's own draws: the mean of w agrees with mcs's estimate.
    res = gpu_amcs.mcs(m, q_deg=q, draws=20000, backend="cpu")
    assert abs(w.mean() - res.estimate) < 0.1 * res.estimate
