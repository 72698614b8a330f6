"""mcs/amcs from Python against the command line: the same JSON document for the same
arguments (timing fields aside), and the same one-line error messages."""

import json
import re

import numpy as np
import pytest

import gpu_amcs
from conftest import with_tool_sigma, without_timing


def cli_json(cli, tmp_path, *args):
    out = tmp_path / "cli.json"
    r = cli(*args, "--json", out, "--quiet")
    assert r.returncode == 0, r.stderr
    return json.loads(out.read_text())


def test_mcs_equals_cli(cli, tmp_path):
    doc = cli_json(cli, tmp_path, "mcs", "--draws", 20000, "--points", 12, "--backend", "cpu",
                   "--seed", 7)
    res = gpu_amcs.mcs(draws=20000, points=12, backend="cpu", seed=7)
    assert without_timing(res.to_dict()) == without_timing(doc)
    assert len(res.values) == 20000 and np.all(np.diff(res.values) >= 0)
    assert res.estimate == doc["result"]["estimate"]
    assert res.values.mean() == pytest.approx(res.estimate, rel=1e-12)


def test_amcs_equals_cli_with_options(cli, tmp_path):
    args = ["--delta", 0.05, "--points", 9, "--points-seed", 3, "--backend", "cpu",
            "--per-point", "--coverage", 0.9, "--interval", "symmetric", "--thresholds",
            "0.2,0.4", "--batch", 5000, "--preset", "ur5e", "--reference", "nominal"]
    doc = cli_json(cli, tmp_path, "amcs", *args)
    res = gpu_amcs.amcs(delta=0.05, points=9, points_seed=3, backend="cpu", per_point=True,
                        coverage=0.9, interval="symmetric", thresholds=[0.2, 0.4], batch=5000,
                        preset="ur5e", reference="nominal")
    assert without_timing(res.to_dict()) == without_timing(doc)
    # The same with the model given as an object.
    res2 = gpu_amcs.amcs(gpu_amcs.Model.preset("ur5e"), delta=0.05, points=9, points_seed=3,
                         backend="cpu", per_point=True, coverage=0.9, interval="symmetric",
                         thresholds=[0.2, 0.4], batch=5000, reference="nominal")
    assert without_timing(res2.to_dict()) == without_timing(doc)


def test_default_amcs_equals_cli(cli, tmp_path):
    doc = cli_json(cli, tmp_path, "--points", 10, "--delta", 0.02, "--backend", "cpu")
    res = gpu_amcs.amcs(points=10, delta=0.02, backend="cpu")
    assert without_timing(res.to_dict()) == without_timing(doc)
    assert res.converged and res.draws == len(res.values)


def test_points_as_array_equal_points_file(cli, tmp_path):
    m = gpu_amcs.Model.preset("tx60")
    rng = np.random.default_rng(1)
    q = rng.uniform(m.limits[:, 0] * 0.5, m.limits[:, 1] * 0.5, size=(7, 6)).round(3)
    csv = tmp_path / "points.csv"
    csv.write_text("q1,q2,q3,q4,q5,q6\n" + "\n".join(",".join(map(str, r)) for r in q) + "\n")
    model_file = tmp_path / "model.toml"
    model_file.write_text(m.to_toml())
    doc = cli_json(cli, tmp_path, "mcs", "--draws", 5000, "--points-file", csv, "--model",
                   model_file, "--backend", "cpu")
    by_array = gpu_amcs.mcs(gpu_amcs.Model.from_file(model_file), draws=5000, q_deg=q,
                            backend="cpu")
    by_file = gpu_amcs.mcs(gpu_amcs.Model.from_file(model_file), draws=5000, points_file=csv,
                           backend="cpu")
    assert without_timing(by_array.to_dict()) == without_timing(doc)
    assert without_timing(by_file.to_dict()) == without_timing(doc)


