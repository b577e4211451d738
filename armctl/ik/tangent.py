"""Numerical IK for arms with universal and ball joints, stepping in the tangent space.

The compiled engine (:mod:`armctl.ik._engine`) steps 1-DOF joints, ``q += dq``. An arm with a
ball joint (a unit quaternion in ``q``) or a universal joint takes the same methods here: the
stacked goal residual and its Jacobian have one column per tangent entry
(:attr:`~armctl.kinematics.model.KinematicModel.nv`: a ball joint's three columns are the axes of
its moved frame, the lecture's column form, L. Kavan, *Metody skeletální animace*, 2002), each
method computes a tangent step ``v``, and :meth:`~armctl.kinematics.model.KinematicModel.integrate`
applies it (a ball joint: ``q ⊗ exp(v / 2)``), then
:meth:`~armctl.kinematics.model.KinematicModel.clip` projects into the limits (a ball joint into
its swing cone and twist range).

* ``pinv``: ``v = J^+ e`` (singular values below ``rcond`` times the largest dropped).
* ``dls`` (and ``auto``): ``v = J^T (J J^T + lambda^2 I)^-1 e``, ``lambda`` adapted: halved
  after a step that lowers the error, doubled (and the step refused) otherwise.
* ``jt``: ``v = alpha J^T e`` with the optimal length ``alpha = e.JJ^Te / |JJ^Te|^2``.
* ``ccd``: joints from the tip inward, each minimising the lecture's weighted objective
  ``sum a_k |t_k - R u_k|^2`` over its own motion in closed form: a position goal gives the
  pair joint-to-effector ``u`` / joint-to-goal ``t`` (weight the goal's), an orientation or pose
  goal the three axes of the frame and of the target (weight the goal's times ``rw^2``). A ball
  joint takes the best rotation of Wahba's problem (the SVD of ``sum a t u^T``; for a single
  position goal exactly the shortest rotation taking ``u`` onto ``t``); a 1-DOF rotary joint,
  and each axis of a universal joint in turn, the closed-form angle about its axis; a prismatic
  joint the slide toward the first position goal. Each move is projected into the limits at
  once (a ball joint into its cone and twist range). Direction and look-at goals add no pairs
  (``ccd-jt``'s Jacobian-transpose steps serve them).
* ``ccd-jt``: CCD sweeps alternated with optimal Jacobian-transpose steps.

With null-space criteria (:attr:`IKOptions.nullspace`), ``pinv``, ``dls`` and ``auto`` go on from
the first configuration that meets the goals along the lecture's redundancy step
``v = J^+ e + (I - J^+ J) dz``, ``dz = -gain grad h`` with ``h`` and its tangent-space gradient
from :class:`armctl.ik.nullspace.TangentObjective` (posture measured by
:meth:`~armctl.kinematics.model.KinematicModel.difference`, a ball joint's swing and twist margins,
keep-out spheres through the tangent Jacobian); a step is kept only when every goal is still met
and ``h`` fell, else the next one is four times shorter, for :attr:`NullSpace.iterations` steps.

Restarts draw uniformly inside the limits (:meth:`KinematicModel.sample`, uniform rotations in a
ball joint's cone and twist range) from a seeded generator. Success is decided by
:func:`armctl.ik.result.finish` from forward kinematics and the limits, never here.
"""

from __future__ import annotations

import math
import time

import numpy as np

from armctl.config.schema import JointType
from armctl.ik import _residual as R
from armctl.ik.goals import Goal, OrientationGoal, PoseGoal
from armctl.ik.nullspace import TangentObjective
from armctl.ik.options import IKOptions
from armctl.ik.result import IKResult, IKStatus, finish
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = ["NULLSPACE_METHODS", "TANGENT_METHODS", "solve_tangent"]

#: The methods this module runs (registry names).
TANGENT_METHODS = frozenset({"auto", "pinv", "dls", "jt", "ccd", "ccd-jt"})

_RCOND = 1e-4
_MAX_STEP = 0.5  # [rad] or [m]: the largest tangent step norm of one iteration
_NS_STEP = 0.1  # [rad] or [m]: the largest null-space step, as the compiled engine's
_NS_CORRECTIONS = 3  # pseudoinverse steps that bring a null-space step back onto the goals
#: The methods that honour null-space criteria (the others ignore them, as for other arms).
NULLSPACE_METHODS = frozenset({"auto", "pinv", "dls"})


