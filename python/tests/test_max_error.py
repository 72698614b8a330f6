"""max_error and fk against an independent NumPy forward kinematics; input handling."""

import os
import threading
import time

import numpy as np
import pytest

import gpu_amcs
from conftest import with_tool_sigma
from gpu_amcs.numpy_fk import fk as fk_numpy
from gpu_amcs.numpy_fk import inputs

# Tolerance of the CPU evaluator (f64) against the NumPy matrix-product FK: both evaluate the
# same chain in double precision; the positions are ~1e3 mm and each of the six joints adds a
# few ulps of rounding (1e3 mm × 2.2e-16 × ~100 operations ≈ 2e-11 mm), so 1e-9 mm leaves
# two orders of margin while any wrong parameter, unit or convention shows as ≥ 1e-6 mm.
TOL_MM = 1e-9


@pytest.fixture(scope="module")
def tx60():
    return gpu_amcs.Model.preset("tx60")


@pytest.fixture(scope="module")
def tooled(tx60):
    """The TX60 with an uncertain tool point (σ of 4, 2, 6 µm: the run-to-run spread the
    identification gives at the paper's settings, docs/METHOD.md §14)."""
    return with_tool_sigma(tx60, [0.004, 0.002, 0.006])


@pytest.fixture(scope="module")
def q(tx60):
    rng = np.random.default_rng(7)
    lo, hi = tx60.limits[:, 0], tx60.limits[:, 1]
    return rng.uniform(lo * 0.8, hi * 0.8, size=(12, 6))


def rows(model, n, seed=3, scale=3.0):
    """n rows of the 33 inputs around the model's values, a few σ apart (mm, degrees)."""
    rng = np.random.default_rng(seed)
    return model.params + scale * model.sigma * rng.standard_normal((n, gpu_amcs.N_UNCERTAIN))


def correlated_tool(tx60):
    """The TX60 with a 33 × 33 covariance: the parameters' σ², the tool's (4, 2, 6 µm)², and
    tool_x correlated with theta1 (ρ = 0.5)."""
    s = tx60.sigma[:30]
    full = np.diag(np.concatenate([s**2, [0.004**2, 0.002**2, 0.006**2]]))
    full[30, 0] = full[0, 30] = 0.5 * 0.004 * s[0]
    return with_tool_sigma(tx60, [0.004, 0.002, 0.006], covariance=full), full


def test_inputs_are_the_parameters_then_the_tool(tx60, tooled):
    assert gpu_amcs.N_PARAMS == 30 and gpu_amcs.N_UNCERTAIN == 33
    for m in (tx60, tooled):
        assert m.params.shape == (33,) and m.sigma.shape == (33,)
        assert m.param_names[:5] == ["theta1", "d1", "a1", "alpha1", "beta1"]
        assert m.param_names[29] == "beta6"
        assert m.param_names[30:] == ["tool_x", "tool_y", "tool_z"]
        np.testing.assert_array_equal(m.params[30:], m.tool)
    np.testing.assert_array_equal(tooled.params, tx60.params)
    np.testing.assert_array_equal(tx60.sigma[30:], [0, 0, 0])
    np.testing.assert_array_equal(tooled.sigma[30:], [0.004, 0.002, 0.006])
    np.testing.assert_array_equal(tooled.sigma[:30], tx60.sigma[:30])
    assert tooled.free == tx60.free + [30, 31, 32]
    assert all(i < 30 for i in tx60.free)
    assert "free inputs of 33" in repr(tooled)


def test_covariance_covers_the_tool(tx60):
    # A 30 × 30 file matrix (here diagonal, the σ² of the parameters) is extended by the tool's
    # independent variances; a 33 × 33 one is returned as given, with its tool correlations.
    s = tx60.sigma[:30]
    m30 = with_tool_sigma(tx60, [0.004, 0.002, 0.006], covariance=np.diag(s**2))
    c = m30.covariance
    assert c.shape == (33, 33)
    np.testing.assert_allclose(np.diag(c), m30.sigma**2, rtol=1e-12)
    np.testing.assert_allclose(c[30:, 30:], np.diag([0.004, 0.002, 0.006]) ** 2, rtol=1e-12)
    assert np.count_nonzero(c - np.diag(np.diag(c))) == 0
    m33, full = correlated_tool(tx60)
    np.testing.assert_allclose(m33.covariance, full, rtol=1e-12, atol=0)
    assert tx60.covariance is None
    # The blocks each matrix covers, as the model file names them.
    assert m30.covariance_blocks == ["joints"]
    assert m33.covariance_blocks == ["joints", "tool"]
    assert tx60.covariance_blocks is None


