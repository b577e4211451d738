"""Every bad-config case gives its own ConfigError naming file, key path, line and a fix."""

from __future__ import annotations

from pathlib import Path

import pytest

import armctl
from armctl.config.arm_yaml import load_arm_yaml
from armctl.config.urdf import parse_urdf
from armctl.errors import ConfigError, UnknownNameError

GOOD = """\
armctl: 1
name: t
base: base
joints:
  - name: j1
    type: revolute
    parent: base
    child: l1
    axis: [0, 0, 1]
    limits: {lower: -1, upper: 1}
  - name: j2
    type: prismatic
    parent: l1
    child: l2
    origin: {xyz: [0.1, 0, 0]}
    axis: [1, 0, 0]
    limits: {lower: 0, upper: 0.05}
"""


def load(tmp_path: Path, text: str) -> armctl.Arm:
    p = tmp_path / "arm.yaml"
    p.write_text(text)
    return armctl.load_arm(p)


def expect(tmp_path: Path, text: str, *fragments: str, line: int | None = None) -> ConfigError:
    with pytest.raises(ConfigError) as info:
        load(tmp_path, text)
    err = info.value
    msg = str(err)
    assert "arm.yaml" in msg
    for frag in fragments:
        assert frag in msg, (frag, msg)
    if line is not None:
        assert err.where.line == line, (err.where, msg)
    return err


def test_good_config_loads(tmp_path: Path) -> None:
    arm = load(tmp_path, GOOD)
    assert arm.joint_names == ("j1", "j2")
    assert arm.tool == "l2"


def test_missing_key(tmp_path: Path) -> None:
    err = expect(tmp_path, GOOD.replace("    parent: l1\n", ""), "joints[1] (j2)",
                 "missing required key 'parent'")
    assert err.fix and "parent:" in err.fix


def test_wrong_type(tmp_path: Path) -> None:
    expect(tmp_path, GOOD.replace("lower: -1,", "lower: low,"), "joints[0] (j1).limits.lower",
           "expected a number", "'low'", line=10)


def test_zero_length_axis(tmp_path: Path) -> None:
    expect(tmp_path, GOOD.replace("axis: [0, 0, 1]", "axis: [0, 0, 0]"), "joints[0] (j1).axis",
           "zero length", line=9)


def test_lower_greater_than_upper(tmp_path: Path) -> None:
    err = expect(tmp_path, GOOD.replace("{lower: -1, upper: 1}", "{lower: 1, upper: -1}"),
                 "lower limit 1 is greater than upper limit -1", line=10)
    assert err.fix == "swap the two values"


def test_unknown_parent_suggests_nearest(tmp_path: Path) -> None:
    err = expect(tmp_path, GOOD.replace("parent: l1", "parent: l_1"),
                 "unknown parent link 'l_1'", "did you mean 'l1'")
    assert err.where.line == 11


def test_cycle(tmp_path: Path) -> None:
    text = GOOD + """\
  - {name: j3, type: fixed, parent: l2, child: l3}
"""
    text = text.replace("    parent: l1\n", "    parent: l3\n")
    expect(tmp_path, text, "cycle")


def test_two_roots(tmp_path: Path) -> None:
    text = GOOD + "links:\n  - {name: floating_part}\n"
    expect(tmp_path, text, "two roots", "'floating_part'")


def test_duplicate_joint_names(tmp_path: Path) -> None:
    expect(tmp_path, GOOD.replace("name: j2", "name: j1"), "duplicate joint name 'j1'", line=11)


def test_link_child_of_two_joints(tmp_path: Path) -> None:
    expect(tmp_path, GOOD.replace("child: l2", "child: l1"), "child of two joints")


def test_duplicate_frame_name(tmp_path: Path) -> None:
    text = GOOD + "frames:\n  - {name: l1, parent: l2}\n"
    expect(tmp_path, text, "frame name 'l1' is already used")


def test_unknown_joint_type_suggests(tmp_path: Path) -> None:
    err = expect(tmp_path, GOOD.replace("type: prismatic", "type: prismatc"),
                 "'prismatc' is not one of", line=12)
    assert err.fix == "did you mean 'prismatic'?"


def test_unknown_key_suggests_nearest(tmp_path: Path) -> None:
    err = expect(tmp_path, GOOD.replace("    axis: [1, 0, 0]", "    axsi: [1, 0, 0]"),
                 "unknown key 'axsi'", line=16)
    assert err.fix == "did you mean 'axis'?"