@pytest.mark.parametrize("run", ["mcs", "amcs"])
def test_tool_sigma_model_equals_cli(cli, tmp_path, run):
    """A model file with tool_sigma (docs/METHOD.md §14): the same document from Python and
    from `gpu-amcs --model`, and the tool's spread is in it (w differs from the fixed tool)."""
    tx60 = gpu_amcs.Model.preset("tx60")
    m = with_tool_sigma(tx60, [0.004, 0.002, 0.006])
    model_file = tmp_path / "tool.toml"
    model_file.write_text(m.to_toml())
    assert "tool_sigma = [0.004, 0.002, 0.006]" in model_file.read_text()
    kw = dict(points=12, backend="cpu", seed=5)
    if run == "mcs":
        doc = cli_json(cli, tmp_path, "mcs", "--model", model_file, "--draws", 20000, "--points",
                       12, "--backend", "cpu", "--seed", 5)
        res = gpu_amcs.mcs(gpu_amcs.Model.from_file(model_file), draws=20000, **kw)
        fixed = gpu_amcs.mcs(tx60, draws=20000, **kw)
    else:
        doc = cli_json(cli, tmp_path, "amcs", "--model", model_file, "--delta", 0.02,
                       "--points", 12, "--backend", "cpu", "--seed", 5)
        res = gpu_amcs.amcs(gpu_amcs.Model.from_file(model_file), delta=0.02, **kw)
        fixed = gpu_amcs.amcs(tx60, delta=0.02, **kw)
    assert without_timing(res.to_dict()) == without_timing(doc)
    # The object built from text is the same model as the one read from the file.
    same = gpu_amcs.mcs(m, draws=20000, **kw) if run == "mcs" else gpu_amcs.amcs(m, delta=0.02,
                                                                                 **kw)
    assert without_timing(same.to_dict()) == without_timing(doc)
    assert res.estimate != fixed.estimate


def test_fk_equals_cli_fk_with_a_base_transform(cli, tmp_path):
    """The KR 6 R700 sixx preset has a base transform (Rx(180°)): fk gives positions in the
    description's frame, as `gpu-amcs fk` prints them."""
    m = gpu_amcs.Model.preset("kr6r700sixx")
    rng = np.random.default_rng(3)
    q = rng.uniform(0.5 * m.limits[:, 0], 0.5 * m.limits[:, 1], size=(6, 6))
    csv = tmp_path / "q.csv"
    rows = "\n".join(",".join(repr(float(v)) for v in r) for r in q)
    csv.write_text("q1,q2,q3,q4,q5,q6\n" + rows + "\n")
    r = cli("fk", "--preset", "kr6r700sixx", "--points-file", csv)
    assert r.returncode == 0, r.stderr
    want = np.loadtxt(r.stdout.splitlines()[1:], delimiter=",")[:, 6:]
    np.testing.assert_array_equal(m.fk(q), want)


def cli_error(cli, *args):
    r = cli(*args)
    assert r.returncode == 2, r.stderr
    line = r.stderr.strip()
    assert line.startswith("error: ") and "\n" not in line
    return line[len("error: "):]


def test_model_file_error_is_the_cli_line(cli, tmp_path):
    m = gpu_amcs.Model.preset("tx60").to_toml()
    bad = tmp_path / "bad.toml"
    # A σ of a length beyond the 100 mm bound (a unit mistake).
    bad.write_text(m.replace("d = 0.005056", "d = 5000.0", 1))
    assert bad.read_text() != m
    want = cli_error(cli, "mcs", "--model", bad, "--draws", 1000, "--backend", "cpu")
    with pytest.raises(ValueError) as e:
        gpu_amcs.mcs(gpu_amcs.Model.from_file(bad), draws=1000, backend="cpu")
    # The command line names the flag before the library's message.
    assert want == "--model: " + str(e.value)
    with pytest.raises(ValueError) as e:
        gpu_amcs.Model.from_file(tmp_path / "missing.toml")
    assert cli_error(cli, "mcs", "--model", tmp_path / "missing.toml") == "--model: " + str(
        e.value)


def test_setting_errors_name_the_keyword(cli):
    want = cli_error(cli, "mcs", "--coverage", 1.5, "--draws", 1000)
    with pytest.raises(ValueError) as e:
        gpu_amcs.mcs(coverage=1.5, draws=1000)
    # The same message with the keyword where the command line names its flag.
    assert str(e.value) == want.replace("--coverage", "coverage")
    want = cli_error(cli, "amcs", "--delta", -1)
    with pytest.raises(ValueError) as e:
        gpu_amcs.amcs(delta=-1)
    assert str(e.value) == want.replace("--delta", "delta")
    with pytest.raises(ValueError, match="delta and ndig exclude each other"):
        gpu_amcs.amcs(delta=0.1, ndig=2)
    with pytest.raises(ValueError, match="preset: unknown"):
        gpu_amcs.mcs(preset="tx90", draws=1000)
    with pytest.raises(ValueError, match="interval: unknown interval 'widest'"):
        gpu_amcs.mcs(interval="widest", draws=1000)
    with pytest.raises(ValueError, match="q_deg and points_file exclude each other"):
        gpu_amcs.mcs(q_deg=np.zeros((1, 6)), points_file="x.csv", draws=1000)


