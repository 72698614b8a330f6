"""sensitivity, tail, map and identify from Python against the command line: the same JSON
document, text and CSV for the same arguments (timing fields aside), and errors naming the
keyword where the command line names its flag."""

import io
import json
import re

import numpy as np
import pytest

import gpu_amcs
from conftest import without_timing


def run_ok(cli, *args):
    r = cli(*args)
    assert r.returncode == 0, r.stderr
    return r


def cli_json(cli, tmp_path, *args):
    """The --json document, --csv directory and stdout of a command-line run."""
    out, csv = tmp_path / "cli.json", tmp_path / "csv"
    r = run_ok(cli, *args, "--json", out, "--csv", csv)
    return json.loads(out.read_text()), csv, r.stdout


def cli_error(cli, *args):
    """The command line's error line (after any warnings)."""
    r = cli(*args)
    assert r.returncode == 2, r.stderr
    line = r.stderr.strip().splitlines()[-1]
    assert line.startswith("error: ")
    return line[len("error: "):]


def untimed(text):
    """Text with its wall-clock times (`0.12 s`) masked."""
    return re.sub(r"\d+\.\d+ s\b", "<t> s", text)


def test_sensitivity_equals_cli(cli, tmp_path):
    args = ["--points", 4, "--draws", 256, "--bootstrap", 100, "--bootstrap-seed", 3,
            "--thresholds", "0.1,0.15", "--seed", 11, "--backend", "cpu"]
    doc, csv, stdout = cli_json(cli, tmp_path, "sensitivity", *args)
    res = gpu_amcs.sensitivity(points=4, draws=256, bootstrap=100, bootstrap_seed=3,
                               thresholds=[0.1, 0.15], seed=11, backend="cpu")
    assert res.to_dict() == doc
    assert res.to_json() == (tmp_path / "cli.json").read_text()
    assert res.to_text() == stdout
    assert res.to_csv() == (csv / "indices.csv").read_text()
    assert res.to_csv("indices.csv") == res.to_csv("indices") == res.to_csv()
    # The figures and every file of the report, from the same Report as the command line's.
    svg = tmp_path / "svg"
    run_ok(cli, "sensitivity", *args, "--svg", svg)
    names = sorted(p.name for p in svg.iterdir())
    assert names, "the command line writes figures"
    for name in names:
        assert res.to_svg(name) == (svg / name).read_text()
    files = res.files()
    assert files["indices.csv"] == res.to_csv()
    assert json.loads(files["sensitivity.json"]) == doc
    with pytest.raises(ValueError, match=r"^figure: unknown figure 'nope' \(this report has "):
        res.to_svg("nope")
    with pytest.raises(ValueError, match=r"^table: unknown table 'nope' \(this report has \"indices\"\)"):
        res.to_csv("nope")
    w = doc["sensitivity"]["quantities"][0]
    assert [n for n, _ in res.first_order] == [i["name"] for i in w["inputs"]]
    # A different seed gives a different document: the comparison can fail.
    other = gpu_amcs.sensitivity(points=4, draws=256, bootstrap=100, bootstrap_seed=3,
                                 thresholds=[0.1, 0.15], seed=12, backend="cpu")
    assert other.to_dict() != doc


def test_sensitivity_with_nominal_reference_and_points_file(cli, tmp_path):
    m = gpu_amcs.Model.preset("tx60")
    rng = np.random.default_rng(2)
    q = rng.uniform(0.4 * m.limits[:, 0], 0.4 * m.limits[:, 1], size=(5, 6)).round(4)
    pts = tmp_path / "q.csv"
    pts.write_text("q1,q2,q3,q4,q5,q6\n" + "\n".join(",".join(map(str, r)) for r in q) + "\n")
    doc, _, _ = cli_json(cli, tmp_path, "sensitivity", "--points-file", pts, "--draws", 128,
                         "--reference", "nominal", "--backend", "cpu", "-q")
    by_file = gpu_amcs.sensitivity(points_file=pts, draws=128, reference="nominal",
                                   backend="cpu")
    by_array = gpu_amcs.sensitivity(m, q_deg=q, draws=128, reference="nominal", backend="cpu")
    assert by_file.to_dict() == doc
    assert by_array.to_dict() == doc


