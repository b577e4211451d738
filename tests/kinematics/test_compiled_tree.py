"""The compiled tree: its documented layout, its read-only arrays, the arm's reach."""

from __future__ import annotations

import ast
import dataclasses
import math

import numpy as np
import pytest
from armctl_testpaths import BUNDLED, REPO
from randarm import random_tree_urdf

import armctl
from armctl.config.schema import JointType
from armctl.config.urdf import parse_urdf
from armctl.kinematics import CompiledTree, KinematicModel
from armctl.kinematics.compiled_tree import (
    FRAME_COLUMNS,
    FRAME_OFFSET,
    JOINT_AXIS,
    JOINT_COLUMNS,
    JOINT_ORIGIN,
    JOINT_PRISMATIC,
    TRANSLATION,
)


def _arms() -> list[KinematicModel]:
    arms: list[KinematicModel] = [armctl.load_arm(name) for name in BUNDLED]
    rng = np.random.default_rng(11)
    arms += [armctl.Arm(parse_urdf(random_tree_urdf(rng, 12)).spec) for _ in range(3)]
    return arms


ARMS = _arms()
IDS = [f"{a.name}-{i}" for i, a in enumerate(ARMS)]


def _motion(axis: np.ndarray, prismatic: bool, q: float) -> np.ndarray:
    """``M(q)``: a rotation about ``axis`` (Rodrigues) or a translation along it."""
    m = np.eye(4)
    if prismatic:
        m[:3, 3] = axis * q
        return m
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    m[:3, :3] = np.eye(3) + math.sin(q) * k + (1.0 - math.cos(q)) * (k @ k)
    return m


def _documented_fk(tree: CompiledTree, q: np.ndarray) -> np.ndarray:
    """Every frame's pose built from the documented fields alone, in plain NumPy."""
    world: list[np.ndarray] = []
    for j in range(len(tree.joint_names)):
        p = int(tree.parent[j])
        assert p < j  # parents first
        t_parent = np.eye(4) if p < 0 else world[p]
        world.append(t_parent @ tree.joint_origin(j)
                     @ _motion(tree.joint_axis(j), tree.is_prismatic(j), q[j]))
    out = []
    for k in range(len(tree.frame_names)):
        a = int(tree.anchor[k])
        out.append((np.eye(4) if a < 0 else world[a]) @ tree.frame_offset(k))
    return np.array(out)


@pytest.mark.parametrize("arm", ARMS, ids=IDS)
def test_the_documented_layout_gives_the_kernels_poses(arm: KinematicModel) -> None:
    tree = arm.tree
    n, m = arm.dof, len(arm.frame_names)
    assert tree.joints.shape == (n, JOINT_COLUMNS) and tree.frames.shape == (m, FRAME_COLUMNS)
    assert tree.parent.shape == (n,) and tree.anchor.shape == (m,)
    assert tree.paths.shape == (m, max(n, 1))
    assert tree.joint_names == arm.joint_names and tree.frame_names == arm.frame_names
    for j in range(n):
        assert np.array_equal(tree.joints[j, JOINT_ORIGIN].reshape(3, 4), tree.joint_origin(j)[:3])
        assert np.array_equal(tree.joints[j, TRANSLATION], tree.joint_origin(j)[:3, 3])
        assert np.linalg.norm(tree.joints[j, JOINT_AXIS]) == pytest.approx(1.0)
        assert tree.is_prismatic(j) == (tree.joints[j, JOINT_PRISMATIC] == 1.0)
        assert tree.is_prismatic(j) == (arm.joint_types[j] is JointType.PRISMATIC)
    for k, name in enumerate(arm.frame_names):
        assert np.array_equal(tree.frames[k, FRAME_OFFSET].reshape(3, 4), tree.frame_offset(k)[:3])
        assert tuple(tree.chain(k)) == arm.chain(name)
        anchor = int(tree.anchor[k])
        assert anchor == (arm.chain(name)[-1] if arm.chain(name) else -1)
    rng = np.random.default_rng(5)
    for q in arm.sample(rng, 5):
        np.testing.assert_allclose(_documented_fk(tree, q), arm.fk_frames(q), atol=1e-12)


def test_the_tree_is_frozen_and_its_arrays_read_only() -> None:
    tree = armctl.load_arm("ur5e").tree
    for field in dataclasses.fields(tree):
        value = getattr(tree, field.name)
        if isinstance(value, np.ndarray):
            assert not value.flags.writeable, field.name
            assert value.flags.c_contiguous, field.name
            with pytest.raises(ValueError):
                value.flat[0] = 1.0
    with pytest.raises(dataclasses.FrozenInstanceError):
        tree.joints = np.zeros((6, JOINT_COLUMNS))  # type: ignore[misc]
    # the model's limits are the tree's
    arm = armctl.load_arm("ur5e")
    assert arm.lower is arm.tree.lower and arm.upper is arm.tree.upper


