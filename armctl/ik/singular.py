"""Singular configurations of IK goals: where a search that failed got stuck.

A configuration is singular for a set of goals when the goal Jacobian (the residual Jacobian of
the compiled solvers, :mod:`armctl.ik._residual`) has lost rank there: in some joint direction the
goal frame no longer moves to first order, so a Jacobian step (pinv, DLS, J^T) makes no progress
along it (the lecture, L. Kavan, *Metody skeletální animace*, 2002: the pseudoinverse has trouble
near a singular J, and J^T makes no motion when the error lies in Ker(J^T)). The classic case is
an arm stretched straight out, with the goal on the line of its links but closer to the base.

The Jacobian is made dimensionless first: its orientation rows are weighted by the arm's reach
``L`` (a radian of orientation counts as much as ``L`` of position), all rows are divided by
``L``, and the columns of prismatic joints are multiplied by it (their motion is counted in
reach-lengths). Goal weights are left out. Its singular values are compared with the rank the
goals have on this arm almost everywhere (the largest over a few random configurations): a
direction goal along the axis of the last joint, for example, never has full rank, and that is
not a singularity.

A failed search counts as stuck at a singularity (:func:`stuck_at_singularity`) when one of those
singular values is below :data:`SINGULAR_THRESHOLD` and the error still falls along a lost
direction (a probe of :data:`PROBE_STEP` each way): the search stopped at a saddle of the error,
which a Jacobian step cannot see, not at the closest configuration. A goal out of reach, whose
closest configuration (the arm stretched towards it) is singular too, is a minimum of the error
there and is not counted.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np

from armctl.ik._pack import GoalArrays, model_arrays, pack_goals
from armctl.ik._residual import _residual, n_rows
from armctl.ik.goals import Goal
from armctl.kinematics.compiled_tree import JOINT_PRISMATIC
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = [
    "PROBE_STEP",
    "SINGULAR_THRESHOLD",
    "goal_jacobian",
    "goal_rank",
    "singular_value",
    "stuck_at_singularity",
]

#: A configuration is singular for its goals when a singular value of the dimensionless goal
#: Jacobian (among the rank the goals have elsewhere) is below this: a joint turn of 1 rad then
#: moves the goal frame by less than 1/1000 of the arm's reach in a direction the goals
#: constrain.
SINGULAR_THRESHOLD = 1e-3

#: The probe along a lost direction: a joint-space step of this length [rad] (prismatic joints
#: in reach-lengths), clipped into the limits.
PROBE_STEP = 0.05

#: Singular values below this count as zero when the goals' usual rank is measured.
_RANK_TOLERANCE = 1e-6
#: Random configurations (besides the middle of the ranges) that measure the usual rank.
_RANK_SAMPLES = 16
#: A probe must lower the error by this fraction (far above round-off).
_PROBE_GAIN = 1e-6


def goal_jacobian(model: KinematicModel, goals: Sequence[Goal], q: Array) -> Array:
    """The dimensionless goal Jacobian at ``q`` (see the module docstring).

    Args:
        model: The arm.
        goals: The goals.
        q: Joint vector ``(dof,)`` [rad]/[m].

    Returns:
        ``(m, dof)``: one row per residual row of the goals, one column per joint (zero for
        joints that move no goal frame).
    """
    return _evaluate(model, pack_goals(model, goals), q, True)[1]


def _evaluate(model: KinematicModel, ga: GoalArrays, q: Array,
              with_jacobian: bool) -> tuple[float, Array]:
    """Half the squared dimensionless residual at ``q``, and the goal Jacobian (if asked)."""
    _, _, jd, _, fd, paths = model_arrays(model).kernel
    n = model.dof
    g = len(ga.gf)
    m = int(n_rows(ga.gt))
    reach = model.tree.max_reach
    jac = np.zeros((m, n))
    energy = _residual(np.array(q, dtype=float), jd, fd, paths, ga.gf, ga.gt, ga.gd, np.ones(g),
                       reach, np.empty((g, 4, 4)), np.empty((6, n)), np.empty(m), jac,
                       with_jacobian)
    jac /= reach
    jac[:, _prismatic(model)] *= reach
    return float(energy) / reach**2, jac


def _prismatic(model: KinematicModel) -> Array:
    """Which Jacobian columns (tangent entries, ``(nv,)``) belong to prismatic joints."""
    per_joint = model_arrays(model).kernel[2][:, JOINT_PRISMATIC] != 0.0
    if not model.multi_dof_joints:
        return per_joint
    return np.repeat(per_joint, [model.v_index(j).stop - model.v_index(j).start
                                 for j in range(len(model.joint_names))])


def goal_rank(model: KinematicModel, goals: Sequence[Goal]) -> int:
    """The rank of the goal Jacobian at almost every configuration.

    The largest rank over the middle of the ranges and a few random configurations (a fixed
    generator: the answer is reproducible). Only the goals' types, frames and tool axes matter
    (and for a look-at goal its point, through the distance to it).
    """
    ga = pack_goals(model, goals)
    rng = np.random.default_rng(0)
    rank = 0
    for q in (model.middle(), *model.sample(rng, _RANK_SAMPLES)):
        s = np.linalg.svd(_evaluate(model, ga, q, True)[1], compute_uv=False)
        rank = max(rank, int(np.sum(s > _RANK_TOLERANCE)))
    return rank


def singular_value(model: KinematicModel, goals: Sequence[Goal], q: Array,
                   rank: int | None = None) -> float:
    """The smallest singular value of the goal Jacobian at ``q`` among its usual rank.

    Args:
        model: The arm.
        goals: The goals.
        q: Joint vector ``(dof,)`` [rad]/[m].
        rank: :func:`goal_rank` of the goals, when known.

    Returns:
        The ``r``-th largest singular value, ``r`` the goals' usual rank; ``inf`` when the
        goals' frames move with no joint.
    """
    r = goal_rank(model, goals) if rank is None else rank
    if r == 0:
        return float("inf")
    s = np.linalg.svd(goal_jacobian(model, goals, q), compute_uv=False)
    return float(s[r - 1])


def stuck_at_singularity(model: KinematicModel, goals: Sequence[Goal], q: Array,
                         rank: int | None = None) -> float | None:
    """Whether a failed search ended at a singular configuration with the error still falling.

    Args:
        model: The arm.
        goals: The goals, not all reached at ``q``.
        q: Where the search ended ``(dof,)`` [rad]/[m].
        rank: :func:`goal_rank` of the goals, when known.

    Returns:
        The smallest singular value (:func:`singular_value`) when it is below
        :data:`SINGULAR_THRESHOLD` and a probe along a lost direction lowers the error, else
        ``None`` (not singular, or singular at a minimum of the error such as the closest
        configuration to a goal out of reach).
    """
    ga = pack_goals(model, goals)
    energy, jac = _evaluate(model, ga, q, True)
    _, s, vt = np.linalg.svd(jac, full_matrices=False)
    if not len(s) or s[-1] >= SINGULAR_THRESHOLD:
        return None  # not singular, whatever the goals' usual rank
    r = goal_rank(model, goals) if rank is None else rank
    if r == 0 or s[r - 1] >= SINGULAR_THRESHOLD:
        return None
    scale = np.where(_prismatic(model), model.tree.max_reach, 1.0)
    q0 = np.array(q, dtype=float)
    lost = [vt[k] for k in range(r) if s[k] < SINGULAR_THRESHOLD]
    if model.multi_dof_joints:
        # a ball joint leaves a null space of many dimensions, in which the SVD's choice of
        # a lost direction is arbitrary: probe a basis of the whole null space too
        lost += list(np.linalg.svd(jac, full_matrices=True)[2][len(s):])
    for direction in lost:
        for sign in (1.0, -1.0):
            step = sign * PROBE_STEP * direction * scale
            probe = (model.clip(model.integrate(q0, step)) if model.multi_dof_joints
                     else np.clip(q0 + step, model.lower, model.upper))
            if _evaluate(model, ga, probe, False)[0] < energy * (1.0 - _PROBE_GAIN):
                return float(s[r - 1])
    return None