def test_unknown_top_level_key(tmp_path: Path) -> None:
    err = expect(tmp_path, GOOD + "tools: l2\n", "unknown key 'tools'")
    assert err.fix == "did you mean 'tool'?"


def test_duplicate_yaml_key(tmp_path: Path) -> None:
    expect(tmp_path, GOOD.replace("    type: revolute\n", "    type: revolute\n    type: fixed\n"),
           "appears twice")


def test_not_yaml(tmp_path: Path) -> None:
    expect(tmp_path, "name: [unclosed\n", "not valid YAML")


def test_revolute_without_limits(tmp_path: Path) -> None:
    expect(tmp_path, GOOD.replace("    limits: {lower: -1, upper: 1}\n", ""),
           "needs position limits", "continuous")


def test_angles_accept_degrees(tmp_path: Path) -> None:
    arm = load(tmp_path, GOOD.replace("{lower: -1, upper: 1}", "{lower: -90 deg, upper: 45 deg}"))
    assert arm.lower[0] == pytest.approx(-1.5707963267948966)
    assert arm.upper[0] == pytest.approx(0.7853981633974483)


def test_pose_outside_limits(tmp_path: Path) -> None:
    expect(tmp_path, GOOD + "poses:\n  home: [2, 0]\n", "pose 'home'", "outside its limits")


def test_bus_servo_for_unknown_joint(tmp_path: Path) -> None:
    text = GOOD + ("bus:\n  port: sim\n  protocol: dynamixel\n  servos:\n"
                   "    j1: {id: 1, model: xl430-w250}\n    j3: {id: 2, model: xl430-w250}\n")
    expect(tmp_path, text, "servo for unknown or fixed joint 'j3'")


def test_bus_duplicate_servo_id(tmp_path: Path) -> None:
    text = GOOD + ("bus:\n  port: sim\n  protocol: dynamixel\n  servos:\n"
                   "    j1: {id: 1, model: xl430-w250}\n    j2: {id: 1, model: xl430-w250}\n")
    expect(tmp_path, text, "servo id 1 is already used by joint 'j1'")


def test_missing_file() -> None:
    with pytest.raises(ConfigError, match="file not found"):
        load_arm_yaml("/nonexistent/arm.yaml")


def test_bundled_name_typo_suggests() -> None:
    with pytest.raises(ConfigError, match="did you mean the bundled arm 'so101'"):
        armctl.load_arm("so10l")


URDF = """<robot name="r">
  <link name="a"/><link name="b"/>
  <joint name="j" type="revolute"><parent link="a"/><child link="b"/>
    <axis xyz="0 0 1"/><limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
</robot>"""


def test_urdf_not_xml() -> None:
    with pytest.raises(ConfigError, match="not a valid URDF: not well-formed XML") as info:
        parse_urdf("name: this is yaml\n", Path("robot.urdf"))
    assert "robot.urdf:1" in str(info.value)


def test_urdf_two_roots() -> None:
    with pytest.raises(ConfigError, match="2 roots"):
        parse_urdf(URDF.replace('<link name="b"/>', '<link name="b"/><link name="c"/>'))


def test_urdf_unknown_joint_type() -> None:
    with pytest.raises(UnknownNameError, match="unknown joint type 'revolut'"):
        parse_urdf(URDF.replace('type="revolute"', 'type="revolut"'))


def test_urdf_zero_axis() -> None:
    with pytest.raises(ConfigError, match="zero-length axis"):
        parse_urdf(URDF.replace('xyz="0 0 1"', 'xyz="0 0 0"'))


def test_urdf_lower_greater_than_upper() -> None:
    with pytest.raises(ConfigError, match="lower limit 1 is greater than upper limit -1"):
        parse_urdf(URDF.replace('lower="-1" upper="1"', 'lower="1" upper="-1"'))


def test_urdf_unknown_link() -> None:
    with pytest.raises(ConfigError, match="names link 'c', which is not defined"):
        parse_urdf(URDF.replace('<child link="b"/>', '<child link="c"/>'))


def test_urdf_floating_joint_rejected() -> None:
    with pytest.raises(ConfigError, match="floating"):
        parse_urdf(URDF.replace('type="revolute"', 'type="floating"'))
