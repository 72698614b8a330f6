"""Seven-joint models: every Model method in the model's own layout (7 joints, 35 parameters,
38 inputs), checked against the independent NumPy forward kinematics, and shapes of a six-joint
model refused with the seven-joint shape named.

The model is the KUKA LBR iiwa 14 R820 from its standard DH table (KUKA's figures: d1 = 360,
d3 = 420, d5 = 400, d7 = 126 mm, every a = 0; α = -90, 90, 90, -90, -90, 90, 0 deg). The
model's chain Rz(θ + q)·Tz(d)·Tx(a)·Rx(α)·Ry(β) is the standard DH transform for β = 0, so the
table goes into the model file as it is."""

import json
import re

import numpy as np
import pytest

import gpu_amcs
from conftest import with_tool_sigma, without_timing
from gpu_amcs import numpy_fk
from gpu_amcs.numpy_fk import fk as fk_numpy
from gpu_amcs.numpy_fk import inputs

# As test_max_error.py: the engine's f64 chain against the NumPy matrix products; the positions
# are ~1e3 mm and each joint adds a few ulps, so 1e-9 mm leaves orders of margin while any
# wrong parameter, unit or joint shows as ≥ 1e-6 mm.
TOL_MM = 1e-9

# (d mm, α deg) of the seven rows; θ = a = 0.
IIWA_DH = [(360, -90), (0, 90), (420, 90), (0, -90), (400, -90), (0, 90), (126, 0)]
IIWA_LIMITS = [170, 120, 170, 120, 170, 120, 175]
TOOL = [10.0, -5.0, 40.0]
# σ per joint (deg, mm): β is each joint's fixed parameter (σ 0).
SIGMA = dict(theta=0.01, d=0.05, a=0.05, alpha=0.01, beta=0.0)


def iiwa_toml(tool=TOOL):
    lines = ['name = "KUKA LBR iiwa 14 R820"',
             "tool = [" + ", ".join(repr(float(v)) for v in tool) + "]"]
    sigma = ", ".join(f"{k} = {v!r}" for k, v in SIGMA.items())
    for (d, alpha), lim in zip(IIWA_DH, IIWA_LIMITS):
        lines += ["", "[[joint]]", "theta = 0.0", f"d = {float(d)!r}", "a = 0.0",
                  f"alpha = {float(alpha)!r}", "beta = 0.0", 'fixed = "beta"',
                  f"limits = [{-float(lim)!r}, {float(lim)!r}]", f"sigma = {{ {sigma} }}"]
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def iiwa():
    return gpu_amcs.Model.from_toml(iiwa_toml(), "iiwa14.toml")


@pytest.fixture(scope="module")
def q(iiwa):
    rng = np.random.default_rng(11)
    lo, hi = iiwa.limits[:, 0], iiwa.limits[:, 1]
    return rng.uniform(lo * 0.8, hi * 0.8, size=(12, 7))


def rows(model, n, seed=3, scale=3.0):
    """n rows of the model's inputs around its values, a few σ apart (mm, degrees)."""
    rng = np.random.default_rng(seed)
    return model.params + scale * model.sigma * rng.standard_normal((n, len(model.params)))


def test_layout_is_the_models_own(iiwa):
    # The module constants stay the six-joint counts.
    assert gpu_amcs.N_PARAMS == 30 and gpu_amcs.N_UNCERTAIN == 33
    assert gpu_amcs.Model.preset("tx60").joints == 6
    assert iiwa.joints == 7
    assert iiwa.params.shape == (38,) and iiwa.sigma.shape == (38,)
    names = iiwa.param_names
    assert len(names) == 38
    assert names[:5] == ["theta1", "d1", "a1", "alpha1", "beta1"]
    assert names[30:35] == ["theta7", "d7", "a7", "alpha7", "beta7"]
    assert names[35:] == ["tool_x", "tool_y", "tool_z"]
    np.testing.assert_array_equal(iiwa.params[35:], TOOL)
    np.testing.assert_array_equal(iiwa.tool, TOOL)
    # d of each joint (mm) and α (deg) as the table gives them.
    np.testing.assert_array_equal(iiwa.params[1:35:5], [d for d, _ in IIWA_DH])
    np.testing.assert_array_equal(iiwa.params[3:35:5], [a for _, a in IIWA_DH])
    np.testing.assert_array_equal(iiwa.sigma[:5], [0.01, 0.05, 0.05, 0.01, 0.0])
    np.testing.assert_array_equal(iiwa.sigma[35:], [0, 0, 0])
    # Free: θ, d, a, α of the seven joints (β fixed), no tool.
    assert iiwa.free == [i for i in range(35) if i % 5 != 4]
    assert iiwa.limits.shape == (7, 2)
    np.testing.assert_array_equal(iiwa.limits[:, 1], IIWA_LIMITS)
    assert iiwa.covariance is None
    assert "28 free inputs of 38" in repr(iiwa)
    # The model file round trip keeps the seven joints.
    back = gpu_amcs.Model.from_toml(iiwa.to_toml())
    assert back.joints == 7
    np.testing.assert_array_equal(back.params, iiwa.params)
    np.testing.assert_array_equal(back.sigma, iiwa.sigma)