@pytest.mark.parametrize("method", ["subset", "mc"])
def test_tail_equals_cli(cli, tmp_path, method):
    thresholds = "0.12,0.2" if method == "subset" else "0.1,0.12"
    args = ["--points", 4, "--threshold", thresholds, "--max-evaluations", 40000,
            "--samples-per-level", 500, "--p0", 0.2, "--cov", 0.2, "--method", method,
            "--backend", "cpu", "--seed", 5]
    doc, csv, stdout = cli_json(cli, tmp_path, "tail", *args)
    res = gpu_amcs.tail(points=4, threshold=[float(t) for t in thresholds.split(",")],
                        max_evaluations=40000, samples_per_level=500, p0=0.2, cov=0.2,
                        method=method, backend="cpu", seed=5)
    assert without_timing(res.to_dict()) == without_timing(doc)
    assert "seconds" in doc["tail"]  # the one field left out
    assert untimed(res.to_text()) == untimed(stdout)
    assert res.to_csv() == (csv / "tail.csv").read_text()
    assert res.p_f == [e["p_f"] for e in doc["tail"]["estimates"]]
    assert res.evaluations == doc["tail"]["evaluations"]


def test_tail_takes_one_threshold_as_a_number(cli, tmp_path):
    doc, _, _ = cli_json(cli, tmp_path, "tail", "--points", 3, "--threshold", 0.15,
                         "--max-evaluations", 20000, "--backend", "cpu", "-q")
    res = gpu_amcs.tail(points=3, threshold=0.15, max_evaluations=20000, backend="cpu")
    assert without_timing(res.to_dict()) == without_timing(doc)


@pytest.mark.parametrize("grid", ["plane", "volume"])
def test_map_equals_cli(cli, tmp_path, grid):
    if grid == "plane":
        args = ["--plane", "xz", "--at", 50, "--cells", "5,4", "--box-size", "700,600,600"]
        kw = dict(plane="xz", at=50, cells=[5, 4], box_size=[700, 600, 600])
    else:
        args = ["--cells", "3,3,2", "--free-orientation", "--ik-seeds", 4,
                "--reference-q", "0,-20,100,0,30,0"]
        kw = dict(cells=[3, 3, 2], free_orientation=True, ik_seeds=4,
                  reference_q=[0, -20, 100, 0, 30, 0])
    doc, csv, stdout = cli_json(cli, tmp_path, "map", *args, "--draws", 400, "--thresholds",
                                "0.05,0.1", "--seed", 9, "--backend", "cpu")
    res = gpu_amcs.map(**kw, draws=400, thresholds=[0.05, 0.1], seed=9, backend="cpu")
    assert without_timing(res.to_dict()) == without_timing(doc)
    assert res.reached == doc["map"]["reached"] > 0
    assert untimed(res.to_text()) == untimed(stdout)
    assert res.to_csv() == (csv / "map.csv").read_text()
    other = gpu_amcs.map(**kw, draws=400, thresholds=[0.05, 0.1], seed=10, backend="cpu")
    assert without_timing(other.to_dict()) != without_timing(doc)


def test_map_of_a_model_object_with_an_orientation(cli, tmp_path):
    m = gpu_amcs.Model.preset("ur10e")
    model_file = tmp_path / "m.toml"
    model_file.write_text(m.to_toml())
    doc, _, _ = cli_json(cli, tmp_path, "map", "--model", model_file, "--plane", "xy", "--at",
                         300, "--cells", "4,4", "--orientation", "180,0,90", "--draws", 200,
                         "--backend", "cpu", "-q")
    res = gpu_amcs.map(m, plane="xy", at=300, cells=[4, 4], orientation=[180, 0, 90],
                       draws=200, backend="cpu")
    assert without_timing(res.to_dict()) == without_timing(doc)


@pytest.fixture(scope="module")
def sweeps(cli, tmp_path_factory):
    d = tmp_path_factory.mktemp("sweeps")
    out = {}
    for name, args in [("three", ["--runs", 3, "--step", 5]),
                       ("short", ["--runs", 2, "--range", 5, "--step", 1])]:
        f = d / f"{name}.csv"
        run_ok(cli, "simulate", *args, "-o", f)
        out[name] = f
    return out


