"""Teleoperation keeps the follower out of contact: it waits at an obstacle the leader reaches."""

from __future__ import annotations

import numpy as np
import pytest

from armctl.config.motion import ExitPolicy
from armctl.config.scene import Obstacle, SceneSpec, TableSpec
from armctl.config.schema import Box, Origin
from armctl.ik import PositionGoal
from armctl.robot import Robot
from armctl.robot.teleop import Teleop, TeleopCycle, TeleopOptions

pytestmark = pytest.mark.timeout(120)

#: A wall standing on the table in front of the follower, between its left and right.
WALL = Obstacle("wall", Box((0.12, 0.02, 0.15), Origin((0.22, 0.0, 0.075))))
SCENE = SceneSpec(TableSpec(0.0), (WALL,))


def _segment_distance_to_box(a: np.ndarray, b: np.ndarray, lo: np.ndarray, hi: np.ndarray
                             ) -> float:
    """Brute force: the least distance from points along a segment to an axis-aligned box."""
    pts = a + np.linspace(0.0, 1.0, 400)[:, None] * (b - a)
    gap = np.maximum(np.maximum(lo - pts, pts - hi), 0.0)
    return float(np.linalg.norm(gap, axis=1).min())


def test_the_follower_waits_at_the_wall_and_follows_again() -> None:
    with Robot.open("so101_leader", hold=False, exit_policy=ExitPolicy.HOLD) as lead, \
            Robot.open("so101", exit_policy=ExitPolicy.HOLD, scene=SCENE) as fol:
        arm = fol.arm
        left = arm.ik(PositionGoal(np.array([0.2, 0.12, 0.06])), q0=np.zeros(arm.dof)).q
        right = arm.ik(PositionGoal(np.array([0.2, -0.12, 0.06])), q0=np.zeros(arm.dof)).q
        model = fol.collisions
        assert model is not None and model.free(left) and model.free(right)
        assert model.first_contact_on_segment(left, right) is not None  # the wall is between
        sim = lead.bus.simulator  # type: ignore[attr-defined]
        for name, v in zip(arm.joint_names, left, strict=True):
            sim.set_joint(name, float(v))
        tele = Teleop(lead, fol, TeleopOptions(rate_hz=50.0, duration=8.0))
        fol.move_joints(left)
        tele.start()
        commands: list[np.ndarray] = []
        blocked: list[str] = []

        def cycle(c: TeleopCycle) -> None:
            commands.append(np.array(c.command))
            blocked.append(c.blocked)
            goal = right if 0.5 <= c.t < 4.0 else left  # reach through the wall, then back
            for name, v in zip(arm.joint_names, goal, strict=True):
                sim.set_joint(name, float(v))

        stats = tele.run(cycle)
    assert "'wall'" in next(b for b in blocked if b)
    assert sum(stats.blocked.values()) > 10
    # every command kept the padding: the link capsules, by brute force against the wall box
    idx = fol.executor.idx
    lo = np.array([0.22 - 0.06, -0.01, 0.0]) - 0.005
    hi = np.array([0.22 + 0.06, 0.01, 0.15]) + 0.005
    from armctl.kinematics.capsules import collision_capsules

    caps = collision_capsules(arm.spec)
    for cmd in commands[::5]:
        q = np.zeros(arm.dof)
        q[idx] = cmd
        frames = arm.fk_frames(q)
        for link, cs in caps.items():
            pose = frames[arm.frame_index(link)]
            for cap in cs:
                a, b = cap.world(pose)
                assert _segment_distance_to_box(a, b, lo, hi) >= cap.radius - 2e-3, link
    # it followed the leader back: the last command is at the left pose again
    last = np.zeros(arm.dof)
    last[idx] = commands[-1]
    assert np.allclose(last[:5], left[:5], atol=0.02)
