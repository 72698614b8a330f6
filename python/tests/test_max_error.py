"""max_error and fk against an independent NumPy forward kinematics; input handling."""

import os
import threading
import time

import numpy as np
import pytest

import gpu_amcs
from gpu_amcs.numpy_fk import fk as fk_numpy

# Tolerance of the CPU evaluator (f64) against the NumPy matrix-product FK: both evaluate the
# same chain in double precision; the positions are ~1e3 mm and each of the six joints adds a
# few ulps of rounding (1e3 mm × 2.2e-16 × ~100 operations ≈ 2e-11 mm), so 1e-9 mm leaves
# two orders of margin while any wrong parameter, unit or convention shows as ≥ 1e-6 mm.
TOL_MM = 1e-9


@pytest.fixture(scope="module")
def tx60():
    return gpu_amcs.Model.preset("tx60")


@pytest.fixture(scope="module")
def q(tx60):
    rng = np.random.default_rng(7)
    lo, hi = tx60.limits[:, 0], tx60.limits[:, 1]
    return rng.uniform(lo * 0.8, hi * 0.8, size=(12, 6))


def rows(model, n, seed=3, scale=3.0):
    """n parameter rows around the model's values, a few σ apart (mm, degrees)."""
    rng = np.random.default_rng(seed)
    return model.params + scale * model.sigma * rng.standard_normal((n, 30))


def test_fk_matches_numpy(tx60, q):
    want = fk_numpy(tx60.params[None, :], tx60.tool, q)[0]
    got = tx60.fk(q)
    assert got.shape == (len(q), 3)
    np.testing.assert_allclose(got, want, rtol=0, atol=TOL_MM)


def test_fk_tx60_flange_at_zero():
    # TX60 flange at q = 0 is (0, 20, 1045) mm (Stäubli TX60 data sheet: 375 + 290 + 310 + 70
    # mm column, 20 mm shoulder offset), a closed form independent of any FK code.
    m = gpu_amcs.Model.from_toml(gpu_amcs.Model.preset("tx60").to_toml())
    np.testing.assert_allclose(
        fk_numpy(m.params[None, :], [0, 0, 0], np.zeros((1, 6)))[0, 0], [0, 20, 1045],
        atol=1e-9)


def test_max_error_equals_numpy_difference(tx60, q):
    p = rows(tx60, 40)
    ref = fk_numpy(tx60.params[None, :], tx60.tool, q)[0]
    e = np.linalg.norm(fk_numpy(p, tx60.tool, q) - ref, axis=-1)
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
    ref = fk_numpy(tx60.params[None, :], tx60.tool, q)[0]
    want = np.linalg.norm(fk_numpy(p, tx60.tool, q) - ref, axis=-1).max(axis=1)
    got = tx60.max_error(p, q, reference="nominal", backend="cpu")
    np.testing.assert_allclose(got, want, atol=TOL_MM)
    qu = np.clip(q, ur.limits[:, 0], ur.limits[:, 1])
    ref_u = fk_numpy(ur.params[None, :], tx60.tool, qu)[0]
    want_u = np.linalg.norm(fk_numpy(p, tx60.tool, qu) - ref_u, axis=-1).max(axis=1)
    got_u = tx60.max_error(p, qu, reference="nominal", nominal=ur, backend="cpu")
    np.testing.assert_allclose(got_u, want_u, atol=TOL_MM)
    assert got_u.min() > 10  # a different robot is centimetres away


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


def test_the_mean_row_has_zero_error(tx60, q):
    # Zero up to the evaluator's rounding (its kernel and the reference positions take
    # different f64 operation orders: ~1e-13 mm).
    w = tx60.max_error(np.tile(tx60.params, (3, 1)), q, backend="cpu")
    assert w.shape == (3,) and np.all(w < TOL_MM)


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
    big[::2, 5:35] = p
    view = big[::2, 5:35]
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
    assert tx60.max_error(np.zeros((0, 30)), q).shape == (0,)


@pytest.mark.parametrize(
    "params_shape, needle",
    [((5, 29), "params: expected a 2-D array of shape (N, 30), got shape (5, 29)"),
     ((30,), "params: expected a 2-D array of shape (N, 30), got shape (30,)"),
     ((2, 3, 30), "params: expected a 2-D array of shape (N, 30), got shape (2, 3, 30)")])
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
        tx60.max_error([["a"] * 30], q)


def test_bad_options(tx60, q):
    p = rows(tx60, 2)
    with pytest.raises(ValueError, match="backend: unknown backend 'fast'"):
        tx60.max_error(p, q, backend="fast")
    with pytest.raises(ValueError, match="reference: unknown reference 'design'"):
        tx60.max_error(p, q, reference="design")
    with pytest.raises(ValueError, match=r"columns\[1\]: unknown parameter 'gamma2'"):
        tx60.max_error(p[:, :2], q, columns=["theta1", "gamma2"])
    with pytest.raises(ValueError, match=r"columns\[1\]: parameter theta1 appears twice"):
        tx60.max_error(p[:, :2], q, columns=[0, "theta1"])
    with pytest.raises(ValueError, match=r"columns\[0\]: parameter index 30 is out of range"):
        tx60.max_error(p[:, :1], q, columns=[30])
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


def test_draws_are_the_runs_draws(tx60, q):
    """model.draws(n, seed) through max_error gives the w values an MCS run of that seed keeps."""
    res = gpu_amcs.mcs(tx60, draws=3000, q_deg=q, seed=99, backend="cpu")
    d = tx60.draws(3000, seed=99)
    assert d.shape == (3000, 30)
    w = np.sort(tx60.max_error(d, q, backend="cpu"))
    # Same draws: the offset path gets the same f64 parameters up to one degree↔radian round
    # trip (≈1e-16 relative), far below 1e-9 mm.
    np.testing.assert_allclose(w, res.values, rtol=0, atol=TOL_MM)
    np.testing.assert_allclose(d[1000:1010], tx60.draws(10, seed=99, first=1000), rtol=0, atol=0)
    # Different seeds, different draws; fixed parameters do not move.
    assert not np.allclose(d, tx60.draws(3000, seed=100))
    fixed = np.setdiff1d(np.arange(30), tx60.free)
    np.testing.assert_array_equal(d[:, fixed], np.broadcast_to(tx60.params[fixed], (3000, len(fixed))))
    # Their spread is the model's σ (3000 draws: the sample σ is within 4 × σ/√(2·3000) ≈ 5 %).
    np.testing.assert_allclose(d[:, tx60.free].std(axis=0), tx60.sigma[tx60.free], rtol=0.05)


# Largest allowed |w_gpu − w_cpu| per row, mm: the f32 deviation form's error budget at spreads
# of a few σ (docs/METHOD.md, "GPU backend"; the Rust GPU tests use the same 1e-5 mm bound).
GPU_TOL_MM = 1e-5


def test_gpu_backend_agrees_with_cpu(tx60, q):
    if not gpu_amcs.adapters():
        if os.environ.get("CI") == "true":
            pytest.fail("no GPU adapter and CI=true (install mesa-vulkan-drivers for lavapipe)")
        pytest.skip("no GPU adapter")
    p = rows(tx60, 3000, seed=21)
    cpu = tx60.max_error(p, q, backend="cpu", per_point=True)
    gpu = tx60.max_error(p, q, backend="gpu", per_point=True)
    assert np.abs(gpu - cpu).max() < GPU_TOL_MM
    assert cpu.max() > 0.05  # the comparison is on errors of tenths of a mm, not zeros