def test_uncertain_tool_and_covariance(iiwa):
    tooled = with_tool_sigma(iiwa, [0.004, 0.002, 0.006])
    np.testing.assert_array_equal(tooled.sigma[35:], [0.004, 0.002, 0.006])
    assert tooled.free == iiwa.free + [35, 36, 37]
    # A 35 × 35 file matrix (the parameters' σ²) extended by the tool's variances.
    s = iiwa.sigma[:35]
    m35 = with_tool_sigma(iiwa, [0.004, 0.002, 0.006], covariance=np.diag(s**2))
    c = m35.covariance
    assert c.shape == (38, 38)
    np.testing.assert_allclose(np.diag(c), m35.sigma**2, rtol=1e-12)
    assert np.count_nonzero(c - np.diag(np.diag(c))) == 0
    # A 38 × 38 one with a tool correlation is returned as given.
    full = np.diag(np.concatenate([s**2, [0.004**2, 0.002**2, 0.006**2]]))
    full[35, 0] = full[0, 35] = 0.5 * 0.004 * s[0]
    m38 = with_tool_sigma(iiwa, [0.004, 0.002, 0.006], covariance=full)
    np.testing.assert_allclose(m38.covariance, full, rtol=1e-12, atol=0)


def test_fk_standard_dh_closed_form_and_numpy(iiwa, q):
    # At q = 0 the arm stands straight up: the flange at 360 + 420 + 400 + 126 mm, its frame
    # the base's (the α's add up to 0), so the tool point is the flange plus the tool.
    np.testing.assert_allclose(iiwa.fk(np.zeros((1, 7)))[0], np.add([0, 0, 1306], TOOL),
                               atol=1e-9)
    np.testing.assert_allclose(
        fk_numpy(inputs(iiwa.params[None, :35], [0, 0, 0]), np.zeros((1, 7)))[0, 0],
        [0, 0, 1306], atol=1e-9)
    np.testing.assert_allclose(fk_numpy(iiwa.params[None, :35], np.zeros((1, 7)), tool=[0, 0, 0])
                               [0, 0], [0, 0, 1306], atol=1e-9)
    # q2 = 90° turns the rigid rest of the arm about the shoulder (0, 0, 360): the tool point
    # keeps its distance from it.
    got = iiwa.fk([[0, 90, 0, 0, 0, 0, 0]])[0]
    assert abs(np.linalg.norm(got - [0, 0, 360]) - np.linalg.norm(np.add([0, 0, 946], TOOL))) \
        < 1e-9
    want = fk_numpy(iiwa.params[None, :], q)[0]
    out = iiwa.fk(q)
    assert out.shape == (12, 3)
    np.testing.assert_allclose(out, want, rtol=0, atol=TOL_MM)


def test_from_urdf_dh_table_is_the_same_arm(tmp_path, iiwa, q):
    # The same table as a DH .csv imports (through Model.from_urdf) as a seven-joint model
    # whose flange is where the model file's is.
    text = "convention,standard\nunits,mm-deg\nname,iiwa14\ntheta,d,a,alpha,lower,upper\n"
    text += "".join(f"0,{d},0,{al},{-l},{l}\n" for (d, al), l in zip(IIWA_DH, IIWA_LIMITS))
    f = tmp_path / "iiwa14.csv"
    f.write_text(text)
    m = gpu_amcs.Model.from_urdf(f)
    assert m.joints == 7 and m.params.shape == (38,) and m.limits.shape == (7, 2)
    np.testing.assert_array_equal(m.limits[:, 1], IIWA_LIMITS)
    assert np.all(m.sigma == 0) and m.free == []
    flange = fk_numpy(inputs(iiwa.params[None, :35], [0, 0, 0]), q)[0]
    np.testing.assert_allclose(m.fk(q), flange, atol=1e-6)
    np.testing.assert_allclose(m.fk(np.zeros((1, 7)))[0], [0, 0, 1306], atol=1e-9)