@pytest.mark.parametrize("case", [
    ("three", []),
    ("three", ["--covariance", "--fit", "point-cloud"]),
    ("short", ["--no-prior"]),
    ("short", ["--no-refine", "--base-known", "--preset", "tx60"]),
])
def test_identify_equals_cli(cli, tmp_path, sweeps, case):
    name, args = case
    f = sweeps[name]
    out = tmp_path / "m.toml"
    r = run_ok(cli, "identify", f, *args, "--out", out)
    kw = dict(covariance="--covariance" in args, no_prior="--no-prior" in args,
              no_refine="--no-refine" in args, base_known="--base-known" in args,
              fit="point-cloud" if "point-cloud" in args else "commanded")
    res = gpu_amcs.identify(f, **kw)
    # The file is the model, then (after a whole-chain fit) its provenance; the model's own
    # to_toml() keeps the provenance (issue 34).
    assert res.model.to_toml() == res.to_toml() == out.read_text()
    # stdout is the text, then the line naming the file written.
    assert r.stdout == res.to_text() + f"wrote {out}\n"
    warnings = [line[len("warning: "):] for line in r.stderr.splitlines()
                if line.startswith("warning: ")]
    assert res.warnings == warnings
    if name == "short" and "--no-prior" in args:
        assert warnings  # the case meant to warn does
    verbose = run_ok(cli, "identify", f, *args, "--verbose")
    assert verbose.stdout == res.to_text(verbose=True)
    # The --json document, field for field (identification has no timing fields).
    doc_file = tmp_path / "identify.json"
    run_ok(cli, "identify", f, *args, "--out", tmp_path / "m2.toml", "--json", doc_file, "-q")
    cli_doc = json.loads(doc_file.read_text())
    assert res.to_dict() == without_timing(cli_doc)
    assert res.to_json() == doc_file.read_text()
    d = res.to_dict()
    runs = d["identify"]["runs"]
    assert len(runs) == len(res.models) == (3 if name == "three" else 2)
    assert [j["joint"] for j in runs[0]["joints"]] == [1, 2, 3, 4, 5, 6]


def test_identify_beyond_geometry_equals_cli(cli, tmp_path):
    """beyond_geometry=True: the command line's --beyond-geometry check, the same document and
    the same model file, which carries the joint errors (the default finds them too; "off"
    does not)."""
    poses = tmp_path / "poses.csv"
    run_ok(cli, "simulate", "--poses", 120, "--seed", 3, "--tracker-sigma", 0.01,
           "--compliance", 1, "--harmonics", 1, "-o", poses)
    doc_file = tmp_path / "id.json"
    run_ok(cli, "identify", poses, "--tracker-sigma", 0.01, "--beyond-geometry",
           "--out", tmp_path / "m.toml", "--json", doc_file)
    res = gpu_amcs.identify(poses, tracker_sigma=0.01, beyond_geometry=True)
    assert res.to_dict() == json.loads(doc_file.read_text())
    check = res.to_dict()["identify"]["runs"][0]["chain"]["beyond_geometry"]
    assert check["predicts_better"] and check["parameters"] > 0
    assert check["loo_rms_extended_mm"] < check["loo_rms_geometric_mm"]
    assert check["kept"]
    assert "[joint_errors]" in res.to_toml()
    assert res.to_toml() == (tmp_path / "m.toml").read_text()
    # The default (auto) finds the lack of fit and keeps them as well; "off" (or False) does not.
    assert gpu_amcs.identify(poses, tracker_sigma=0.01).to_toml() == res.to_toml()
    plain = gpu_amcs.identify(poses, tracker_sigma=0.01, beyond_geometry="off")
    assert "beyond_geometry" not in plain.to_dict()["identify"]["runs"][0]["chain"]
    assert plain.to_dict()["identify"]["runs"][0]["chain"]["joint_error_fit"] == "off"
    assert "[joint_errors]" not in plain.to_toml()
    assert gpu_amcs.identify(poses, tracker_sigma=0.01, beyond_geometry=False).to_toml() == \
        plain.to_toml()
    # "check" reports the check and keeps the geometry alone: the "off" model's geometry.
    checked = gpu_amcs.identify(poses, tracker_sigma=0.01, beyond_geometry="check")
    report = checked.to_dict()["identify"]["runs"][0]["chain"]["beyond_geometry"]
    assert report["predicts_better"] and not report["kept"]
    assert checked.to_toml() == plain.to_toml()
    with pytest.raises(ValueError, match="beyond_geometry"):
        gpu_amcs.identify(poses, tracker_sigma=0.01, beyond_geometry="sometimes")
    # Harmonic orders per joint: the command line's --harmonic-orders, the same document.
    doc_file = tmp_path / "orders.json"
    run_ok(cli, "identify", poses, "--tracker-sigma", 0.01, "--harmonic-orders", "2,2,1,0,0,0",
           "--json", doc_file)
    set_orders = gpu_amcs.identify(poses, tracker_sigma=0.01, harmonic_orders=[2, 2, 1, 0, 0, 0])
    assert set_orders.to_dict() == json.loads(doc_file.read_text())
    selection = set_orders.to_dict()["identify"]["runs"][0]["chain"]["beyond_geometry"]["selection"]
    assert selection["harmonic_orders"] == [2, 2, 1, 0, 0, 0] and not selection["by_data"]
    with pytest.raises(ValueError, match="harmonic_orders: J3: order 3"):
        gpu_amcs.identify(poses, tracker_sigma=0.01, harmonic_orders=[2, 2, 3, 0, 0, 0])
    # The payload at the task: the command line's --payload-kg, refused for a geometric model.
    bent = gpu_amcs.Model.from_file(tmp_path / "m.toml")
    kw = dict(points=10, draws=20000, backend="cpu")
    heavy = gpu_amcs.mcs(bent, payload_kg=8.0, **kw)
    doc_file = tmp_path / "heavy.json"
    run_ok(cli, "mcs", "--model", tmp_path / "m.toml", "--points", 10, "--draws", 20000,
           "--backend", "cpu", "--payload-kg", 8, "--json", doc_file)
    assert heavy.estimate == json.loads(doc_file.read_text())["result"]["estimate"]
    assert heavy.estimate > 1.5 * gpu_amcs.mcs(bent, **kw).estimate
    with pytest.raises(ValueError, match="payload_kg"):
        gpu_amcs.mcs(plain.model, payload_kg=5.0, **kw)