def test_runaway_draws_are_refused_before_any_work():
    with pytest.raises(ValueError, match=r"MCS with 1000000000000000 draws"):
        gpu_amcs.mcs(draws=10**15, backend="cpu")
    with pytest.raises(ValueError, match=r"parameter draws"):
        gpu_amcs.Model.preset("tx60").draws(10**13)


def masked_times(text):
    """The comparison's table with its last column (the runs' wall-clock seconds) masked."""
    return "\n".join(re.sub(r"[0-9.]+( \|)?$", r"<t>\1", line) if "MCS" in line else line
                     for line in text.splitlines())


def test_compare_equals_cli(cli, tmp_path):
    """gpu_amcs.compare: the document, table and Markdown of `gpu-amcs compare` (the library's
    CompareJob for both), and its setting errors with compare's keywords."""
    out, md = tmp_path / "cli.json", tmp_path / "cli.md"
    args = ["--points", 5, "--draws", 50000, "--deltas", "0.05,0.02", "--batch", 5000,
            "--coverage", 0.9, "--backend", "cpu", "--seed", 7]
    r = cli("compare", *args, "--json", out, "--markdown", md, "--quiet")
    assert r.returncode == 0, r.stderr
    res = gpu_amcs.compare(points=5, draws=50000, deltas=[0.05, 0.02], batch=5000, coverage=0.9,
                           backend="cpu", seed=7)
    doc = json.loads(out.read_text())
    assert without_timing(res.to_dict()) == without_timing(doc)
    assert masked_times(res.to_text()) == masked_times(r.stdout)
    assert masked_times(res.to_markdown()) == masked_times(md.read_text())
    assert res.mcs_draws == 50000
    assert [d for d, _, _ in res.amcs] == [0.05, 0.02]
    assert [n for _, n, _ in res.amcs] == [a[1]["draws"] for a in doc["amcs"]]
    # One δ as a number; the defaults are the command line's.
    one = gpu_amcs.compare(points=5, draws=50000, deltas=0.05, batch=5000, coverage=0.9,
                           backend="cpu", seed=7)
    assert one.amcs == res.amcs[:1]
    for flags, kw in [(["--deltas=-1"], dict(deltas=-1)), (["--draws", 10], dict(draws=10)),
                      (["--batch", 0], dict(batch=0))]:
        want = cli_error(cli, "compare", "--points", 5, *flags)
        with pytest.raises(ValueError) as e:
            gpu_amcs.compare(points=5, **kw)
        flag = flags[0].split("=")[0]
        assert str(e.value) == want.replace(flag, flag[2:]), flags


BACKLASH_TABLE = """
[joint_errors]
compliance_urad_per_nm = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
harmonics_deg = [[0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0],
                 [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0], [0.0, 0.0, 0.0, 0.0]]
link_mass_kg = [10.0, 8.0, 5.0, 3.0, 1.0, 0.5]
backlash_deg = [0.08, 0.05, 0.03, 0.02, 0.02, 0.02]
backlash_sigma_deg = [0.0, 0.0, 0.0, 0.0, 0.0, 0.0]
"""


