"""Validation from Python equals the command line's (issue 34): ``IdentifyResult.model.to_toml()``
keeps ``[provenance]`` (the frame and the nominal model), ``gpu_amcs.validate`` uses the model's
own nominal with its own best-fit placement on tracker data, and neither front end silently
changes the frame."""

import json

import pytest

import gpu_amcs


def assert_close(a, b, rel=1e-9, path="doc"):
    """Equal documents, numbers within `rel` relative (or 1e-12 absolute)."""
    if isinstance(a, dict):
        assert isinstance(b, dict) and a.keys() == b.keys(), path
        for k in a:
            assert_close(a[k], b[k], rel, f"{path}.{k}")
    elif isinstance(a, list):
        assert isinstance(b, list) and len(a) == len(b), path
        for i, (x, y) in enumerate(zip(a, b)):
            assert_close(x, y, rel, f"{path}[{i}]")
    elif isinstance(a, float) and isinstance(b, (int, float)):
        assert abs(a - b) <= max(rel * abs(b), 1e-12), f"{path}: {a} vs {b}"
    else:
        assert a == b, f"{path}: {a!r} vs {b!r}"


def run_ok(cli, *args):
    r = cli(*[str(a) for a in args])
    assert r.returncode == 0, r.stderr
    return r


@pytest.fixture
def ur5e(cli, tmp_path):
    """A UR5e identified from simulated tracker poses: (result, held-out poses)."""
    poses, truth, held = tmp_path / "poses.csv", tmp_path / "truth.toml", tmp_path / "held.csv"
    run_ok(cli, "simulate", "--preset", "ur5e", "--poses", 60, "--seed", 3, "-o", poses,
           "--truth-out", truth)
    run_ok(cli, "simulate", "--preset", "ur5e", "--poses", 40, "--seed", 11, "--truth", truth,
           "-o", held)
    return gpu_amcs.identify(poses, preset="ur5e"), held


def test_model_to_toml_keeps_provenance(ur5e, tmp_path):
    res, _ = ur5e
    text = res.model.to_toml()
    assert text == res.to_toml()
    assert "[provenance]" in text and "nominal_sha256" in text
    assert 'frame = "measurement"' in text
    # Read back, written again: the same table.
    f = tmp_path / "m.toml"
    f.write_text(text)
    again = gpu_amcs.Model.from_file(f).to_toml()
    assert "[provenance]" in again and "nominal_model" in again
    # A per-run model and a preset have none.
    assert "[provenance]" not in gpu_amcs.Model.preset("ur5e").to_toml()


def test_validate_equals_cli(cli, ur5e, tmp_path):
    res, held = ur5e
    f = tmp_path / "m.toml"
    f.write_text(res.model.to_toml())
    doc_file = tmp_path / "v.json"
    r = run_ok(cli, "validate", "--model", f, held, "--nominal", "--check-draws", 2000,
               "--json", doc_file)
    doc = json.loads(doc_file.read_text())
    for model in [f, str(f)]:
        v = gpu_amcs.validate(model, held, nominal=True, check_draws=2000)
        assert v.frame == "measurement"
        assert v.to_dict() == doc
    # The model in memory holds the fit's radians, its file decimal degrees: the same to
    # rounding (the errors agree to 1e-13 mm), so within 1e-9 relative.
    v = gpu_amcs.validate(res.model, held, nominal=True, check_draws=2000)
    assert v.frame == "measurement"
    assert_close(v.to_dict(), doc)
    v = gpu_amcs.validate(f, held, nominal=True, check_draws=2000)
    assert r.stdout == v.to_text()
    d = v.to_dict()
    assert d["nominal"]["name"] == "Universal Robots UR5e"
    assert d["nominal"]["source"]["kind"] == "recorded"
    assert "by least squares" in d["nominal"]["method"]
    # The recorded nominal given as a preset or a model: the same; another robot's: refused,
    # by both front ends, with the same line.
    same = gpu_amcs.validate(res.model, held, nominal=gpu_amcs.Model.preset("ur5e"),
                             check_draws=0)
    assert same.to_dict()["nominal"]["errors_mm"] == d["nominal"]["errors_mm"]
    with pytest.raises(ValueError, match=r"^nominal: .*is not the one") as e:
        gpu_amcs.validate(res.model, held, nominal=True, preset="tx60")
    r = cli("validate", "--model", str(f), str(held), "--nominal", "--preset", "tx60")
    assert r.returncode == 2 and "is not the one" in r.stderr
    assert "'Staubli TX60'" in str(e.value) and "'Staubli TX60'" in r.stderr


def test_no_silent_change_of_frame(cli, ur5e, tmp_path):
    res, held = ur5e
    # A model file without its [provenance] (as model.to_toml() wrote it before): refused in
    # Python and on the command line, instead of metres of error in the base frame.
    text = res.model.to_toml()
    bare = tmp_path / "bare.toml"
    bare.write_text(text[: text.index("[provenance]")])
    with pytest.raises(ValueError, match=r"^frame: .*state the frame"):
        gpu_amcs.validate(bare, held)
    r = cli("validate", "--model", str(bare), str(held))
    assert r.returncode == 2 and "state the frame" in r.stderr
    v = gpu_amcs.validate(bare, held, frame="measurement", check_draws=0)
    assert v.to_dict()["frame_source"] == "stated"
    assert v.to_dict()["model"]["errors_mm"]["rms_mm"] < 0.1
    with pytest.raises(ValueError, match=r"^frame: unknown frame"):
        gpu_amcs.validate(bare, held, frame="tracker")


def test_term_model_equals_cli(cli, ur5e, tmp_path):
    """`term=True` gives the model `validate --term-out` writes, with its term drawn from the
    held-out poses' errors; fewer than 10 poses are refused by both front ends."""
    res, held = ur5e
    f = tmp_path / "m.toml"
    f.write_text(res.model.to_toml())
    out = tmp_path / "t.toml"
    r = run_ok(cli, "validate", "--model", f, held, "--check-draws", 0, "--term-out", out)
    v = gpu_amcs.validate(f, held, check_draws=0, term=True)
    assert r.stdout == v.to_text()
    assert "discrepancy term from these 40 poses' errors" in r.stdout
    assert v.term_model is not None and v.term_model.to_toml() == out.read_text()
    assert "discrepancy_poses = 40" in out.read_text()
    assert gpu_amcs.validate(f, held, check_draws=0).term_model is None
    few = tmp_path / "few.csv"
    few.write_text("".join(held.read_text().splitlines(keepends=True)[:6]))
    with pytest.raises(ValueError, match=r"^term: .*at least 10 poses"):
        gpu_amcs.validate(f, few, check_draws=0, term=True)
    r = cli("validate", "--model", str(f), str(few), "--term-out", str(tmp_path / "n.toml"))
    assert r.returncode == 2 and "--term-out:" in r.stderr