def test_identify_poses_in_a_tracker_frame_equals_cli(cli, tmp_path):
    poses = tmp_path / "poses.csv"
    run_ok(cli, "simulate", "--poses", 60, "--seed", 3, "-o", poses)
    out = tmp_path / "m.toml"
    doc_file = tmp_path / "id.json"
    r = run_ok(cli, "identify", poses, "--tracker-sigma", 0.01, "--fix", "a1",
               "--uncertainty", "montecarlo", "--mc-draws", 50, "--out", out, "--json", doc_file)
    res = gpu_amcs.identify(poses, tracker_sigma=0.01, fix=["a1"], uncertainty="montecarlo",
                            mc_draws=50)
    assert res.to_toml() == out.read_text()
    assert "[provenance]" in res.to_toml()
    assert res.to_dict() == json.loads(doc_file.read_text())
    assert r.stdout == res.to_text() + f"wrote {out}\n"
    chain = res.to_dict()["identify"]["runs"][0]["chain"]
    assert chain["identifiability"]["fixed_by_user"] == ["a1"]
    assert chain["monte_carlo"]["draws"] == 50
    # A placed model: tail and sensitivity draw the placement in the measurement frame and
    # leave it out with frame="base", each equal to the command line's --frame.
    model_file = tmp_path / "placed.toml"
    model_file.write_text(res.to_toml())
    placed = gpu_amcs.Model.from_file(model_file)
    dims = {}
    for frame in ["measurement", "base"]:
        t = gpu_amcs.tail(placed, points=5, threshold=0.03, backend="cpu", frame=frame)
        doc, _, _ = cli_json(cli, tmp_path, "tail", "--model", model_file, "--points", 5,
                             "--threshold", 0.03, "--backend", "cpu", "--frame", frame)
        assert without_timing(t.to_dict()) == without_timing(doc)
        dims[frame] = t.to_dict()["tail"]["dimension"]
        note = "base placement drawn" if frame == "measurement" else "left out"
        assert any(note in n for n in t.notes), t.notes
        s = gpu_amcs.sensitivity(placed, points=5, draws=256, bootstrap=100, backend="cpu",
                                 frame=frame)
        doc, _, _ = cli_json(cli, tmp_path, "sensitivity", "--model", model_file, "--points", 5,
                             "--draws", 256, "--bootstrap", 100, "--backend", "cpu",
                             "--frame", frame)
        assert s.to_dict() == doc
        assert ("base_yaw" in s.to_dict()["sensitivity"]["parameters"]) == (frame == "measurement")
    # The placement's six inputs are drawn in the measurement frame only.
    assert dims["measurement"] == dims["base"] + 6
    with pytest.raises(ValueError, match=r"^frame: "):
        gpu_amcs.tail(placed, points=5, threshold=0.03, frame="tracker")
    with pytest.raises(ValueError, match=r"^tracker_sigma: "):
        gpu_amcs.identify(poses, tracker_sigma=-1.0)
    with pytest.raises(ValueError, match=r"^uncertainty: "):
        gpu_amcs.identify(poses, uncertainty="bootstrap")
    # The library's identification job names the setting: the same message after the keyword
    # as after the command line's flag.
    for kwargs, keyword, flags, want in [
        (dict(fit="point-cloud"), "fit", ["--fit", "point-cloud"], "applies to sweeps only"),
        (dict(no_refine=True), "no_refine", ["--no-refine"], "applies to sweeps only"),
        (dict(uncertainty="montecarlo", mc_draws=5), "mc_draws",
         ["--uncertainty", "montecarlo", "--mc-draws", "5"], "at least 10 re-identifications"),
    ]:
        with pytest.raises(ValueError) as e:
            gpu_amcs.identify(poses, **kwargs)
        py = str(e.value)
        assert py.startswith(f"{keyword}: {want}"), py
        flag = next(f for f in flags if f.startswith("--") and f != "--uncertainty")
        assert cli_error(cli, "identify", poses, *flags) == flag + py[len(keyword):]