def test_draws_have_38_columns(iiwa):
    tooled = with_tool_sigma(iiwa, [0.004, 0.002, 0.006])
    for m in (iiwa, tooled):
        x = m.draws(4000, seed=5)
        assert x.shape == (4000, 38)
        fixed = np.setdiff1d(np.arange(38), m.free)
        np.testing.assert_array_equal(x[:, fixed], np.broadcast_to(m.params[fixed],
                                                                   (4000, len(fixed))))
        free = np.array(m.free)
        np.testing.assert_allclose(x[:, free].std(axis=0), m.sigma[free], rtol=0.1)
        np.testing.assert_allclose(x[:, free].mean(axis=0), m.params[free],
                                   atol=5 * m.sigma[free].max() / np.sqrt(4000))
        # A draw is a function of the seed and its index.
        np.testing.assert_array_equal(m.draws(3, seed=5, first=10), x[10:13])
    assert np.all(tooled.draws(10, seed=1)[:, 35:].std(axis=0) > 0)
    assert tooled.draws(0).shape == (0, 38)


def test_max_error_equals_numpy_on_explicit_rows(iiwa, q):
    p = rows(iiwa, 40)
    ref = fk_numpy(iiwa.params[None, :], q)[0]
    e = np.linalg.norm(fk_numpy(p, q) - ref, axis=-1)
    np.testing.assert_allclose(iiwa.max_error(p, q, backend="cpu"), e.max(axis=1), atol=TOL_MM)
    pp = iiwa.max_error(p, q, backend="cpu", per_point=True)
    assert pp.shape == (40, 12)
    np.testing.assert_allclose(pp, e, atol=TOL_MM)
    assert 0.01 < e.max() < 10
    # 35 columns: the parameters, the tool at the model's tool.
    w35 = iiwa.max_error(p[:, :35], q, backend="cpu")
    e35 = np.linalg.norm(fk_numpy(p[:, :35], q, tool=iiwa.tool) - ref, axis=-1).max(axis=1)
    np.testing.assert_allclose(w35, e35, atol=TOL_MM)
    # Named columns (the last joint's θ and the tool's z), as absolute values and as offsets.
    sub = p[:, [30, 37]]
    full = np.broadcast_to(iiwa.params, p.shape).copy()
    full[:, [30, 37]] = sub
    want = np.linalg.norm(fk_numpy(full, q) - ref, axis=-1).max(axis=1)
    np.testing.assert_allclose(iiwa.max_error(sub, q, columns=["theta7", "tool_z"],
                                              backend="cpu"), want, atol=TOL_MM)
    np.testing.assert_allclose(iiwa.max_error(sub - iiwa.params[[30, 37]], q, columns=[30, 37],
                                              offsets=True, backend="cpu"), want, atol=1e-8)
    # NumPy's max_error of the draws agrees too.
    x = iiwa.draws(200, seed=9)
    np.testing.assert_allclose(iiwa.max_error(x, q, backend="cpu"),
                               numpy_fk.max_error(x, q, ref), atol=TOL_MM)


def test_shapes_are_refused_naming_the_models_shape(iiwa, q):
    p = rows(iiwa, 5)
    tx60 = gpu_amcs.Model.preset("tx60")
    msg = "params: expected a 2-D array of shape (N, 38) or (N, 35), got shape (5, 33)"
    with pytest.raises(ValueError, match=re.escape(msg)):
        iiwa.max_error(p[:, :33], q)
    with pytest.raises(ValueError, match=re.escape("(N, 38) or (N, 35), got shape (38,)")):
        iiwa.max_error(p[0], q)
    msg = ("q_deg: expected a 2-D array of shape (m, 7) joint angles in degrees, or a 1-D array "
           "of shape (7,) for one row, got shape (12, 6)")
    with pytest.raises(ValueError, match=re.escape(msg)):
        iiwa.max_error(p, q[:, :6])
    with pytest.raises(ValueError, match=re.escape(msg)):
        iiwa.fk(q[:, :6])
    # A six-joint model names its own shapes.
    msg = "shape (m, 6) joint angles in degrees, or a 1-D array of shape (6,) for one row, got "
    with pytest.raises(ValueError, match=re.escape(msg + "shape (12, 7)")):
        tx60.fk(q)
    with pytest.raises(ValueError, match=re.escape("(N, 33) or (N, 30), got shape (5, 38)")):
        tx60.max_error(p, q[:, :6])
    with pytest.raises(ValueError, match=r"columns\[0\]: input index 38 is out of range 0…37"):
        iiwa.max_error(p[:, :1], q, columns=[38])
    with pytest.raises(ValueError, match=r"unknown input 'beta8' \(expected theta1 … beta7"):
        iiwa.max_error(p[:, :1], q, columns=["beta8"])
    bad = q.copy()
    bad[3, 6] = np.inf
    with pytest.raises(ValueError, match=r"q_deg: row 3, column 6 \(q7\): inf is not a finite"):
        iiwa.fk(bad)
    # The analyses take the model's joint count too.
    with pytest.raises(ValueError, match=re.escape("q_deg: expected a 2-D array of shape (m, 7)")):
        gpu_amcs.mcs(iiwa, q_deg=q[:, :6], draws=1000, backend="cpu")
    with pytest.raises(ValueError, match=re.escape(
            "(reference_q): needs 7 numbers (q1..q7 in degrees, one per joint of the model), got 6")):
        gpu_amcs.map(iiwa, reference_q=[0, 30, 0, -60, 0, 30], plane="xy", at=500,
                     cells=[2, 2], draws=100, backend="cpu")
    # The NumPy reference takes the joint count from the width of the rows.
    with pytest.raises(ValueError, match=re.escape("q_deg: expected shape (m, 7)")):
        fk_numpy(p, q[:, :6])
    with pytest.raises(ValueError, match="neither 5n parameters nor 5n"):
        fk_numpy(p[:, :37], q)
    with pytest.raises(ValueError, match="need tool"):
        fk_numpy(p[:, :35], q)


