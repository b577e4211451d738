"""URDF -> armctl YAML -> load gives identical kinematics for every frame of the original."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from armctl_testpaths import DATA, WITH_URDF

import armctl
from armctl.cli import main
from armctl.config.arm_yaml import parse_arm
from armctl.config.source import parse_yaml
from armctl.config.urdf import load_urdf, parse_urdf
from armctl.config.writer import dump_arm_yaml
from armctl.errors import ConfigError


def _random_tree(seed: int) -> str:
    import sys

    sys.path.insert(0, str(Path(__file__).parent.parent / "kinematics"))
    from randarm import random_tree_urdf

    return random_tree_urdf(np.random.default_rng(seed), 12)


def assert_same_kinematics(a: armctl.Arm, b: armctl.Arm, seed: int = 0) -> None:
    assert a.joint_names == b.joint_names
    np.testing.assert_array_equal(a.lower, b.lower)
    np.testing.assert_array_equal(a.upper, b.upper)
    assert set(a.frame_names) <= set(b.frame_names)
    rng = np.random.default_rng(seed)
    for q in a.sample(rng, 20):
        pa, pb = a.fk_all(q), b.fk_all(q)
        for name in a.frame_names:
            np.testing.assert_allclose(pb[name], pa[name], atol=1e-12, err_msg=name)


@pytest.mark.parametrize("seed", range(6))
def test_random_tree_round_trip(seed: int) -> None:
    spec = parse_urdf(_random_tree(seed)).spec
    text = dump_arm_yaml(spec)
    again = parse_arm(parse_yaml(text))
    assert_same_kinematics(armctl.Arm(spec), armctl.Arm(again), seed)
    assert not any(j.type.value == "fixed" for j in again.joints)  # fixed joints were merged


@pytest.mark.parametrize("name", WITH_URDF)
def test_reference_urdf_round_trip_through_cli(name: str, tmp_path: Path) -> None:
    urdf = DATA / "urdf" / f"{name}.urdf"
    out = tmp_path / f"{name}.yaml"
    assert main(["convert", str(urdf), "-o", str(out)]) == 0
    assert_same_kinematics(armctl.load_arm(urdf), armctl.load_arm(out))


def test_convert_refuses_to_overwrite(tmp_path: Path) -> None:
    out = tmp_path / "x.yaml"
    out.write_text("keep me")
    assert main(["convert", str(DATA / "urdf" / "ur5e.urdf"), "-o", str(out)]) == 2
    assert out.read_text() == "keep me"


def test_tip_keeps_only_the_chain() -> None:
    text = _random_tree(3)
    full = parse_urdf(text).spec
    leaf = full.end_effectors[-1]
    imported = parse_urdf(text, tip=leaf)
    assert imported.spec.tool == leaf
    kept = {j.child for j in imported.spec.joints}
    parents = {j.child: j.parent for j in full.joints}
    link, chain = leaf, set()
    while link in parents:
        chain.add(link)
        link = parents[link]
    assert kept == chain


def test_mimic_joint_becomes_fixed_with_a_note(tmp_path: Path) -> None:
    text = """<robot name="g"><link name="a"/><link name="b"/><link name="c"/>
      <joint name="j" type="revolute"><parent link="a"/><child link="b"/><axis xyz="0 0 1"/>
        <limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
      <joint name="finger" type="prismatic"><parent link="b"/><child link="c"/>
        <axis xyz="1 0 0"/><limit lower="0" upper="0.04" velocity="1" effort="1"/>
        <mimic joint="j" multiplier="1" offset="0.01"/></joint></robot>"""
    p = tmp_path / "g.urdf"
    p.write_text(text)
    imported = load_urdf(p)
    assert imported.spec.actuated_joints[0].name == "j"
    assert len(imported.spec.actuated_joints) == 1
    assert any("mimic joint 'finger'" in n for n in imported.notes)
    arm = armctl.Arm(imported.spec)
    np.testing.assert_allclose(arm.fk([0.0], "c")[:3, 3], [0.01, 0, 0], atol=1e-15)


def test_multi_dof_joints_are_one_joint_each(tmp_path: Path) -> None:
    p = tmp_path / "s.yaml"
    p.write_text("""armctl: 1
name: s
base: base
joints:
  - name: shoulder
    type: spherical
    parent: base
    child: upper
    limits: {swing: 1.2, twist: {lower: -1, upper: 1}}
  - name: wrist
    type: universal
    parent: upper
    child: hand
    origin: {xyz: [0, 0, 0.3]}
    axes: [[0, 1, 0], [1, 0, 0]]
    limits: [{lower: -1, upper: 1}, {lower: -0.5, upper: 0.5}]