class _Problem:
    """The packed goals and scratch arrays of one solve."""

    def __init__(self, model: KinematicModel, goals: tuple[Goal, ...]) -> None:
        from armctl.ik._pack import pack_goals

        self.model = model
        self.goals = goals
        ga = pack_goals(model, goals)
        self.ga = ga
        self.m = R.n_rows(ga.gt)
        self.rw = math.sqrt(2.0) * 0.25 * model.tree.max_reach  # the engine's default weight
        self.pose = np.empty((len(goals), 4, 4))
        self.jg = np.empty((6, model.nv))
        self.e = np.empty(self.m)
        self.jac = np.empty((self.m, model.nv))

    def residual(self, q: Array, with_jac: bool = True) -> float:
        t = self.model.tree
        ga = self.ga
        return float(R._residual(q, t.joints, t.frames, t.paths, ga.gf, ga.gt, ga.gd, ga.gw,
                                 self.rw, self.pose, self.jg, self.e, self.jac, with_jac))

    def met(self, q: Array) -> bool:
        return all(g.reached(self.model.fk(q, g.frame)) for g in self.goals)


def _cap(v: Array) -> Array:
    n = float(np.linalg.norm(v))
    return v * (_MAX_STEP / n) if n > _MAX_STEP else v


def _pinv_step(p: _Problem) -> Array:
    return np.asarray(np.linalg.pinv(p.jac, rcond=_RCOND) @ p.e, dtype=float)


def _dls_step(p: _Problem, lam: float) -> Array:
    jjt = p.jac @ p.jac.T
    jjt[np.diag_indices_from(jjt)] += lam * lam
    return np.asarray(p.jac.T @ np.linalg.solve(jjt, p.e), dtype=float)


def _jt_step(p: _Problem) -> Array:
    g = p.jac.T @ p.e
    jg = p.jac @ g
    den = float(jg @ jg)
    return g * (float(p.e @ jg) / den) if den > 1e-30 else g * 0.0


def _pairs(p: _Problem, q: Array, j: int, origin: Array) -> list[tuple[float, Array, Array]]:
    """The weighted vector pairs ``(a, u, t)`` of joint ``j``'s CCD objective ``sum a |t - R u|^2``.

    A position goal adds the joint-to-effector and joint-to-goal vectors (weight the goal's),
    an orientation (or pose) goal the three axes of the frame and of the target (weight the
    goal's times ``rw^2`` [m^2/rad^2], the engine's orientation scale).
    """
    model = p.model
    out: list[tuple[float, Array, Array]] = []
    for kind, goal in zip(p.ga.gt, p.goals, strict=True):
        if j not in model.chain(goal.frame):
            continue
        tip = model.fk(q, goal.frame)
        k = int(kind)
        target = goal.target_position
        if target is not None and k in (R.POSITION, R.POSE):
            out.append((goal.weight, tip[:3, 3] - origin, np.asarray(target, float) - origin))
        rot = (np.asarray(goal.rotation) if isinstance(goal, OrientationGoal) else
               np.asarray(goal.pose)[:3, :3] if isinstance(goal, PoseGoal) else None)
        if rot is not None:
            for c in range(3):
                out.append((goal.weight * p.rw * p.rw, tip[:3, c], rot[:, c]))
    return out


def _axis_angle(pairs: list[tuple[float, Array, Array]], axis: Array) -> float:
    """The lecture's closed-form CCD angle about a unit axis.

    The turn that best brings every ``u`` onto its ``t`` (weights ``a``).
    """
    num = den = 0.0
    for a, u, t in pairs:
        num += a * float(axis @ np.cross(u, t))
        den += a * (float(u @ t) - float(axis @ u) * float(axis @ t))
    return math.atan2(num, den) if abs(num) + abs(den) > 1e-18 else 0.0