def test_identify_several_reflectors_equals_cli(cli, tmp_path):
    """Several reflectors per pose (a target column) identified together: Python and the
    command line give the same model and report; validate compares the model's own reflector."""
    poses = tmp_path / "poses.csv"
    run_ok(cli, "simulate", "--poses", 40, "--seed", 4, "--other-target", "-45,25,95",
           "--other-target", "5,55,60", "-o", poses)
    out = tmp_path / "m.toml"
    doc_file = tmp_path / "id.json"
    run_ok(cli, "identify", poses, "--out", out, "--json", doc_file)
    res = gpu_amcs.identify(poses)
    assert res.to_toml() == out.read_text()
    assert 'target = "T1"' in res.to_toml()
    assert res.to_dict() == json.loads(doc_file.read_text())
    chain = res.to_dict()["identify"]["runs"][0]["chain"]
    assert chain["targets"] == ["T1", "T2", "T3"]
    names = [p["name"] for p in chain["parameters"]]
    assert names[-6:] == ["target2_x", "target2_y", "target2_z", "target3_x", "target3_y",
                          "target3_z"]
    v = gpu_amcs.validate(out, poses, check_draws=0)
    assert v.to_dict()["target"] == {"label": "T1", "left_out": 80}


def test_identify_with_a_nominal_model(cli, tmp_path, sweeps):
    nominal = gpu_amcs.Model.preset("tx60")
    nf = tmp_path / "nominal.toml"
    nf.write_text(nominal.to_toml())
    out = tmp_path / "m.toml"
    run_ok(cli, "identify", sweeps["three"], "--nominal", nf, "--out", out)
    assert gpu_amcs.identify(sweeps["three"], nominal=nominal).to_toml() == out.read_text()
    assert gpu_amcs.identify(sweeps["three"], nominal=nf).to_toml() == out.read_text()


def test_identify_strict_refuses_implausible_results(cli, sweeps):
    want = cli_error(cli, "identify", sweeps["short"], "--no-prior", "--strict")
    n = int(want.split("--strict: ")[1].split(" ")[0])
    assert n >= 2, want
    with pytest.raises(ValueError, match=rf"^strict: {n} implausible result\(s\): "):
        gpu_amcs.identify(sweeps["short"], no_prior=True, strict=True)


@pytest.mark.parametrize("cli_args, call, kw", [
    (["sensitivity", "--draws", 100], gpu_amcs.sensitivity, dict(draws=100)),
    (["sensitivity", "--bootstrap", 5], gpu_amcs.sensitivity, dict(bootstrap=5)),
    (["tail", "--threshold", 0.2, "--cov", 2], gpu_amcs.tail, dict(threshold=0.2, cov=2)),
    (["tail", "--threshold=-1"], gpu_amcs.tail, dict(threshold=-1)),
    (["tail", "--threshold", 0.2, "--p0", 0.7], gpu_amcs.tail, dict(threshold=0.2, p0=0.7)),
    (["map", "--draws", 0], gpu_amcs.map, dict(draws=0)),
    (["map", "--cells", "0,3,3"], gpu_amcs.map, dict(cells=[0, 3, 3])),
    (["map", "--plane", "xy", "--at", 100, "--cells", "3,3,3"], gpu_amcs.map,
     dict(plane="xy", at=100, cells=[3, 3, 3])),
    (["map", "--orientation", "1,2"], gpu_amcs.map, dict(orientation=[1, 2])),
    (["map", "--reference-q", "1,2,3"], gpu_amcs.map, dict(reference_q=[1, 2, 3])),
    # The grid, the prediction's draws and a run's draws, as the library's jobs check them.
    (["map", "--plane", "xy"], gpu_amcs.map, dict(plane="xy")),
    (["map", "--at", 100], gpu_amcs.map, dict(at=100)),
    (["plan", "--draws", 50, "--out", "never.csv"], gpu_amcs.plan, dict(draws=50)),
    # What a plan does not use, and its tracker's own figures, as the plan job refuses them.
    (["plan", "--reference", "nominal", "--out", "never.csv"], gpu_amcs.plan,
     dict(reference="nominal")),
    (["plan", "--frame", "base", "--out", "never.csv"], gpu_amcs.plan, dict(frame="base")),
    (["plan", "--tracker-at", "3000,0,500", "--tracker-range", 0, "--out", "never.csv"],
     gpu_amcs.plan, dict(tracker_at=[3000, 0, 500], tracker_range=0)),
    (["plan", "--tracker-at", "3000,0,500", "--max-incidence", 91, "--out", "never.csv"],
     gpu_amcs.plan, dict(tracker_at=[3000, 0, 500], max_incidence=91)),
    (["mcs", "--draws", 10], gpu_amcs.mcs, dict(draws=10)),
    (["sensitivity", "--points", 0], gpu_amcs.sensitivity, dict(points=0)),
    (["tail", "--threshold", 0.2, "--preset", "tx90"], gpu_amcs.tail,
     dict(threshold=0.2, preset="tx90")),
    (["sensitivity", "--box-size", "0,1,1"], gpu_amcs.sensitivity, dict(box_size=[0, 1, 1])),
    (["sensitivity", "--backend", "cpu", "--adapter", "x"], gpu_amcs.sensitivity,
     dict(backend="cpu", adapter="x")),
])
def test_errors_are_the_cli_line_with_the_keyword(cli, cli_args, call, kw):
    """The command line's one-line message, with each flag spelled as the keyword."""
    want = cli_error(cli, *map(str, cli_args))
    for flag in sorted(re.findall(r"--[a-z][a-z-]*", want), key=len, reverse=True):
        want = want.replace(flag, flag[2:].replace("-", "_"))
    with pytest.raises(ValueError) as e:
        call(**kw)
    assert str(e.value) == want