def test_fk_matches_numpy(tx60, q):
    want = fk_numpy(tx60.params[None, :], q)[0]
    got = tx60.fk(q)
    assert got.shape == (len(q), 3)
    np.testing.assert_allclose(got, want, rtol=0, atol=TOL_MM)


def test_fk_tx60_flange_at_zero():
    # TX60 flange at q = 0 is (0, 20, 1045) mm (Stäubli TX60 data sheet: 375 + 290 + 310 + 70
    # mm column, 20 mm shoulder offset), a closed form independent of any FK code.
    m = gpu_amcs.Model.from_toml(gpu_amcs.Model.preset("tx60").to_toml())
    np.testing.assert_allclose(
        fk_numpy(inputs(m.params[None, :30], [0, 0, 0]), np.zeros((1, 6)))[0, 0], [0, 20, 1045],
        atol=1e-9)


def test_max_error_equals_numpy_difference(tx60, q):
    p = rows(tx60, 40)
    ref = fk_numpy(tx60.params[None, :], q)[0]
    e = np.linalg.norm(fk_numpy(p, q) - ref, axis=-1)
    np.testing.assert_allclose(tx60.max_error(p, q, backend="cpu"), e.max(axis=1), atol=TOL_MM)
    pp = tx60.max_error(p, q, backend="cpu", per_point=True)
    assert pp.shape == (40, len(q))
    np.testing.assert_allclose(pp, e, atol=TOL_MM)
    # The values are the draws' size, not noise: errors of a few σ are tenths of a mm.
    assert 0.01 < e.max() < 10


def test_max_error_nominal_reference(tx60, q):
    ur = gpu_amcs.Model.preset("ur5e")
    # A TX60 whose parameters moved by a few σ, against the nominal TX60 (its own preset) and
    # against an explicit nominal model; the reference uses the nominal's joint parameters with
    # the analysed model's tool (docs/METHOD.md §3).
    p = rows(tx60, 10, seed=5)
    ref = fk_numpy(tx60.params[None, :], q)[0]
    want = np.linalg.norm(fk_numpy(p, q) - ref, axis=-1).max(axis=1)
    got = tx60.max_error(p, q, reference="nominal", backend="cpu")
    np.testing.assert_allclose(got, want, atol=TOL_MM)
    # An explicit nominal: the TX60's design with its upper arm 3 mm longer (the same robot, as
    # a calibration sees it: flanges millimetres apart).
    other = gpu_amcs.Model.from_toml(tx60.to_toml().replace("a = 290.0", "a = 293.0", 1))
    ref_o = fk_numpy(inputs(other.params[None, :30], tx60.tool), q)[0]
    want_o = np.linalg.norm(fk_numpy(p, q) - ref_o, axis=-1).max(axis=1)
    got_o = tx60.max_error(p, q, reference="nominal", nominal=other, backend="cpu")
    np.testing.assert_allclose(got_o, want_o, atol=TOL_MM)
    assert got_o.min() > 1  # the longer arm is millimetres away
    # Another robot as the nominal is refused, as the command line refuses it.
    qu = np.clip(q, ur.limits[:, 0], ur.limits[:, 1])
    with pytest.raises(ValueError, match="nominal: .*another robot"):
        tx60.max_error(p, qu, reference="nominal", nominal=ur, backend="cpu")


def test_columns_and_offsets_agree_with_full_rows(tx60, q):
    free = tx60.free
    p = rows(tx60, 25, seed=11)
    full = tx60.max_error(p, q, backend="cpu")
    # Only the free columns (the fixed ones sit at the model's values: σ = 0 makes them so).
    np.testing.assert_allclose(tx60.max_error(p[:, free], q, columns=free, backend="cpu"), full,
                               atol=TOL_MM)
    names = [tx60.param_names[i] for i in free]
    np.testing.assert_allclose(tx60.max_error(p[:, free], q, columns=names, backend="cpu"), full,
                               atol=TOL_MM)
    np.testing.assert_allclose(
        tx60.max_error(p - tx60.params, q, offsets=True, backend="cpu"), full, atol=TOL_MM)


