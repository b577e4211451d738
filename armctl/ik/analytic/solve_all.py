"""Every IK solution of a goal, in closed form: :func:`ik_all` and its result."""

from __future__ import annotations

import weakref
from dataclasses import dataclass, replace
from typing import TYPE_CHECKING, NamedTuple

import numpy as np
import numpy.typing as npt

from armctl.errors import InputError
from armctl.ik.analytic import _families as F
from armctl.ik.analytic._pipeline import (
    BAD_REF,
    COUNT_SHIFT,
    GENERAL,
    NOT_FINITE,
    NOT_ROTATION,
    PAIR,
    PARALLEL,
    SPHERICAL,
    pack6,
    pose6,
    pose6_distinct,
)
from armctl.ik.analytic._polish import assemble, inspect_pose
from armctl.ik.analytic._search import CAPACITY, one_pair
from armctl.ik.analytic.chain import Chain, screw
from armctl.ik.analytic.classify import (
    CLOSED_FORM_KINDS,
    Decomposition,
    Family,
    GoalKind,
    decomposition,
)
from armctl.ik.analytic.errors import NoDecompositionError
from armctl.ik.goals import Goal, PoseGoal
from armctl.kinematics.model import KinematicModel
from armctl.spatial import orthonormalize, transform_inverse
from armctl.typing import Array

if TYPE_CHECKING:
    from armctl.collision.contact import Contact
    from armctl.collision.model import CollisionModel

__all__ = ["ACCEPT", "CONTINUUM", "TWINS", "IKSolutions", "Target", "acceptance", "as_target",
           "ik_all"]


#: Largest position [m] and rotation [rad] error of a returned solution.
ACCEPT = 1e-9
#: Rows closer than this on every joint (modulo 2 pi for rotary ones) are one solution:
#: ([rad] for rotary joints, [m] for prismatic ones).
TWINS = (1e-3, 1e-5)
#: For a singular goal: its representatives closer than this on every joint are one row
#: ([rad], [m]).
CONTINUUM = (0.1, 1e-3)
_CODE = {Family.SPHERICAL_WRIST: SPHERICAL, Family.SPHERICAL_SHOULDER: SPHERICAL,
         Family.THREE_PARALLEL: PARALLEL, Family.THREE_PARALLEL_OUTER: PARALLEL,
         Family.PAIR_SEARCH: PAIR, Family.PAIR_SEARCH_INVERTED: PAIR,
         Family.GENERAL_6R: GENERAL}


