"""Model construction, units and round trips."""

import numpy as np
import pytest

import gpu_amcs
from conftest import REPO, with_tool_sigma
from gpu_amcs.numpy_fk import fk as fk_numpy


def test_presets_and_units():
    assert gpu_amcs.presets() == [
        "tx60", "ur5e", "ur10e", "irb2400", "kr6r700sixx", "iiwa14", "panda",
    ]
    for name in ("iiwa14", "panda"):
        p = gpu_amcs.Model.preset(name)
        assert p.joints == 7 and p.params.shape == (38,) and p.limits.shape == (7, 2)
    m = gpu_amcs.Model.preset("tx60")
    assert m.name == "Staubli TX60"
    assert m.params.shape == (33,) and m.sigma.shape == (33,)
    assert m.param_names[:5] == ["theta1", "d1", "a1", "alpha1", "beta1"]
    # File units: J1 alpha = -90 deg, J1 d = 375 mm, J2 a = 290 mm (the model file's values).
    assert m.params[3] == -90.0 and m.params[1] == 375.0 and m.params[7] == 290.0
    assert m.sigma[0] == pytest.approx(0.003216, rel=1e-12)  # deg, as the file states
    assert m.covariance is None
    assert m.limits.shape == (6, 2) and tuple(m.limits[1]) == (-127.5, 127.5)
    assert np.all(m.sigma[np.setdiff1d(np.arange(33), m.free)] == 0)
    assert "Staubli TX60" in repr(m)
    with pytest.raises(ValueError, match="tx90"):
        gpu_amcs.Model.preset("tx90")


def test_toml_round_trip(tmp_path):
    m = gpu_amcs.Model.preset("ur5e")
    text = m.to_toml()
    back = gpu_amcs.Model.from_toml(text)
    np.testing.assert_array_equal(back.params, m.params)
    np.testing.assert_array_equal(back.sigma, m.sigma)
    # The tool's spread survives the round trip too (the model file's tool_sigma).
    t = with_tool_sigma(m, [0.003, 0.0, 0.005])
    back = gpu_amcs.Model.from_toml(t.to_toml())
    np.testing.assert_array_equal(back.sigma[30:], [0.003, 0.0, 0.005])
    assert back.free == m.free + [30, 32]
    f = tmp_path / "m.toml"
    f.write_text(text)
    np.testing.assert_array_equal(gpu_amcs.Model.from_file(f).params, m.params)
    with pytest.raises(ValueError, match="here.toml"):
        gpu_amcs.Model.from_toml(text.replace("theta = 0.0", "theta = nan", 1), "here.toml")


def test_from_urdf_reproduces_the_preset():
    # tests/data/irb2400.urdf is the ROS-Industrial abb_irb2400_support description the
    # irb2400 preset was converted from: the imported model puts the flange where the preset
    # does (the import proves 1e-9 mm against the URDF itself).
    urdf = REPO / "tests" / "data" / "irb2400.urdf"
    # Two leaves (tool0 and base): without a tip, tool0, named in a warning.
    with pytest.warns(UserWarning, match=r"tip link 'tool0' \(named tool0\)"):
        auto = gpu_amcs.Model.from_urdf(urdf)
    imported = gpu_amcs.Model.from_urdf(urdf, tip="tool0")
    assert auto.to_toml() == imported.to_toml()
    assert imported.name == "abb_irb2400"
    # tool0 at q = 0 is (940, 0, 1455) mm: the sum of the URDF's joint origins.
    np.testing.assert_allclose(imported.fk(np.zeros((1, 6)))[0], [940, 0, 1455], atol=1e-9)
    preset = gpu_amcs.Model.preset("irb2400")
    rng = np.random.default_rng(2)
    lim = np.minimum(np.abs(preset.limits), 170) * np.sign(preset.limits)
    q = rng.uniform(lim[:, 0] * 0.9, lim[:, 1] * 0.9, size=(20, 6))
    np.testing.assert_allclose(imported.fk(q), preset.fk(q), atol=1e-6)
    np.testing.assert_allclose(imported.fk(q), fk_numpy(imported.params[None], q)[0], atol=1e-9)
    assert np.all(imported.sigma == 0)
    with pytest.raises(ValueError, match="nothing.urdf"):
        gpu_amcs.Model.from_urdf(REPO / "nothing.urdf")