def test_max_error_with_tool_columns_equals_numpy(tooled, q):
    """Rows that move the parameters and the tool point: the engine against the NumPy chain
    with each row's own tool point, on the model with an uncertain tool."""
    p = rows(tooled, 40, seed=17)
    # The tool moves by a few σ (µm), as much as the parameters' own effect is small: scale it
    # up to tenths of a mm so a tool ignored or mis-signed would show far above TOL_MM.
    p[:, 30:] = tooled.tool + 50 * tooled.sigma[30:] * np.random.default_rng(4).standard_normal(
        (40, 3))
    ref = fk_numpy(tooled.params[None, :], q)[0]
    e = np.linalg.norm(fk_numpy(p, q) - ref, axis=-1)
    got = tooled.max_error(p, q, backend="cpu", per_point=True)
    np.testing.assert_allclose(got, e, rtol=0, atol=TOL_MM)
    # The tool columns matter: the same rows with the tool at the model's tool differ.
    fixed = tooled.max_error(p[:, :30], q, backend="cpu", per_point=True)
    assert np.abs(fixed - got).max() > 0.05
    # By name and by offset, only the tool columns and a few parameters.
    cols = ["theta2", "a3", "tool_x", "tool_y", "tool_z"]
    idx = [tooled.param_names.index(c) for c in cols]
    sub = np.tile(tooled.params, (40, 1))
    sub[:, idx] = p[:, idx]
    want = np.linalg.norm(fk_numpy(sub, q) - ref, axis=-1).max(axis=1)
    np.testing.assert_allclose(tooled.max_error(p[:, idx], q, columns=cols, backend="cpu"), want,
                               rtol=0, atol=TOL_MM)
    np.testing.assert_allclose(
        tooled.max_error(p[:, idx] - tooled.params[idx], q, columns=idx, offsets=True,
                         backend="cpu"), want, rtol=0, atol=TOL_MM)


def test_thirty_columns_keep_the_tool_at_the_model(tooled, q):
    """A 30-column matrix is the 30 parameters; the tool stays at the model's tool (its σ is
    not sampled: the rows are the caller's)."""
    p = rows(tooled, 25, seed=19)
    at_mean = p.copy()
    at_mean[:, 30:] = tooled.tool
    np.testing.assert_array_equal(tooled.max_error(p[:, :30], q, backend="cpu"),
                                  tooled.max_error(at_mean, q, backend="cpu"))
    np.testing.assert_array_equal(
        tooled.max_error(p[:, :30], q, backend="cpu"),
        tooled.max_error(p[:, :30], q, columns=list(range(30)), backend="cpu"))
    np.testing.assert_array_equal(
        tooled.max_error(p[:, :30] - tooled.params[:30], q, offsets=True, backend="cpu"),
        tooled.max_error(at_mean - tooled.params, q, offsets=True, backend="cpu"))


def test_tool_only_rows_give_the_length_of_the_tool_offset(tooled, q):
    """Rows that move only the tool point by δ (flange frame): every point's error is R_j δ
    for its flange rotation R_j, so e_j = |δ| at every point and w = |δ| (docs/METHOD.md §14's
    known answer). Offsets of a few µm to a mm; the CPU path's rounding is ~1e-13 mm."""
    rng = np.random.default_rng(23)
    delta = rng.standard_normal((30, 3)) * np.logspace(-3, 0, 30)[:, None]
    off = np.zeros((30, 33))
    off[:, 30:] = delta
    length = np.linalg.norm(delta, axis=1)
    e = tooled.max_error(off, q, offsets=True, per_point=True, backend="cpu")
    np.testing.assert_allclose(e, np.broadcast_to(length[:, None], e.shape), rtol=0, atol=TOL_MM)
    w = tooled.max_error(tooled.params + off, q, backend="cpu")
    np.testing.assert_allclose(w, length, rtol=0, atol=TOL_MM)
    w3 = tooled.max_error(delta, q, columns=["tool_x", "tool_y", "tool_z"], offsets=True,
                          backend="cpu")
    np.testing.assert_allclose(w3, length, rtol=0, atol=TOL_MM)


def test_the_mean_row_has_zero_error(tx60, q):
    # Zero up to the evaluator's rounding (its kernel and the reference positions take
    # different f64 operation orders: ~1e-13 mm).
    w = tx60.max_error(np.tile(tx60.params, (3, 1)), q, backend="cpu")
    assert w.shape == (3,) and np.all(w < TOL_MM)
    w30 = tx60.max_error(np.tile(tx60.params[:30], (3, 1)), q, backend="cpu")
    assert w30.shape == (3,) and np.all(w30 < TOL_MM)