def test_sides_with_configurations_equal_points_file_columns(cli, tmp_path):
    """sides= (m × n of 1, -1, 0) at q_deg: the same as a points file's s1..sn columns, from
    Python and from the command line; misplaced sides name the keyword."""
    m = gpu_amcs.Model.preset("tx60")
    model_file = tmp_path / "lash.toml"
    model_file.write_text(m.to_toml() + BACKLASH_TABLE)
    lash = gpu_amcs.Model.from_file(model_file)
    rng = np.random.default_rng(3)
    q = rng.uniform(m.limits[:, 0] * 0.5, m.limits[:, 1] * 0.5, size=(7, 6)).round(3)
    s = np.where(rng.uniform(size=(7, 6)) < 0.5, -1, 1)
    s[2, :] = 0  # point 3: every side drawn
    csv = tmp_path / "points.csv"
    csv.write_text("q1,q2,q3,q4,q5,q6,s1,s2,s3,s4,s5,s6\n" + "\n".join(
        ",".join(map(str, list(r) + list(map(int, t)))) for r, t in zip(q, s)) + "\n")
    doc = cli_json(cli, tmp_path, "mcs", "--draws", 3000, "--points-file", csv, "--model",
                   model_file, "--backend", "cpu")
    by_array = gpu_amcs.mcs(lash, draws=3000, q_deg=q, sides=s, backend="cpu").to_dict()
    by_file = gpu_amcs.mcs(lash, draws=3000, points_file=csv, backend="cpu").to_dict()
    assert without_timing(by_array) == without_timing(doc)
    assert without_timing(by_file) == without_timing(doc)
    drawn = gpu_amcs.mcs(lash, draws=3000, q_deg=q, backend="cpu").to_dict()
    assert without_timing(drawn)["result"] != without_timing(by_array)["result"]
    with pytest.raises(ValueError, match=r"^sides: belong to the configurations q_deg"):
        gpu_amcs.mcs(lash, sides=s, draws=100, backend="cpu")
    with pytest.raises(ValueError, match=r"^sides: .*5 rows of sides for 7 test points"):
        gpu_amcs.mcs(lash, q_deg=q, sides=s[:5], draws=100, backend="cpu")
    with pytest.raises(ValueError, match=r"^sides: .*backlash_deg"):
        gpu_amcs.mcs(m, q_deg=q, sides=s, draws=100, backend="cpu")


def test_term_for_unknown_sides_stands_in_until_every_side_is_given(tmp_path):
    """A model with backlash and a term for unknown sides: the getter gives the term; an
    analysis predicts the points whose sides are not all given at the centre of the gaps and
    draws the term there (the note says so); with every side given it is the analysis of the
    model without the term."""
    m = gpu_amcs.Model.preset("tx60")
    term = ("\n[joint_errors.backlash_sides_unknown]\nrobot_share = 1.0\nnoise = \"unknown\"\n"
            "residual_norms = [0.1, 0.2, 0.3, 0.4, 0.5, 0.6, 0.7, 0.8, 0.9, 1.0]\n")
    plain_file, term_file = tmp_path / "lash.toml", tmp_path / "lash_u.toml"
    plain_file.write_text(m.to_toml() + BACKLASH_TABLE)
    term_file.write_text(m.to_toml() + BACKLASH_TABLE + term)
    plain, with_term = gpu_amcs.Model.from_file(plain_file), gpu_amcs.Model.from_file(term_file)
    d = with_term.discrepancy_sides_unknown
    assert d is not None and np.allclose(d["residual_norms"], np.arange(1, 11) / 10), d
    assert d["compensation"] is None and d["drawn"]
    assert plain.discrepancy_sides_unknown is None and m.discrepancy_sides_unknown is None
    rng = np.random.default_rng(5)
    q = rng.uniform(m.limits[:, 0] * 0.5, m.limits[:, 1] * 0.5, size=(6, 6)).round(3)
    s = np.where(rng.uniform(size=(6, 6)) < 0.5, -1, 1)

    def run(model, **kw):
        return gpu_amcs.mcs(model, draws=3000, q_deg=q, backend="cpu", **kw)

    def note(r):
        return next(n for n in r.notes if "joint errors drawn" in n)

    centre = run(with_term)
    assert "sides not known at the test points: each joint is taken at the centre" in \
        note(centre), centre.notes
    assert any("model discrepancy drawn" in n for n in centre.notes), centre.notes
    given, given_plain = run(with_term, sides=s), run(plain, sides=s)
    assert note(given).endswith("its sides given at every point"), given.notes
    assert given.to_dict()["result"]["moments"] == given_plain.to_dict()["result"]["moments"]
    assert centre.estimate > given.estimate + 0.01
    some = s.copy()
    some[4, 2] = 0
    partial = run(with_term, sides=some)
    assert "sides given in full at 5 of the 6 test points and used there; at the other 1" in \
        note(partial), partial.notes
    assert note(partial).endswith("(5 sides given at those points are not used)"), partial.notes
    moments = [r.to_dict()["result"]["moments"] for r in (given, partial, centre)]
    assert moments[1] != moments[0] and moments[1] != moments[2]
    assert given.estimate <= partial.estimate <= centre.estimate