@dataclass(frozen=True)
class IKSolutions:
    """All solutions of one goal.

    Attributes:
        q: ``(m, dof)`` joint vectors [rad], sorted by distance to ``q_ref``; every 2*pi variant
            of a joint that fits in its range is listed separately.
        within_limits: ``(m,)`` whether each row lies inside the joint limits.
        position_error: ``(m,)`` FK position error of each row [m].
        rotation_error: ``(m,)`` FK rotation (or direction) error of each row [rad].
        singular: True when the goal has a continuum of solutions (e.g. wrist axes aligned);
            the rows are then representatives of it.
        family: The decomposition used (see :mod:`armctl.ik.analytic.classify`).
        free: Names of the joints held at their ``q_ref`` value (the free joint of a redundant
            arm; for a position goal, every joint but the three that place the point).
        q_ref: The reference configuration the rows are sorted by [rad] (read-only when
            ``ik_all`` took its default, the middle of the ranges: results share it).
        contacts: ``None`` when collisions were not checked; else per row the deepest contact
            of that configuration (pair, distance, depth), or ``None`` for a row free of
            contact (see :meth:`checked`).
    """

    q: Array
    within_limits: npt.NDArray[np.bool_]
    position_error: Array
    rotation_error: Array
    singular: bool
    family: str
    free: tuple[str, ...]
    q_ref: Array
    contacts: tuple[Contact | None, ...] | None = None

    def __len__(self) -> int:
        return int(self.q.shape[0])

    @property
    def valid(self) -> Array:
        """The rows inside the joint limits ``(k, dof)``, nearest to ``q_ref`` first.

        When collisions were checked (:meth:`checked`), only the rows also free of contact.
        """
        keep = self.within_limits
        if self.contacts is not None:
            keep = keep & self.collision_free
        return self.q[keep]

    @property
    def best(self) -> Array | None:
        """The valid solution nearest to ``q_ref``, or None when there is none."""
        v = self.valid
        return v[0] if len(v) else None

    @property
    def collision_free(self) -> npt.NDArray[np.bool_]:
        """``(m,)`` whether each row is free of contact.

        Raises:
            InputError: If collisions were not checked (see :meth:`checked`).
        """
        if self.contacts is None:
            raise InputError("these solutions were not checked for collisions; call "
                             "checked(CollisionModel.of(arm)) or pass avoid= to ik_all")
        return np.array([c is None for c in self.contacts], dtype=bool)

    def checked(self, avoid: CollisionModel) -> IKSolutions:
        """These solutions, each marked free or in contact by the collision checker ``avoid``."""
        return replace(self, contacts=tuple(avoid.contact(q) for q in self.q))

    def distinct(self, rotary: npt.ArrayLike, tol: float | npt.ArrayLike | None = None
                 ) -> IKSolutions:
        """One row per distinct solution, without the 2 pi variants.

        Rows equal modulo 2 pi on every rotary joint are variants of one solution (the same
        pose of the arm). Each solution is represented by its variant inside the limits nearest
        to ``q_ref`` (the nearest variant when none is inside), so :attr:`best` is unchanged;
        the rows stay sorted by distance to ``q_ref``.

        Args:
            rotary: ``(dof,)`` mask of the rotary joints.
            tol: Rows closer than this on every joint (modulo 2 pi for rotary ones) are one
                solution [rad]/[m]; a scalar or ``(dof,)``. ``None``: :data:`TWINS` (rad, m),
                or :data:`CONTINUUM` for a singular goal, whose representatives of the
                continuum closer than that are near-duplicates.
        """
        rot = np.asarray(rotary, dtype=bool)
        if tol is None:
            rad, m = CONTINUUM if self.singular else TWINS
            tol = np.where(rot, rad, m)
        reps: list[int] = []
        for i in range(len(self)):
            for c, r in enumerate(reps):
                d = np.abs(self.q[i] - self.q[r])
                d = np.where(rot, np.minimum(d % (2.0 * np.pi), (-d) % (2.0 * np.pi)), d)
                if bool(np.all(d < tol)):
                    if self.within_limits[i] and not self.within_limits[r]:
                        reps[c] = i
                    break
            else:
                reps.append(i)
        keep = np.array(sorted(reps), dtype=int)
        contacts = (None if self.contacts is None else
                    tuple(self.contacts[int(i)] for i in keep))
        return IKSolutions(self.q[keep], self.within_limits[keep], self.position_error[keep],
                           self.rotation_error[keep], self.singular, self.family, self.free,
                           self.q_ref, contacts)


@dataclass(frozen=True)
class Target:
    """A goal as the kernels take it.

    Attributes:
        kind: What it constrains.
        frame: The goal frame (``None``: the tool).
        pose: ``(4, 4)`` target pose (identity unless ``kind`` is POSE).
        position: Target position [m].
        direction: Target unit direction (DIRECTION goals; zeros otherwise).
        axis: The tool axis that must point along it, in the frame's coordinates.
    """

    kind: GoalKind
    frame: str | None
    pose: Array
    position: Array
    direction: Array
    axis: Array


def acceptance(goal: Goal) -> float:
    """The largest FK error [m] and [rad] at which a closed-form solution meets ``goal``.

    The goal's own tolerance (the smaller of its position and rotation tolerances), never below
    :data:`ACCEPT`: the single answer of the ``analytic`` solver and the full list of
    :func:`ik_all` accept the same solutions. (Some goals are met only to about 1e-6: an arm
    whose CAD angles are rounded, such as 1.5708 for pi/2, cannot point its tool exactly
    along an axis.)
    """
    return max(min(goal.tolerance.position, goal.tolerance.rotation), ACCEPT)