def test_dtypes_orders_and_views(tx60, q):
    p = rows(tx60, 30, seed=13)
    want = tx60.max_error(p, q, backend="cpu")
    np.testing.assert_array_equal(tx60.max_error(np.asfortranarray(p), q, backend="cpu"), want)
    np.testing.assert_array_equal(
        tx60.max_error(p, np.asfortranarray(q), backend="cpu"), want)
    np.testing.assert_array_equal(tx60.max_error(p.tolist(), q.tolist(), backend="cpu"), want)
    # float32: the same as float64 of the same (rounded) values.
    p32, q32 = p.astype(np.float32), q.astype(np.float32)
    np.testing.assert_array_equal(
        tx60.max_error(p32, q32, backend="cpu"),
        tx60.max_error(p32.astype(np.float64), q32.astype(np.float64), backend="cpu"))
    # Non-contiguous views: every other row, and columns picked out of a wider array.
    big = np.zeros((60, 45))
    big[::2, 5:38] = p
    view = big[::2, 5:38]
    assert not view.flags.c_contiguous and not view.flags.f_contiguous
    np.testing.assert_array_equal(tx60.max_error(view, q, backend="cpu"), want)
    qbig = np.zeros((len(q), 12))
    qbig[:, ::2] = q
    np.testing.assert_array_equal(tx60.max_error(p, qbig[:, ::2], backend="cpu"), want)
    # A reversed (negative-stride) view.
    np.testing.assert_array_equal(tx60.max_error(p[::-1], q, backend="cpu"), want[::-1])
    # Integers convert.
    np.testing.assert_array_equal(tx60.fk(np.zeros((2, 6), dtype=np.int64)),
                                  tx60.fk(np.zeros((2, 6))))


def test_empty_params_give_empty_result(tx60, q):
    assert tx60.max_error(np.zeros((0, 33)), q).shape == (0,)
    assert tx60.max_error(np.zeros((0, 30)), q).shape == (0,)


@pytest.mark.parametrize(
    "params_shape, needle",
    [((5, 29), "params: expected a 2-D array of shape (N, 33) or (N, 30), got shape (5, 29)"),
     ((5, 31), "params: expected a 2-D array of shape (N, 33) or (N, 30), got shape (5, 31)"),
     ((33,), "params: expected a 2-D array of shape (N, 33) or (N, 30), got shape (33,)"),
     ((2, 3, 33),
      "params: expected a 2-D array of shape (N, 33) or (N, 30), got shape (2, 3, 33)")])
def test_wrong_param_shapes(tx60, q, params_shape, needle):
    with pytest.raises(ValueError) as e:
        tx60.max_error(np.zeros(params_shape), q)
    assert needle in str(e.value)


def test_wrong_q_shape_and_values(tx60, q):
    p = rows(tx60, 4)
    with pytest.raises(ValueError, match=r"q_deg: expected a 2-D array of shape \(m, 6\)"):
        tx60.max_error(p, q[:, :5])
    bad = q.copy()
    bad[2, 4] = np.nan
    with pytest.raises(ValueError, match=r"q_deg: row 2, column 4 \(q5\): NaN is not a finite"):
        tx60.max_error(p, bad)
    with pytest.raises(ValueError, match=r"q_deg: row 2, column 4 \(q5\)"):
        tx60.fk(bad)
    far = q.copy()
    far[3, 1] = 400.0
    with pytest.raises(ValueError, match=r"q_deg: test point 4: q2 = 400 deg is outside"):
        tx60.max_error(p, far)
    with pytest.raises(ValueError, match=r"q_deg: no test points"):
        tx60.max_error(p, np.zeros((0, 6)))


def test_nan_and_far_params_name_row_and_column(tx60, q):
    p = rows(tx60, 70000)  # more than one internal chunk: the row is the caller's row
    p[66000, 8] = np.inf
    with pytest.raises(ValueError, match=r"params: row 66000, column 8 \(alpha2\): inf is not"):
        tx60.max_error(p, q)
    p = rows(tx60, 5)
    p[1, 0] += 120.0
    with pytest.raises(ValueError, match=r"params: row 1, column 0 \(theta1\).*up to 90 deg"):
        tx60.max_error(p, q)
    with pytest.raises(ValueError, match="params: not an array of numbers"):
        tx60.max_error([["a"] * 33], q)
    p = rows(tx60, 5)
    p[2, 31] = np.nan
    with pytest.raises(ValueError, match=r"params: row 2, column 31 \(tool_y\): NaN is not"):
        tx60.max_error(p, q)
    # The tool coordinates are lengths: no angle bound (a 200 mm move is still evaluated).
    p = np.tile(tx60.params, (2, 1))
    p[0, 32] += 200.0
    np.testing.assert_allclose(tx60.max_error(p, q, backend="cpu"), [200.0, 0.0], atol=TOL_MM)