def _ccd_sweep(p: _Problem, q: Array) -> Array:
    """One CCD sweep from the tip inward (see the module docstring)."""
    model = p.model
    for j in reversed(range(len(model.joint_names))):
        world = _joint_world(model, q, j)
        pairs = _pairs(p, q, j, world[:3, 3])
        if not pairs:
            continue
        jtype = model.joint_types[j]
        v = np.zeros(model.nv)
        sl = model.v_index(j)
        if jtype is JointType.BALL:  # Wahba's problem: the best rotation of every u onto its t
            b = sum(a * np.outer(t, u) for a, u, t in pairs)
            uu, _, vt = np.linalg.svd(b)
            d = np.sign(np.linalg.det(uu @ vt)) or 1.0
            turn = uu @ np.diag([1.0, 1.0, d]) @ vt
            from armctl.spatial import matrix_to_rotvec

            v[sl] = world[:3, :3].T @ matrix_to_rotvec(turn)  # into the joint's moved frame
            q = model.clip(model.integrate(q, v))
        elif jtype is JointType.PRISMATIC:
            axis = model.jacobian(q, model.spec.actuated_joints[j].child)[:3, sl.start]
            slides = [(a, float(axis @ (t - u))) for a, u, t in pairs[:1]]
            if slides:
                v[sl] = slides[0][1]
                q = model.clip(model.integrate(q, v))
        else:  # revolute, continuous, each axis of a universal joint in turn
            for k in range(sl.stop - sl.start):
                child = model.spec.actuated_joints[j].child
                axis = model.jacobian(q, child)[3:, sl.start + k]
                world = _joint_world(model, q, j)
                pairs = _pairs(p, q, j, world[:3, 3])
                step = np.zeros(model.nv)
                step[sl.start + k] = _axis_angle(pairs, axis)
                q = model.clip(model.integrate(q, step))
    return q


def _movable(model: KinematicModel, goals: tuple[Goal, ...]) -> Array:
    """1.0 for each tangent entry of a joint that moves a goal's frame, else 0.0."""
    out = np.zeros(model.nv)
    for g in goals:
        for j in model.chain(g.frame):
            out[model.v_index(j)] = 1.0
    return out


def _refine(p: _Problem, q: Array, h: TangentObjective, deadline: float) -> tuple[Array, int]:
    """Lower ``h`` along the self-motion of a configuration ``q`` that meets the goals.

    Each step is ``v = J^+ e + (I - J^+ J) dz`` with ``dz = -gain scale grad h`` (capped at
    :data:`_NS_STEP` times ``scale``), applied by ``integrate`` and ``clip``, followed by up to
    :data:`_NS_CORRECTIONS` pseudoinverse steps back onto the goals; it is kept when
    every goal is still met and ``h`` fell (``scale`` then doubles, at most 1), else ``scale``
    is quartered; six refused steps in all, the iteration budget or the deadline end it.

    Returns:
        The best configuration (meeting every goal) and the steps taken.
    """
    model, ns = p.model, h.ns
    movable = _movable(model, p.goals)
    best_q, best_h = q, h(q)
    scale, refused, steps = 1.0, 0, 0
    for _ in range(ns.iterations):
        steps += 1
        p.residual(best_q)
        jp = np.linalg.pinv(p.jac, rcond=_RCOND)
        grad = h.gradient(best_q) * movable
        dz = -ns.gain * scale * (grad - jp @ (p.jac @ grad))
        n = float(np.linalg.norm(dz))
        if n > _NS_STEP * scale:
            dz *= _NS_STEP * scale / n
        qn = model.clip(model.integrate(best_q, jp @ p.e + dz))
        for _ in range(_NS_CORRECTIONS):  # back onto the goals: the step's second-order drift
            if p.met(qn):
                break
            p.residual(qn)
            qn = model.clip(model.integrate(qn, _cap(_pinv_step(p))))
        hn = h(qn)
        if p.met(qn) and hn < best_h - 1e-12 * (1.0 + abs(best_h)):
            best_q, best_h, scale = qn, hn, min(2.0 * scale, 1.0)
        else:
            refused += 1
            scale *= 0.25
            if refused >= 6:
                break
        if time.perf_counter() > deadline:
            break
    return best_q, steps