def as_target(goal: Goal | npt.ArrayLike, frame: str | None = None) -> Target:
    """The kernels' form of a goal object or of a ``(4, 4)`` pose array (for ``frame``).

    Raises:
        NoDecompositionError: For an orientation-only goal.
        InputError: For a frame mismatch or a bad pose array.
    """
    if isinstance(goal, Goal):
        if frame is not None and goal.frame != frame:
            raise InputError(f"the goal names frame {goal.frame!r} but frame={frame!r} was given")
        if goal.kind not in CLOSED_FORM_KINDS:
            raise NoDecompositionError(
                "the analytic solvers take pose, position + direction or position goals; "
                f"{goal.label} goals ({type(goal).__name__}) have no closed form here",
                "use solver 'dls' or 'nlp'")
        # the packed targets (armctl.ik._residual), as writable C-contiguous copies: the kernels
        # are compiled for one array type
        row = goal.packed()
        pose = np.eye(4)
        if goal.kind is GoalKind.POSE:
            pose[:3, :3] = row[3:12].reshape(3, 3)
            pose[:3, 3] = row[0:3]
        return Target(goal.kind, goal.frame, pose, row[0:3].copy(), row[12:15].copy(),
                      row[15:18].copy())
    arr = np.array(goal, dtype=float)
    if arr.shape != (4, 4):
        raise InputError(f"a pose must be a finite 4x4 transform, got shape {arr.shape}")
    finite, dev, det = inspect_pose(arr)
    if not finite:
        raise InputError("a pose must be a finite 4x4 transform; it contains NaN or inf")
    if dev > 1e-6 or det < 0:
        raise InputError("the pose's rotation part is not a rotation matrix (R R^T != I or "
                         "det < 0)")
    if dev > 1e-14:
        arr[:3, :3] = orthonormalize(arr[:3, :3])
    arr[3] = (0.0, 0.0, 0.0, 1.0)
    return Target(GoalKind.POSE, frame, arr, arr[:3, 3].copy(), np.zeros(3), np.zeros(3))


def _chain_ref(chain: Chain, q_ref: Array) -> Array:
    return chain.sign * q_ref[chain.index]


def _run(dec: Decomposition, goal: Target, q_ref: Array, out: Array) -> tuple[int, bool, Chain]:
    """Run the closed form; candidates (solver chain order) into ``out``."""
    chain = dec.chain
    fam = dec.family
    if fam is Family.POSITION_3R:
        # held joints fold into the axes after them and into the tool point: the point is
        # E_i E_j E_k (G t0) with each solved axis moved by the held motions before it
        g = np.eye(4)
        hs, os, js = [], [], []
        solved = set(dec.solved)
        for k, j in enumerate(chain.joints):
            if j in solved:
                hs.append(g[:3, :3] @ chain.h[k])
                os.append(g[:3, :3] @ chain.o[k] + g[:3, 3])
                js.append(j)
            else:
                g = g @ screw(chain.h[k], chain.o[k], q_ref[j])
        w = g[:3, :3] @ chain.m[:3, 3] + g[:3, 3]
        sub = Chain(tuple(js), np.array(hs), np.array(os), chain.m, np.ones(3))
        n, sing = F.pos3(sub.h, sub.o, w, goal.position, q_ref[js], out)
        return n, sing, sub
    if fam in (Family.PARALLEL_DIRECTION, Family.YAW_PARALLEL_DIRECTION):
        fn = (F.three_parallel_direction if fam is Family.PARALLEL_DIRECTION
              else F.yaw_three_parallel_direction)
        n, sing = fn(chain.h, chain.o, chain.m, goal.position,
                     goal.direction, goal.axis, _chain_ref(chain, q_ref),
                     out)
        return n, sing, chain
    target = goal.pose
    if dec.free:
        chain, target = _hold(dec, chain, q_ref, target)
    if dec.inverted:
        target = transform_inverse(target)
    fn6 = {SPHERICAL: F.spherical_wrist, PARALLEL: F.three_parallel, PAIR: one_pair}[_CODE[fam]]
    n, sing = fn6(chain.h, chain.o, chain.m, target, _chain_ref(chain, q_ref), out)
    return n, sing, chain


def _hold(dec: Decomposition, chain: Chain, q_ref: Array, target: Array) -> tuple[Chain, Array]:
    """Fold the held end joint (at its reference value) into the tool or into the goal."""
    j = dec.free[0]
    whole = dec.whole
    k = whole.joints.index(j)
    e = screw(whole.h[k], whole.o[k], q_ref[j])
    if k == whole.n - 1:  # last joint held: it moves the tool pose
        full = chain.reversed() if dec.inverted else chain
        full = Chain(full.joints, full.h, full.o, e @ full.m, full.sign)
        return (full.reversed() if dec.inverted else full), target
    return chain, transform_inverse(e) @ target  # first joint held: it moves the goal