def test_huge_finite_params_and_negative_counts_are_value_errors(tx60, q):
    # A finite 1e300 mm would overflow the forward kinematics to inf: refused, naming it.
    p = rows(tx60, 3)
    p[2, 2] = 1e300
    with pytest.raises(ValueError, match=r"params: row 2, column 2 \(\w+\): 1e300 mm is 1e300 mm"):
        tx60.max_error(p, q)
    with pytest.raises(ValueError, match=r"n: -1 draws is not a count \(0 or more\)"):
        tx60.draws(-1)
    with pytest.raises(ValueError, match=r"n: expected a whole number"):
        tx60.draws("ten")


def test_memory_limit_is_checked_before_any_work(tx60, q):
    # 10^9 broadcast rows cost no memory as a view, but their results would need 8 GB.
    p = np.broadcast_to(tx60.params, (10**9, gpu_amcs.N_UNCERTAIN))
    with pytest.raises(ValueError, match=r"memory_limit: max_error of 1000000000 rows .* needs"):
        tx60.max_error(p, q, memory_limit="1G")
    with pytest.raises(ValueError, match=r"memory_limit: 10 parameter draws needs"):
        tx60.draws(10, memory_limit=100)
    assert tx60.draws(10, memory_limit="1gb").shape == (10, 33)
    for bad in ["lots", 0, -5, 1.5j]:
        with pytest.raises(ValueError, match="memory_limit"):
            tx60.draws(10, memory_limit=bad)
    with pytest.raises(ValueError, match=r"memory_limit: MCS with 10000000 draws needs"):
        gpu_amcs.mcs(tx60, draws=10**7, memory_limit="10M")
    with pytest.raises(ValueError, match=r"memory_limit: .* needs"):
        gpu_amcs.map(tx60, plane="xz", at=0.0, cells=[100, 100], draws=1000, memory_limit="1M")


def test_bad_options(tx60, q):
    p = rows(tx60, 2)
    with pytest.raises(ValueError, match="backend: unknown backend 'fast'"):
        tx60.max_error(p, q, backend="fast")
    with pytest.raises(ValueError, match="reference: unknown reference 'design'"):
        tx60.max_error(p, q, reference="design")
    with pytest.raises(ValueError, match=r"columns\[1\]: unknown input 'gamma2'.*tool_x"):
        tx60.max_error(p[:, :2], q, columns=["theta1", "gamma2"])
    with pytest.raises(ValueError, match=r"columns\[1\]: input theta1 appears twice"):
        tx60.max_error(p[:, :2], q, columns=[0, "theta1"])
    with pytest.raises(ValueError, match=r"columns\[1\]: input tool_z appears twice"):
        tx60.max_error(p[:, :2], q, columns=["tool_z", 32])
    with pytest.raises(ValueError, match=r"columns\[0\]: input index 33 is out of range 0…32"):
        tx60.max_error(p[:, :1], q, columns=[33])
    with pytest.raises(ValueError, match=r"expected a 2-D array of shape \(N, 2\)"):
        tx60.max_error(p, q, columns=["tool_x", "tool_y"])
    with pytest.raises(ValueError, match=r"nominal is used only with reference=\"nominal\""):
        tx60.max_error(p, q, nominal=tx60)


def test_gil_is_released(tx60, q):
    """While one thread is inside max_error, the main thread keeps running Python: the
    largest gap between its loop iterations is a small part of the call. With the GIL held
    through the call the gap would be the whole call."""
    n = 20000
    p = rows(tx60, n)
    while True:
        t = time.perf_counter()
        tx60.max_error(p, q, backend="cpu")
        if time.perf_counter() - t > 0.4 or n >= 4_000_000:
            break
        n *= 4
        p = rows(tx60, n)
    span = {}
    started = threading.Event()

    def worker():
        started.set()
        span["t0"] = time.perf_counter()
        tx60.max_error(p, q, backend="cpu")
        span["t1"] = time.perf_counter()

    th = threading.Thread(target=worker)
    stamps = []
    th.start()
    started.wait()
    while th.is_alive():
        stamps.append(time.perf_counter())
        time.sleep(0.001)
    th.join()
    inside = [s for s in stamps if span["t0"] < s < span["t1"]]
    call = span["t1"] - span["t0"]
    edges = [span["t0"], *inside, span["t1"]]
    gap = max(b - a for a, b in zip(edges, edges[1:]))
    assert gap < 0.5 * call, f"main thread stalled {gap:.3f} s of a {call:.3f} s call"