@pytest.mark.parametrize("arm", ARMS, ids=IDS)
def test_reach_bounds_every_frame_over_sampled_configurations(arm: KinematicModel) -> None:
    tree = arm.tree
    qs = arm.sample(np.random.default_rng(2), 2000)
    for k, name in enumerate(arm.frame_names):
        pos = arm.fk_batch(qs, name)[:, :3, 3]
        dist = np.linalg.norm(pos, axis=1)
        assert dist.max() <= tree.reach(k) + 1e-9, name
        chain = arm.chain(name)
        if chain:
            shoulder = tree.joint_origin(chain[0])[:3, 3]
            from_first = np.linalg.norm(pos - shoulder, axis=1)
            assert from_first.max() <= tree.reach(k, from_first_joint=True) + 1e-9, name
            assert tree.reach(k, from_first_joint=True) <= tree.reach(k) + 1e-12
        else:  # fixed to the base: its distance is the bound
            assert dist.max() == pytest.approx(tree.reach(k))
        assert arm.reach(name) == tree.reach(k)
    assert tree.max_reach == pytest.approx(max(float(tree.frame_reach.max()), 1e-3))


@pytest.mark.parametrize("name", ["ur5e", "panda", "wx250s"])
def test_reach_is_tight_for_the_tool(name: str) -> None:
    """The bound is not loose: a sampled configuration comes close to it."""
    arm = armctl.load_arm(name)
    qs = arm.sample(np.random.default_rng(3), 5000)
    shoulder = arm.tree.joint_origin(arm.chain()[0])[:3, 3]
    dists = np.linalg.norm(arm.fk_batch(qs)[:, :3, 3] - shoulder, axis=1)
    assert dists.max() > 0.8 * arm.reach(from_first_joint=True)


def test_reach_counts_the_travel_of_prismatic_joints() -> None:
    text = """<robot name="slide">
      <link name="base"/><link name="carriage"/><link name="tip"/>
      <joint name="slide" type="prismatic"><parent link="base"/><child link="carriage"/>
        <origin xyz="0 0 0.1"/><axis xyz="1 0 0"/>
        <limit lower="-0.05" upper="0.3" velocity="1" effort="1"/></joint>
      <joint name="turn" type="revolute"><parent link="carriage"/><child link="tip"/>
        <origin xyz="0.2 0 0"/><axis xyz="0 0 1"/>
        <limit lower="-3" upper="3" velocity="1" effort="1"/></joint>
    </robot>"""
    arm = armctl.Arm(parse_urdf(text).spec)
    # 0.1 (slide origin) + 0.3 (largest travel) + 0.2 (turn origin) to the tip link
    assert arm.reach("tip") == pytest.approx(0.6)
    assert arm.reach("tip", from_first_joint=True) == pytest.approx(0.5)
    assert arm.fk([0.3, 0.0], "tip")[:3, 3] == pytest.approx([0.5, 0.0, 0.1])


# names of the private attributes and methods of the kinematics classes
def _private_names() -> set[str]:
    names: set[str] = set()
    for path in (REPO / "armctl" / "kinematics").glob("*.py"):
        for node in ast.walk(ast.parse(path.read_text())):
            if isinstance(node, ast.ClassDef):
                for sub in ast.walk(node):
                    if (isinstance(sub, ast.Attribute) and isinstance(sub.value, ast.Name)
                            and sub.value.id == "self" and sub.attr.startswith("_")
                            and not sub.attr.startswith("__")):
                        names.add(sub.attr)
                    if isinstance(sub, ast.FunctionDef) and sub.name.startswith("_") \
                            and not sub.name.startswith("__"):
                        names.add(sub.name)
    return names


def test_no_module_outside_kinematics_reads_its_private_attributes() -> None:
    private = _private_names()
    assert {"_chains", "_frame_index"} <= private  # the scan sees the model's privates
    offenders = []
    root = REPO / "armctl"
    scanned = 0
    for path in sorted(root.rglob("*.py")):
        if "kinematics" in path.relative_to(root).parts:
            continue
        scanned += 1
        for node in ast.walk(ast.parse(path.read_text())):
            if not isinstance(node, ast.Attribute) or node.attr not in private:
                continue
            if isinstance(node.value, ast.Name) and node.value.id in ("self", "cls"):
                continue  # an object of the module's own class
            offenders.append(f"{path.relative_to(REPO)}:{node.lineno}: .{node.attr}")
    assert scanned > 50  # armctl/ik, motion, servo, robot, cli, render, ...
    assert not offenders, "\n".join(offenders)