def test_problem_errors_name_the_keyword(tmp_path):
    bad = tmp_path / "bad.csv"
    bad.write_text("q1,q2,q3,q4,q5,q6\n0,0,0,0,0,0\n999,0,0,0,0,0\n")
    with pytest.raises(ValueError, match=r"^points_file: .*bad.csv: test point 2: q1 = 999"):
        gpu_amcs.sensitivity(points_file=bad, draws=64)
    with pytest.raises(ValueError, match=r"^q_deg: test point 1: q1 = 999"):
        gpu_amcs.tail(q_deg=[[999, 0, 0, 0, 0, 0]], threshold=0.2)
    with pytest.raises(ValueError, match=r"^preset: unknown preset 'tx90'"):
        gpu_amcs.mcs(gpu_amcs.Model.preset("tx60"), preset="tx90", reference="nominal",
                     draws=1000)
    with pytest.raises(ValueError, match=r"^preset: unknown preset 'tx90'"):
        gpu_amcs.map(preset="tx90")
    with pytest.raises(ValueError, match="method: unknown method 'is'"):
        gpu_amcs.tail(threshold=0.2, method="is")
    with pytest.raises(ValueError, match="plane: unknown plane 'ab'"):
        gpu_amcs.map(plane="ab", at=0)
    with pytest.raises(ValueError, match="orientation and free_orientation exclude"):
        gpu_amcs.map(orientation=[180, 0, 0], free_orientation=True)
    with pytest.raises(ValueError, match="fit: unknown fit"):
        gpu_amcs.identify("x.csv", fit="circle")


def test_plan_equals_cli(cli, tmp_path):
    """gpu_amcs.plan: the document, summary and design file of `gpu-amcs plan`."""
    design = tmp_path / "design.csv"
    args = ["--points", 12, "--poses", 14, "--candidates", 300, "--draws", 5000,
            "--threshold", "0.02,0.04", "--backend", "cpu", "--seed", 3]
    out = tmp_path / "plan.json"
    r = run_ok(cli, "plan", *args, "--out", design, "--json", out)
    doc = json.loads(out.read_text())
    res = gpu_amcs.plan(points=12, poses=14, candidates=300, draws=5000, threshold=[0.02, 0.04],
                        backend="cpu", seed=3)
    assert without_timing(res.to_dict()) == without_timing(doc)
    assert untimed(res.to_text()) == untimed(r.stdout)
    assert res.design_csv() == design.read_text()
    # The plan's tables and figure, as `--csv` and `--svg` write them.
    csv, svg = tmp_path / "plan-csv", tmp_path / "plan-svg"
    run_ok(cli, "plan", *args, "--out", tmp_path / "design2.csv", "--csv", csv, "--svg", svg)
    for f in csv.iterdir():
        assert res.to_csv(f.name) == f.read_text(), f.name
    for f in svg.iterdir():
        assert res.to_svg(f.name) == f.read_text(), f.name
    assert len(res.design) == 14
    assert res.reliability == [(x["threshold"], x["r"]) for x in doc["prediction"]["reliability"]]


def test_plan_errors_name_the_keyword(cli):
    msg = cli_error(cli, "plan", "--points", 5, "--poses", 8, "--backend", "cpu",
                    "--out", "never.csv")
    assert "--poses" in msg
    with pytest.raises(ValueError, match=r"\(poses\)"):
        gpu_amcs.plan(points=5, poses=8, backend="cpu")
    with pytest.raises(ValueError, match=r"tracker_at"):
        gpu_amcs.plan(points=5, tracker_at=[1, 2], backend="cpu")