def ik_all(model: KinematicModel, pose: Goal | npt.ArrayLike, q_ref: npt.ArrayLike | None = None,
           frame: str | None = None, *, tol: float = ACCEPT,
           free_values: npt.ArrayLike | None = None, variants: bool = False) -> IKSolutions:
    """Every distinct solution of a goal, in closed form, polished to machine precision.

    Args:
        model: The arm.
        pose: A ``(4, 4)`` pose, or a :class:`PoseGoal`, :class:`DirectionGoal` or
            :class:`PositionGoal`.
        q_ref: Reference configuration [rad]: rows are sorted by distance to it, redundant joints
            are held at its values, and continua take their representatives from it. The middle
            of the joint ranges when ``None``.
        frame: The frame for a pose array (the tool when ``None``).
        tol: Largest accepted FK error of a solution [m] and [rad].
        free_values: Values [rad] at which to hold the one free joint of a redundant arm (the
            Panda's joint 7), each solved in turn; the solutions of all of them are listed
            together. ``None``: the joint's ``q_ref`` value.
        variants: List every 2 pi variant of each solution that fits in the joint ranges as a
            row of its own. By default each solution is one row: its variant inside the
            limits nearest to ``q_ref``. Solutions closer than :data:`TWINS` are still listed
            apart (a nearly singular goal has such pairs); :meth:`IKSolutions.distinct` merges
            them for display.

    Returns:
        The solutions (possibly none: the goal is out of reach).

    Raises:
        NoDecompositionError: If the chain or the goal type has no closed form here.
        InputError: For a bad goal or ``q_ref``.
    """
    if free_values is None and not variants:
        fast = _fast(model, pose, q_ref, frame, tol)
        if fast is not None:
            return fast
    goal = as_target(pose, frame)
    dec = decomposition(model, goal.frame, goal.kind)
    ref = model.middle() if q_ref is None else np.array(model.as_q(q_ref, "q_ref"))
    if free_values is None:
        q, inside, errs, singular = _solve(model, dec, goal, ref, tol, variants)
    else:
        if len(dec.free) != 1:
            raise InputError(f"free_values needs exactly one free joint; {dec.label} holds "
                             f"{len(dec.free)}")
        parts = []
        for v in np.atleast_1d(np.asarray(free_values, dtype=float)):
            held = ref.copy()
            held[dec.free[0]] = v
            parts.append(_solve(model, dec, goal, held, tol, variants))
        q = np.concatenate([p[0] for p in parts])
        order = np.argsort(np.linalg.norm(q - ref, axis=1), kind="stable")
        q = q[order]
        inside = np.concatenate([p[1] for p in parts])[order]
        errs = np.concatenate([p[2] for p in parts])[order]
        singular = any(p[3] for p in parts)
    return IKSolutions(q, inside, errs[:, 0], errs[:, 1], singular, dec.label,
                       dec.free_names, ref)


def _solve(model: KinematicModel, dec: Decomposition, goal: Target, ref: Array,
           tol: float, variants: bool) -> tuple[Array, npt.NDArray[np.bool_], Array, bool]:
    """Closed form, polish, variants and ordering for one reference configuration."""
    tree = model.tree
    if goal.kind is GoalKind.POSE and not dec.free:  # the hot path: one compiled call
        code = _CODE[dec.family]
        c = dec.chain
        return pose6(code, dec.inverted, c.h, c.o, c.m, c.index, c.sign, dec.columns, dec.mask,
                     ref, goal.pose, tree.joints, tree.frames, tree.paths,
                     model.frame_index(goal.frame), tol, model.lower, model.upper, variants)
    raw = np.empty((CAPACITY, 7))
    n, singular, chain = _run(dec, goal, ref, raw)
    q, inside, errs, _ = assemble(raw, n, chain.index, chain.sign, dec.columns,
                                  dec.mask, ref, int(goal.kind), goal.pose, goal.position,
                                  goal.direction, goal.axis, tree.joints, tree.frames, tree.paths,
                                  model.frame_index(goal.frame), tol, model.lower, model.upper,
                                  variants)
    return q, inside, errs, bool(singular)


#: Candidates a closed form gives at most, by family code (the 1-D search and the general
#: method up to their buffer): the rows :func:`pose6_distinct` may write.
_MOST = {SPHERICAL: 8, PARALLEL: 8, PAIR: CAPACITY, GENERAL: CAPACITY}


class _Plan(NamedTuple):
    """What the one-call path of :func:`ik_all` needs of an arm and frame, computed once.

    A named tuple: the call unpacks it in one step.

    Attributes:
        arm: The constants of :func:`pose6_distinct` (``None``: no one-call path: no pose
            decomposition, or joints held at ``q_ref``).
        middle: The middle of the joint ranges (the default ``q_ref``) [rad], as the kernel
            takes it (writable arrays: one compiled version).
        shared_middle: A read-only view of it, the ``q_ref`` of the results of calls without
            one (they share it).
        label: The decomposition's label.
        free: Names of the held joints.
        dof: The number of joints.
        rows: The shape of the solution buffer, ``(most candidates, dof + 2)``.
        most: Its number of rows.
    """

    arm: Array | None
    middle: Array
    shared_middle: Array
    label: str
    free: tuple[str, ...]
    dof: int
    rows: tuple[int, int]
    most: int