def test_from_urdf_expands_xacro(tmp_path):
    # The irb2400 URDF as a xacro file that includes a file of another package (found through
    # packages=) and takes an arg (set through xacro_args=): the same model as the URDF.
    urdf = REPO / "tests" / "data" / "irb2400.urdf"
    text = urdf.read_text()
    ns = 'xmlns:xacro="http://www.ros.org/wiki/xacro"'
    parts = tmp_path / "elsewhere"
    parts.mkdir()
    (parts / "parts.xacro").write_text(
        f'<robot {ns}><xacro:property name="extra" value="camera"/></robot>\n'
    )
    head, rest = text.split("<robot ", 1)
    body = rest.split(">", 1)
    xacro = (
        head + "<robot " + ns + " " + body[0] + ">\n"
        '<xacro:include filename="$(find parts)/parts.xacro"/>\n'
        '<xacro:arg name="suffix" default="_x"/>\n'
        '<material name="${extra}$(arg suffix)"/>\n' + body[1]
    )
    (tmp_path / "robot.xacro").write_text(xacro)
    with pytest.raises(ValueError, match="package 'parts' not found"):
        gpu_amcs.Model.from_urdf(tmp_path / "robot.xacro", tip="tool0")
    m = gpu_amcs.Model.from_urdf(
        tmp_path / "robot.xacro",
        tip="tool0",
        packages={"parts": str(parts)},
        xacro_args={"suffix": "_y"},
    )
    np.testing.assert_array_equal(m.params, gpu_amcs.Model.from_urdf(urdf, tip="tool0").params)


def test_from_urdf_applies_the_model_rules(tmp_path):
    # Limits of ±100 rad on joint_3: the model every other call would refuse is refused at
    # import, naming the URDF's joint.
    text = (REPO / "tests" / "data" / "irb2400.urdf").read_text()
    at = text.index('<joint name="joint_3"')
    end = text.index("</joint>", at)
    joint = text[at:end]
    lower = joint.index('lower="') + len('lower="')
    upper = joint.index('upper="') + len('upper="')
    bad = joint[:lower] + "-100" + joint[joint.index('"', lower):]
    upper = bad.index('upper="') + len('upper="')
    bad = bad[:upper] + "100" + bad[bad.index('"', upper):]
    f = tmp_path / "bad.urdf"
    f.write_text(text[:at] + bad + text[end:])
    with pytest.raises(ValueError, match=r"joint 'joint_3': limits.*720"):
        gpu_amcs.Model.from_urdf(f, tip="tool0")


def test_from_urdf_holds_a_joint_of_a_seven_axis_arm(tmp_path, cli):
    # The LBR iiwa 14 R820's standard DH table (KUKA's figures), seven rows: a seven-joint
    # model as it is, a six-axis model with joint 3 held, the same as the command line's import.
    rows = [(360, -90), (0, 90), (420, 90), (0, -90), (400, -90), (0, 90), (126, 0)]
    limits = [170, 120, 170, 120, 170, 120, 175]
    text = "convention,standard\nunits,mm-deg\nname,iiwa14\ntheta,d,a,alpha,lower,upper\n"
    text += "".join(f"0,{d},0,{al},{-l},{l}\n" for (d, al), l in zip(rows, limits))
    f = tmp_path / "iiwa14.csv"
    f.write_text(text)
    seven = gpu_amcs.Model.from_urdf(f)
    assert seven.joints == 7 and seven.params.shape == (38,)
    np.testing.assert_allclose(seven.fk(np.zeros((1, 7)))[0], [0, 0, 1306], atol=1e-9)
    # Eight rows are refused, naming how many joints to hold.
    f8 = tmp_path / "eight.csv"
    f8.write_text(text + "0,100,0,0,-170,170\n")
    with pytest.raises(ValueError, match=r"8 revolute joints.*hold 1 of them"):
        gpu_amcs.Model.from_urdf(f8)
    with pytest.raises(ValueError, match=r"joint 'joint 3' cannot be held at 175"):
        gpu_amcs.Model.from_urdf(f, hold_joints={"3": 175.0})
    with pytest.warns(UserWarning, match=r"joint 'joint 3' held at 20°"):
        m = gpu_amcs.Model.from_urdf(f, hold_joints={"joint 3": 20.0})
    out = tmp_path / "iiwa.toml"
    r = cli("import", f, "-o", out, "--hold-joint", "3=20")
    assert r.returncode == 0, r.stderr
    np.testing.assert_array_equal(m.params, gpu_amcs.Model.from_file(out).params)
    # At q = 0 the arm stands straight up: 360 + 420 + 400 + 126 mm.
    assert m.joints == 6
    np.testing.assert_allclose(m.fk(np.zeros((1, 6)))[0], [0, 0, 1306], atol=1e-9)