def test_plan_refuses_a_link_radius_nothing_checks_as_the_cli(cli):
    """A link radius without the self-collision check, a floor or a box: the plan job's
    refusal, naming the keywords where the command line names the flags."""
    msg = cli_error(cli, "plan", "--link-radius", 100, "--no-self-collision", "--out",
                    "never.csv")
    assert "--floor" in msg and "--keep-out" in msg
    for flag, kw in [("--no-self-collision", "self_collision"), ("--link-radius", "link_radius"),
                     ("--floor", "floor"), ("--keep-out", "keep_out")]:
        msg = msg.replace(flag, kw)
    with pytest.raises(ValueError) as e:
        gpu_amcs.plan(points=5, link_radius=100, self_collision=False, backend="cpu")
    assert str(e.value) == msg
    # With a floor the radius is used.
    res = gpu_amcs.plan(points=5, poses=12, candidates=300, draws=1000, link_radius=40,
                        self_collision=False, floor=-400, backend="cpu")
    assert len(res.design) == 12


def test_plan_workcell_and_program_equal_cli(cli, tmp_path):
    """floor, keep_out and program(): the command line's --floor, --keep-out and --program."""
    design, prog = tmp_path / "design.csv", tmp_path / "cal.script"
    run_ok(cli, "plan", "--preset", "ur5e", "--points", 6, "--poses", 14, "--candidates", 300,
           "--draws", 2000, "--backend", "cpu", "--seed", 3, "--floor", -20,
           "--keep-out", "300,-800,-20,900,-300,400", "--out", design, "--program", prog)
    res = gpu_amcs.plan(preset="ur5e", points=6, poses=14, candidates=300, draws=2000,
                        backend="cpu", seed=3, floor=-20,
                        keep_out=[[900, -300, 400, 300, -800, -20]])
    assert res.design_csv() == design.read_text()
    assert res.program("urscript", name="cal") == prog.read_text()
    assert res.program("script", name="cal") == res.program("urscript", name="cal")
    assert "MODULE" in res.program("rapid") and "PTP" in res.program("krl")
    # Without the floor and the box the design differs: the workcell is used.
    free = gpu_amcs.plan(preset="ur5e", points=6, poses=14, candidates=300, draws=2000,
                         backend="cpu", seed=3)
    assert free.design_csv() != res.design_csv()
    with pytest.raises(ValueError, match=r"keep_out\[0\]: a box is six numbers"):
        gpu_amcs.plan(preset="ur5e", points=6, keep_out=[[0, 0, 0, 1, 1]], backend="cpu")
    with pytest.raises(ValueError, match=r"language: expected urscript, rapid or krl"):
        res.program("gcode")
    # approach: the command line's --approach, in the design's sides and the program's moves.
    sided, prog2 = tmp_path / "sided.csv", tmp_path / "cal2.script"
    run_ok(cli, "plan", "--preset", "ur5e", "--points", 6, "--poses", 14, "--candidates", 300,
           "--draws", 2000, "--backend", "cpu", "--seed", 3, "--floor", -20,
           "--keep-out", "300,-800,-20,900,-300,400", "--out", sided, "--program", prog2,
           "--approach", "negative")
    neg = gpu_amcs.plan(preset="ur5e", points=6, poses=14, candidates=300, draws=2000,
                        backend="cpu", seed=3, floor=-20,
                        keep_out=[[900, -300, 400, 300, -800, -20]], approach="negative")
    assert neg.design_csv() == sided.read_text()
    assert neg.program("urscript", name="cal2") == prog2.read_text()
    assert sided.read_text().splitlines()[1].endswith(",-1,-1,-1,-1,-1,-1")
    with pytest.raises(ValueError, match=r'approach: expected "positive" or "negative"'):
        gpu_amcs.plan(preset="ur5e", points=6, approach="up", backend="cpu")