#: Plans by ``(id(model), frame)``; an entry leaves with its model (``weakref.finalize``).
_PLANS: dict[tuple[int, str | None], _Plan] = {}
#: The dtypes the compiled path takes (compared as dtype instances: no conversion per call).
_F64 = np.dtype(np.float64)
_BOOL = np.dtype(np.bool_)
_POSE_SHAPE = (4, 4)


def _plan(model: KinematicModel, frame: str | None) -> _Plan:
    """The cached :class:`_Plan` of ``model`` for ``frame`` (raises for an unknown frame)."""
    key = (id(model), frame)
    plan = _PLANS.get(key)
    if plan is not None:
        return plan
    f = model.frame_index(frame)
    arm: Array | None = None
    label = ""
    free: tuple[str, ...] = ()
    most = 0
    try:
        dec = decomposition(model, frame, GoalKind.POSE)
    except NoDecompositionError:
        dec = None
    if dec is not None:
        label, free = dec.label, dec.free_names
        c = dec.chain
        if not dec.free and c.n == 6:
            tree = model.tree
            code = _CODE[dec.family]
            most = _MOST[code]
            arm = pack6(c.h, c.o, c.m, np.asarray(c.sign, dtype=float), model.lower,
                        model.upper, tree.joints, tree.frames, tree.paths, code, dec.inverted, f,
                        np.asarray(c.index), np.asarray(dec.columns))
    middle = np.array(model.middle(), dtype=float)
    shared = middle.view()
    shared.flags.writeable = False
    plan = _Plan(arm, middle, shared, label, free, model.dof, (most, model.dof + 2), most)
    _PLANS[key] = plan
    weakref.finalize(model, _PLANS.pop, key, None)
    return plan


def _fast(model: KinematicModel, pose: Goal | npt.ArrayLike, q_ref: npt.ArrayLike | None,
          frame: str | None, tol: float) -> IKSolutions | None:
    """The one-call path of :func:`ik_all` for a pose of a 6R family; ``None``: not taken."""
    if type(pose) is np.ndarray:
        arr = pose
        if arr.shape != _POSE_SHAPE or arr.dtype != _F64:
            return None
    elif type(pose) is PoseGoal:
        if frame is not None and pose.frame != frame:
            return None  # as_target says what is wrong
        arr, frame = pose.pose, pose.frame
    else:
        return None
    consts, middle, shared, label, free, dof, shape, most = (
        _PLANS.get((id(model), frame)) or _plan(model, frame))
    if consts is None:
        return None
    if q_ref is None:
        ref, result_ref = middle, shared  # the kernel only reads it
    elif (type(q_ref) is np.ndarray and q_ref.dtype == _F64
          and q_ref.shape == middle.shape):
        ref = result_ref = q_ref.copy()  # the result's own; checked for NaN by the kernel
    else:
        ref = result_ref = np.array(model.as_q(q_ref, "q_ref"))
    rows = np.empty(shape)
    inside = np.empty(most, _BOOL)
    res = pose6_distinct(consts, ref, arr, tol, rows, inside)
    if res & 14:  # a status other than OK
        status = (res >> 1) & 7
        if status == BAD_REF:
            model.as_q(ref, "q_ref")  # raises with the joint values
        if status == NOT_FINITE:
            raise InputError("a pose must be a finite 4x4 transform; it contains NaN or inf")
        if status == NOT_ROTATION:
            raise InputError("the pose's rotation part is not a rotation matrix (R R^T != I "
                             "or det < 0)")
        return None  # NEEDS_CLEANUP (the general path orthonormalises it) or OVERFLOW
    # a frozen dataclass's __init__ sets each field through object.__setattr__; filling the
    # instance dict directly is the same object for a fraction of the cost
    m = res >> COUNT_SHIFT
    sols = object.__new__(IKSolutions)
    fields = sols.__dict__
    fields["q"] = rows[:m, :dof]
    fields["within_limits"] = inside[:m]
    fields["position_error"] = rows[:m, dof]
    fields["rotation_error"] = rows[:m, dof + 1]
    fields["singular"] = res & 1 == 1
    fields["family"] = label
    fields["free"] = free
    fields["q_ref"] = result_ref
    return sols
