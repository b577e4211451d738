"""Test arms for the analytic solvers: arms from standard DH tables, random arms per family."""

from __future__ import annotations

import dataclasses
import math

import numpy as np

from armctl.arm import Arm
from armctl.config.schema import (
    ArmSpec,
    FrameSpec,
    JointSpec,
    JointType,
    Limits,
    LinkSpec,
    Origin,
)
from armctl.spatial import matrix_to_rpy

#: PUMA 560, standard DH (d, a, alpha) per joint, from Corke's Robotics Toolbox
#: (mdl_puma560, standard DH): a = [0, 0.4318, 0.0203, 0, 0, 0] m,
#: d = [0, 0, 0.15005, 0.4318, 0, 0] m, alpha = [pi/2, 0, -pi/2, pi/2, -pi/2, 0].
PUMA560 = [(0.0, 0.0, math.pi / 2), (0.0, 0.4318, 0.0), (0.15005, 0.0203, -math.pi / 2),
           (0.4318, 0.0, math.pi / 2), (0.0, 0.0, -math.pi / 2), (0.0, 0.0, 0.0)]

#: A KUKA KR6-class spherical-wrist arm, standard DH (d, a, alpha): base height 0.4 m, shoulder
#: offset 0.025 m, upper arm 0.455 m, elbow offset 0.035 m, forearm 0.42 m, flange 0.08 m
#: (a test geometry of that class, not maker data).
KR6 = [(0.4, 0.025, -math.pi / 2), (0.0, 0.455, 0.0), (0.0, 0.035, -math.pi / 2),
       (0.42, 0.0, math.pi / 2), (0.0, 0.0, -math.pi / 2), (0.08, 0.0, 0.0)]

#: UR5e, standard DH (d, a, alpha), from Universal Robots' published DH table.
UR5E = [(0.1625, 0.0, math.pi / 2), (0.0, -0.425, 0.0), (0.0, -0.3922, 0.0),
        (0.1333, 0.0, math.pi / 2), (0.0997, 0.0, -math.pi / 2), (0.0996, 0.0, 0.0)]


def _origin(t: np.ndarray) -> Origin:
    return Origin(tuple(float(v) for v in t[:3, 3]),  # type: ignore[arg-type]
                  tuple(float(v) for v in matrix_to_rpy(t[:3, :3])))  # type: ignore[arg-type]


def _dh(d: float, a: float, alpha: float, theta: float = 0.0) -> np.ndarray:
    ct, st = math.cos(theta), math.sin(theta)
    ca, sa = math.cos(alpha), math.sin(alpha)
    return np.array([[ct, -st * ca, st * sa, a * ct], [st, ct * ca, -ct * sa, a * st],
                     [0, sa, ca, d], [0, 0, 0, 1.0]])


def dh_arm(name: str, rows: list[tuple[float, float, float]], lower: float = -math.pi,
           upper: float = math.pi, offsets: list[float] | None = None) -> Arm:
    """An arm from a standard DH table: joint ``i`` turns about ``z_{i-1}``, then
    ``Tz(d_i) Tx(a_i) Rx(alpha_i)`` (with the optional joint offset turned in first)."""
    n = len(rows)
    offsets = offsets or [0.0] * n
    links = [LinkSpec("base")] + [LinkSpec(f"l{i + 1}") for i in range(n)]
    joints = []
    pre = np.eye(4)
    for i in range(n):
        joints.append(JointSpec(f"j{i + 1}", JointType.REVOLUTE, "base" if i == 0 else f"l{i}",
                                f"l{i + 1}", _origin(pre), (0.0, 0.0, 1.0),
                                Limits(lower, upper)))
        d, a, alpha = rows[i]
        pre = _dh(d, a, alpha, offsets[i])
    frames = (FrameSpec("tool", f"l{n}", _origin(pre)),)
    return Arm(ArmSpec(name, "base", tuple(links), tuple(joints), frames, "tool", ("tool",)))


def random_arm(rng: np.random.Generator, family: str) -> Arm:
    """A random 6R arm of a family: ``wrist`` (axes 4-6 meet), ``shoulder`` (1-3 meet),
    ``parallel`` (2-4 parallel), ``outer`` (3-5 parallel), or ``general``."""
    rows = []
    for _ in range(6):
        rows.append([rng.uniform(-0.4, 0.4), rng.uniform(-0.5, 0.5), rng.uniform(-np.pi, np.pi)])
    if family == "wrist":  # a4 = a5 = d5 = 0
        rows[3][1] = rows[4][1] = rows[4][0] = 0.0
    elif family == "shoulder":  # a1 = a2 = d2 = 0
        rows[0][1] = rows[1][1] = rows[1][0] = 0.0
    elif family == "parallel":  # z1 || z2 || z3
        rows[1][2] = rows[2][2] = 0.0
    elif family == "outer":  # z2 || z3 || z4
        rows[2][2] = rows[3][2] = 0.0
    offsets = list(rng.uniform(-np.pi, np.pi, 6))
    return dh_arm(f"random-{family}", [tuple(r) for r in rows],  # type: ignore[misc]
                  offsets=offsets)


def _snap(angle: float) -> float:
    """``angle`` moved onto the nearest multiple of pi/2 when within 1e-4 rad of it."""
    k = round(angle / (math.pi / 2))
    return k * math.pi / 2 if abs(angle - k * math.pi / 2) < 1e-4 else angle


def idealised(arm: Arm) -> Arm:
    """The arm with the joint and frame angles that are rounded right angles (URDF ``1.5708``,
    ``3.14159``) made exact, so its special axes are special to machine precision."""

    def fix(origin: Origin) -> Origin:
        return Origin(origin.xyz, tuple(_snap(a) for a in origin.rpy))  # type: ignore[arg-type]

    spec = arm.spec
    joints = tuple(dataclasses.replace(j, origin=fix(j.origin)) for j in spec.joints)
    frames = tuple(dataclasses.replace(f, origin=fix(f.origin)) for f in spec.frames)
    return Arm(dataclasses.replace(spec, name=spec.name + "-ideal", joints=joints, frames=frames))
