"""The collision check of a whole trajectory before anything moves, continuous between samples.

The trajectory is sampled every ``dt``; between two samples each joint travels at most
``dt (|v0| + |v1|) / 2 + a dt^2 / 2`` (its speed is within ``a t`` of the speed at either end,
``a`` the larger of its acceleration limit and the largest sampled acceleration), and
:meth:`~armctl.collision.model.CollisionModel.first_contact_on_samples` turns those travels into
a certificate that nothing touches between the samples, sampling a step more densely when its
ends cannot certify it.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from armctl.collision.contact import Contact
from armctl.collision.errors import CollisionError
from armctl.collision.model import CollisionModel
from armctl.motion.limits import MotionLimits
from armctl.motion.trajectory import Trajectory
from armctl.typing import Array

__all__ = ["check_collisions", "trajectory_contact"]

#: Default sampling step of the check [s].
DT = 0.01
#: Samples per refined step.
_REFINE = 8


def _travel(ts: Array, qd: Array, accel: Array) -> Array:
    """Per step, an upper bound of each joint's path length between the samples."""
    dt = np.diff(ts)[:, None]
    v = np.abs(qd)
    return dt * (v[:-1] + v[1:]) / 2.0 + accel * dt * dt / 2.0


def trajectory_contact(traj: Trajectory, limits: MotionLimits, checker: CollisionModel,
                       dt: float = DT) -> Contact | None:
    """The first contact along a trajectory (its time, pair and depth), or ``None``.

    Args:
        traj: The trajectory.
        limits: The hard limits (their accelerations bound the motion between samples).
        checker: The collision model (use its :meth:`~CollisionModel.escaping` for a motion
            that starts in contact).
        dt: Sampling step [s]; steps that cannot be certified are sampled more densely.
    """
    n = max(2, math.ceil(traj.duration / dt) + 1)
    ts = np.unique(np.concatenate([np.linspace(0.0, traj.duration, n), traj.breakpoints()]))
    q, qd, qdd = traj.sample_many(ts)
    accel = np.maximum(np.where(np.isfinite(limits.acceleration), limits.acceleration, 0.0),
                       np.max(np.abs(qdd), axis=0, initial=0.0))

    def refine(t0: float, t1: float) -> tuple[Array, Array, Array]:
        ft = np.linspace(t0, t1, _REFINE + 1)
        fq, fqd, _ = traj.sample_many(ft)
        return ft, fq, _travel(ft, fqd, accel)

    found = checker.first_contact_on_samples(ts, q, _travel(ts, qd, accel), refine)
    if found is None or found.pair_index < 0:
        return found
    # how deep the pair gets anywhere along the motion (the first contact is at its padding)
    column = checker.slacks_batch(q)[:, found.pair_index] + found.padding
    k = int(np.argmin(column))
    if column[k] < found.distance:
        return replace(found, deepest=float(column[k]), deepest_time=float(ts[k]))
    return replace(found, deepest=found.distance, deepest_time=found.time)


def check_collisions(traj: Trajectory, limits: MotionLimits, checker: CollisionModel,
                     what: str, joint_names: tuple[str, ...] = (), hint: str = "",
                     dt: float = DT) -> None:
    """Refuse a trajectory that brings a link into contact (see :func:`trajectory_contact`).

    Raises:
        CollisionError: Names the pair, the time and joints of the first contact and the depth.
    """
    contact = trajectory_contact(traj, limits, checker, dt)
    if contact is not None:
        raise CollisionError(what, contact, joint_names, hint)