def test_runs_on_seven_joints(iiwa, q):
    tooled = with_tool_sigma(iiwa, [0.004, 0.002, 0.006])
    res = gpu_amcs.mcs(tooled, q_deg=q, draws=5000, backend="cpu", seed=4)
    assert len(res.values) == 5000
    # The run's w are max_error of the run's own draws.
    x = tooled.draws(5000, seed=4)
    np.testing.assert_allclose(np.sort(tooled.max_error(x, q, backend="cpu")), res.values,
                               rtol=0, atol=TOL_MM)
    gen = gpu_amcs.mcs(iiwa, points=8, draws=2000, backend="cpu")
    assert len(gen.values) == 2000 and gen.estimate > 0


def test_mcs_equals_cli_on_seven_joints(cli, tmp_path, iiwa, q):
    # The model file and the configurations as the command line reads them (q1..q7 columns).
    model = tmp_path / "iiwa14.toml"
    model.write_text(iiwa_toml())
    qr = q.round(3)
    points = tmp_path / "points.csv"
    points.write_text("q1,q2,q3,q4,q5,q6,q7\n"
                      + "\n".join(",".join(map(str, r)) for r in qr) + "\n")
    out = tmp_path / "cli.json"
    r = cli("mcs", "--model", model, "--points-file", points, "--draws", 3000, "--seed", 7,
            "--backend", "cpu", "--json", out, "--quiet")
    assert r.returncode == 0, r.stderr
    doc = json.loads(out.read_text())
    res = gpu_amcs.mcs(iiwa, q_deg=qr, draws=3000, seed=7, backend="cpu")
    assert without_timing(res.to_dict()) == without_timing(doc)
    res = gpu_amcs.mcs(gpu_amcs.Model.from_file(model), points_file=points, draws=3000, seed=7,
                       backend="cpu")
    assert without_timing(res.to_dict()) == without_timing(doc)


def test_plan_and_map_on_seven_joints(iiwa, q):
    p = gpu_amcs.plan(iiwa, q_deg=q, poses=30, candidates=300, draws=1000, backend="cpu",
                      seed=3)
    assert len(p.design) == 30 and all(len(pose) == 7 for pose in p.design)
    lines = p.design_csv().splitlines()
    assert lines[0] == "q1,q2,q3,q4,q5,q6,q7" and len(lines) == 31
    assert all(lo <= v <= hi for pose in p.design for v, (lo, hi) in zip(pose, iiwa.limits))
    m = gpu_amcs.map(iiwa, plane="xz", at=0.0, cells=[3, 3], draws=200, backend="cpu",
                     reference_q=[0, 30, 0, -60, 0, 30, 0])
    doc = m.to_dict()["map"]
    assert doc["spec"]["reference_q_deg"] == [0, 30, 0, -60, 0, 30, 0]
    reached = [c for c in doc["cells"] if c.get("ik")]
    assert reached and all(len(c["ik"]["q_deg"]) == 7 for c in reached)
    # Each reached cell's configuration puts the tool point where the cell is.
    for c in reached:
        tool = fk_numpy(iiwa.params[None], np.array([c["ik"]["q_deg"]]))[0, 0]
        assert np.linalg.norm(tool - c["position"]) < 1e-6