def _joint_world(model: KinematicModel, q: Array, j: int) -> Array:
    """The world pose of joint ``j``'s frame after its motion (its child link's frame)."""
    return model.fk(q, model.spec.actuated_joints[j].child)


def solve_tangent(model: KinematicModel, goals: tuple[Goal, ...], q0: Array,
                  options: IKOptions, solver: str) -> IKResult:
    """Solve IK on an arm with universal or ball joints (see the module docstring).

    Args:
        model: The arm.
        goals: The goals.
        q0: The start ``(nq,)``, inside the limits.
        options: Iterations per attempt, restarts, time limit, seed, null-space criteria
            (``pinv``, ``dls`` and ``auto``; the other methods ignore them).
        solver: One of :data:`TANGENT_METHODS`.

    Returns:
        The result; ``success`` from forward kinematics and the limits.
    """
    p = _Problem(model, goals)
    p.residual(model.clip(q0))  # loads the compiled kernels before the clock starts
    p.met(model.clip(q0))
    started = time.perf_counter()
    ns = options.nullspace
    objective = (TangentObjective(model, ns, goals[0].frame)
                 if ns is not None and ns.active and solver in NULLSPACE_METHODS else None)
    rng = np.random.default_rng(options.seed)
    avoid = options.avoid
    best_q, best_e = q0, math.inf
    contact_q: Array | None = None  # the answer with the shallowest contact, when all collide
    contact_depth = math.inf
    found = 0
    iterations = 0
    attempts = 0
    status = IKStatus.MAX_ITERATIONS
    q = model.clip(q0)
    # restarts draw the joints that move a goal frame; the others keep their start values
    held = np.ones(model.nq, dtype=bool)
    for j in {j for g in goals for j in model.chain(g.frame)}:
        held[model.q_index(j)] = False
    start = q.copy()
    while attempts <= options.restarts:
        attempts += 1
        en = p.residual(q)
        lam = 0.05 * model.tree.max_reach
        met = False
        for _ in range(options.max_iterations):
            iterations += 1
            if p.met(q):
                met = True
                break
            if solver in ("ccd", "ccd-jt"):
                q = _ccd_sweep(p, q)
                if solver == "ccd-jt":
                    p.residual(q)
                    q = model.clip(model.integrate(q, _cap(_jt_step(p))))
                en = p.residual(q)
                continue
            if solver == "pinv":
                step = _pinv_step(p)
            elif solver == "jt":
                step = _jt_step(p)
            else:
                step = _dls_step(p, lam)
            qn = model.clip(model.integrate(q, _cap(step)))
            en2 = p.residual(qn)
            if solver in ("dls", "auto"):
                if en2 < en:
                    q, en, lam = qn, en2, max(lam * 0.5, 1e-6)
                else:
                    lam *= 2.0
                    p.residual(q)
            else:
                q, en = qn, en2
            if time.perf_counter() - started > options.time_limit:
                break
        if met or p.met(q):
            if objective is not None:
                q, steps = _refine(p, q, objective, started + options.time_limit)
                iterations += steps
            contact = avoid.contact(q) if avoid is not None else None
            if contact is None:
                return finish(model, goals, q, solver=solver, status=IKStatus.CONVERGED,
                              iterations=iterations, restarts=attempts - 1, started=started,
                              start=q0, avoid=avoid)
            found += 1  # an answer in contact: set aside, search on from a random start
            if contact.depth < contact_depth:
                contact_q, contact_depth = q, contact.depth
        elif en < best_e:
            best_q, best_e = q, en
        if time.perf_counter() - started > options.time_limit:
            status = IKStatus.TIME_LIMIT
            break
        q = model.sample(rng)
        q[held] = start[held]
    if contact_q is not None:
        note = (f"{found} answer(s) found in {attempts} start(s), every one in contact; the one "
                "with the shallowest contact is returned")
        return finish(model, goals, contact_q, solver=solver, status=IKStatus.CONVERGED,
                      iterations=iterations, restarts=attempts - 1, started=started, start=q0,
                      avoid=avoid, message=note)
    return finish(model, goals, best_q, solver=solver, status=status, iterations=iterations,
                  restarts=attempts - 1, started=started, start=q0, search=True, avoid=avoid)