poses:
  home: [1, 0, 0, 0, 0.1, -0.2]
""")
    arm = armctl.load_arm(p)
    assert arm.joint_names == ("shoulder", "wrist")
    assert (arm.nq, arm.nv) == (6, 5)
    np.testing.assert_array_equal(arm.upper[4:], [1, 0.5])
    from scipy.spatial.transform import Rotation

    from armctl.spatial import axis_angle_to_matrix as rot

    r = Rotation.from_rotvec([0.3, -0.2, 0.5])
    q = np.array([*r.as_quat(scalar_first=True), 0.1, 0.4])
    hand = r.as_matrix() @ rot([0, 1, 0], q[4]) @ rot([1, 0, 0], q[5])
    pose = arm.fk(q)
    np.testing.assert_allclose(pose[:3, :3], hand, atol=1e-14)
    np.testing.assert_allclose(pose[:3, 3], r.as_matrix() @ [0, 0, 0.3], atol=1e-14)
    # written back and read again: the same joints, limits and poses
    again = tmp_path / "again.yaml"
    again.write_text(dump_arm_yaml(arm.spec))
    back = armctl.load_arm(again)
    assert back.spec.joints == arm.spec.joints
    assert back.spec.poses == arm.spec.poses


def test_urdf_has_no_ball_joint(tmp_path: Path) -> None:
    p = tmp_path / "b.urdf"
    p.write_text("""<robot name="b"><link name="a"/><link name="b"/>
  <joint name="j" type="spherical"><parent link="a"/><child link="b"/></joint></robot>""")
    with pytest.raises(ConfigError, match="spherical, which URDF does not define"):
        load_urdf(p)


_TOOL_URDF = """<robot name="t"><link name="base"/><link name="l1"/><link name="hand"/>
  <link name="finger_a"/><link name="finger_a_pad"/>{extra_links}
  <joint name="j1" type="revolute"><parent link="base"/><child link="l1"/><axis xyz="0 0 1"/>
    <limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
  <joint name="j2" type="revolute"><parent link="l1"/><child link="hand"/>
    <origin xyz="0.2 0 0"/><axis xyz="0 1 0"/>
    <limit lower="-1" upper="1" velocity="1" effort="1"/></joint>
  <joint name="f" type="prismatic"><parent link="hand"/><child link="finger_a"/>
    <axis xyz="0 1 0"/><limit lower="0" upper="0.04" velocity="1" effort="1"/></joint>
  <joint name="pad" type="fixed"><parent link="finger_a"/><child link="finger_a_pad"/></joint>
  {extra_joints}</robot>"""


def _tool_urdf(*frames: str) -> str:
    links = "".join(f'<link name="{n}"/>' for n in frames)
    joints = "".join(f'<joint name="fix_{n}" type="fixed"><parent link="hand"/>'
                     f'<child link="{n}"/><origin xyz="0.1 0 0"/></joint>' for n in frames)
    return _TOOL_URDF.format(extra_links=links, extra_joints=joints)


@pytest.mark.parametrize(("frames", "tool"), [
    ((), "finger_a_pad"),  # no tool-like name: the deepest leaf
    (("tcp",), "tcp"),
    (("arm_gripper_frame", "tool0"), "tool0"),
    (("hand_tcp", "my_ee_link"), "hand_tcp"),
    (("xtcpx", "arm_gripper_frame"), "xtcpx"),
    (("arm_gripper_frame", "my_ee_link"), "arm_gripper_frame"),
    (("my_ee_link",), "my_ee_link"),
    (("end_effector", "hand_tcp"), "end_effector"),
])
def test_the_tool_is_a_tool_frame_before_a_finger(frames: tuple[str, ...], tool: str) -> None:
    assert parse_urdf(_tool_urdf(*frames)).spec.tool == tool


def test_convert_names_the_tool_it_chose(tmp_path: Path,
                                         capsys: pytest.CaptureFixture[str]) -> None:
    src = tmp_path / "t.urdf"
    src.write_text(_tool_urdf("tcp"))
    assert main(["convert", str(src), "-o", str(tmp_path / "t.yaml")]) == 0
    assert "tool: tcp (override with --tip LINK)" in capsys.readouterr().out
    arm = armctl.load_arm(tmp_path / "t.yaml")
    assert arm.tool == "tcp"
    np.testing.assert_allclose(arm.fk([0.0, 0.0, 0.0])[:3, 3], [0.3, 0, 0], atol=1e-15)