@pytest.mark.parametrize("which", ["tx60", "tooled", "correlated"])
def test_draws_are_the_runs_draws(tx60, tooled, q, which):
    """model.draws(n, seed) through max_error gives the w values an MCS run of that seed keeps,
    with and without a tool spread, independent or correlated with a parameter."""
    models = {"tx60": tx60, "tooled": tooled}
    m = correlated_tool(tx60)[0] if which == "correlated" else models[which]
    res = gpu_amcs.mcs(m, draws=3000, q_deg=q, seed=99, backend="cpu")
    d = m.draws(3000, seed=99)
    assert d.shape == (3000, 33)
    w = np.sort(m.max_error(d, q, backend="cpu"))
    # Same draws: the offset path gets the same f64 inputs up to one degree↔radian round trip
    # and one subtraction of the mean (≈1e-16 relative of values ≤ 1e3), far below 1e-9 mm.
    np.testing.assert_allclose(w, res.values, rtol=0, atol=TOL_MM)
    np.testing.assert_allclose(d[1000:1010], m.draws(10, seed=99, first=1000), rtol=0, atol=0)
    # Different seeds, different draws; fixed inputs do not move.
    assert not np.allclose(d, m.draws(3000, seed=100))
    fixed = np.setdiff1d(np.arange(33), m.free)
    np.testing.assert_array_equal(d[:, fixed], np.broadcast_to(m.params[fixed], (3000, len(fixed))))
    # Their spread is the model's σ (3000 draws: the sample σ is within 4 × σ/√(2·3000) ≈ 5 %).
    np.testing.assert_allclose(d[:, m.free].std(axis=0), m.sigma[m.free], rtol=0.05)
    if which == "tooled":
        # A tool spread does not move the parameters' draws (docs/METHOD.md §14: the tool uses
        # normals 30–32), and it changes w: the run's values are not those of the fixed tool.
        np.testing.assert_array_equal(d[:, :30], tx60.draws(3000, seed=99)[:, :30])
        w_fixed = np.sort(m.max_error(d[:, :30], q, backend="cpu"))
        assert np.abs(w_fixed - w).max() > 1e-3
    if which == "correlated":
        # The stated correlation of tool_x and theta1: the sample ρ of 3000 draws has standard
        # error (1 − ρ²)/√n ≈ 0.014; 5 standard errors.
        r = np.corrcoef(d[:, 0], d[:, 30])[0, 1]
        assert abs(r - 0.5) < 0.07, r


# Largest allowed |w_gpu − w_cpu| per row, mm: the f32 deviation form's error budget at spreads
# of a few σ (docs/METHOD.md, "GPU backend"; the Rust GPU tests use the same 1e-5 mm bound).
GPU_TOL_MM = 1e-5


@pytest.mark.parametrize("which", ["tx60", "tooled"])
def test_gpu_backend_agrees_with_cpu(tx60, tooled, q, which):
    if not gpu_amcs.adapters():
        if os.environ.get("CI") == "true":
            pytest.fail("no GPU adapter and CI=true (install mesa-vulkan-drivers for lavapipe)")
        pytest.skip("no GPU adapter")
    # Parameters (and for "tooled" the tool point: the GPU's f32 deviation form starts at
    # Δ_7 = δ_tool, docs/METHOD.md §14, with the same budget) a few σ from the model.
    m = {"tx60": tx60, "tooled": tooled}[which]
    p = rows(m, 3000, seed=21)
    cpu = m.max_error(p, q, backend="cpu", per_point=True)
    gpu = m.max_error(p, q, backend="gpu", per_point=True)
    assert np.abs(gpu - cpu).max() < GPU_TOL_MM
    assert cpu.max() > 0.05  # the comparison is on errors of tenths of a mm, not zeros
    if which == "tooled":
        # Tool-only rows: |δ| at every point on the GPU too.
        off = np.zeros((200, 33))
        off[:, 30:] = 3 * m.sigma[30:] * np.random.default_rng(6).standard_normal((200, 3))
        e = m.max_error(off, q, offsets=True, per_point=True, backend="gpu")
        length = np.linalg.norm(off[:, 30:], axis=1)
        np.testing.assert_allclose(e, np.broadcast_to(length[:, None], e.shape), rtol=0,
                                   atol=GPU_TOL_MM)