def test_discrepancy_term_is_carried_and_can_be_left_out(cli, tmp_path):
    # Noise not stated: the identified model carries a discrepancy term drawn from its
    # residuals; mcs draws it (as the command line does) unless discrepancy=False
    # (the command line's --no-discrepancy).
    poses = tmp_path / "poses.csv"
    run_ok(cli, "simulate", "--poses", 60, "--seed", 3, "-o", poses)
    res = gpu_amcs.identify(poses)
    model_file = tmp_path / "m.toml"
    model_file.write_text(res.to_toml())
    m = gpu_amcs.Model.from_file(model_file)
    d = m.discrepancy
    assert d is not None and d["drawn"] and d["noise"] == "unknown"
    assert len(d["residual_norms"]) == 60 and d["robot_share"] == 1.0
    lof = res.to_dict()["identify"]["runs"][0]["chain"]["lack_of_fit"]
    assert lof["carried"] and 0.8 <= lof["loo"]["coverage_95"] <= 1.0
    with_term = gpu_amcs.mcs(m, points=10, draws=20000, backend="cpu")
    without = gpu_amcs.mcs(m, points=10, draws=20000, backend="cpu", discrepancy=False)
    assert with_term.estimate > without.estimate + 0.005
    for extra, r in [([], with_term), (["--no-discrepancy"], without)]:
        doc, _, _ = cli_json(cli, tmp_path, "mcs", "--model", model_file, "--points", 10,
                             "--draws", 20000, "--backend", "cpu", *extra)
        assert without_timing(r.to_dict()) == without_timing(doc)
    assert any("model discrepancy drawn" in n for n in with_term.notes), with_term.notes
    assert gpu_amcs.Model.preset("tx60").discrepancy is None


def test_compensation_is_fitted_applied_and_can_be_left_out(cli, tmp_path):
    # A simulated robot with joint compliance and gear harmonics leaves structure a Gaussian
    # process over the joint angles predicts: the identified model carries a compensation, fk
    # adds its mean (as `gpu-amcs fk` does) and compensation=False / no_compensation=True leave
    # it out. (A geometric robot leaves white residuals and gets none.) The joint errors are
    # left out (by default they would be fitted and leave nothing for a process to predict).
    poses = tmp_path / "poses.csv"
    run_ok(cli, "simulate", "--poses", 150, "--seed", 3, "--compliance", 1, "--harmonics", 1,
           "-o", poses)
    res = gpu_amcs.identify(poses, beyond_geometry="off")
    model_file = tmp_path / "m.toml"
    model_file.write_text(res.to_toml())
    m = gpu_amcs.Model.from_file(model_file)
    c = m.discrepancy["compensation"]
    assert c is not None and c["poses"] == 150, c
    assert c["loo_rms_compensated_mm"] < c["loo_rms_geometric_mm"]
    q = np.array([[10.0, 20.0, 70.0, 5.0, 30.0, -10.0], [-30.0, 40.0, 100.0, 0.0, -40.0, 20.0]])
    with_c = m.fk(q)
    without_c = m.fk(q, compensation=False)
    gap = np.linalg.norm(with_c - without_c, axis=1)
    assert np.all(gap > 1e-6) and np.all(gap < 1.0), gap
    task = tmp_path / "q.csv"
    np.savetxt(task, q, delimiter=",", header="q1,q2,q3,q4,q5,q6", comments="")
    out = run_ok(cli, "fk", "--model", model_file, "--points-file", task).stdout
    text = out if isinstance(out, str) else out.decode()
    rows = np.loadtxt(io.StringIO(text), delimiter=",", skiprows=1)
    assert np.allclose(rows[:, 6:9], with_c, rtol=0, atol=1e-9)
    plain = gpu_amcs.identify(poses, no_compensation=True)
    assert "[discrepancy.compensation]" not in plain.to_toml()
    assert "[discrepancy.compensation]" in res.to_toml()


def test_identify_columns_equals_cli(cli, tmp_path):
    """columns= and delimiter=: the command line's --columns and --delimiter, the same model."""
    own = tmp_path / "own.csv"
    run_ok(cli, "simulate", "--poses", 60, "--seed", 4, "--tracker-sigma", 0.01, "-o", own)
    lines = own.read_text().splitlines()
    log = ["J1;J2;J3;J4;J5;J6;X;Y;Z"]
    for line in lines[1:]:
        v = [float(x) for x in line.split(",")]
        log.append(";".join([repr(a) for a in v[:6]] + [repr(x / 1000.0) for x in v[6:]]))
    data = tmp_path / "log.csv"
    data.write_text("\n".join(log) + "\n")
    cmap = ",".join([f"q{k}=J{k}" for k in range(1, 7)] + ["x=X:m", "y=Y:m", "z=Z:m"])
    run_ok(cli, "identify", data, "--columns", cmap, "--delimiter", ";", "--tracker-sigma", 0.01,
           "--out", tmp_path / "m.toml")
    res = gpu_amcs.identify(data, columns=cmap, delimiter=";", tracker_sigma=0.01)
    assert res.to_toml() == (tmp_path / "m.toml").read_text()
    with pytest.raises(ValueError, match="columns: .*'K1'"):
        gpu_amcs.identify(data, columns="q1=K1", delimiter=";")
    with pytest.raises(ValueError, match="delimiter"):
        gpu_amcs.identify(data, columns=cmap, delimiter=";;")
