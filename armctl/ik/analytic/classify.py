"""Which closed form fits a chain: classification from the geometry of its joint axes.

Consecutive axes are tested for meeting in one point and for being parallel, within
:class:`Tolerances`, with the joint and tool offsets as they are in the model. The first family
that fits is chosen; its axes are then idealised (exact common point, exact common direction)
and the small difference, if any, is removed by the polish on the exact FK.
"""

from __future__ import annotations

import itertools
import weakref
from dataclasses import dataclass, replace
from enum import Enum
from functools import cached_property

import numpy as np
import numpy.typing as npt

from armctl.ik.analytic.chain import Chain, chain_of
from armctl.ik.analytic.errors import NoDecompositionError
from armctl.ik.goals import GoalKind
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = ["CLOSED_FORM_KINDS", "Decomposition", "Family", "GoalKind", "Tolerances", "classify",
           "decomposition", "describe"]


class Family(Enum):
    """The decomposable chain families (``value``: how :func:`describe` names them)."""

    SPHERICAL_WRIST = "spherical wrist (Pieper): axes 4, 5, 6 meet"
    SPHERICAL_SHOULDER = "spherical shoulder: axes 1, 2, 3 meet (solved inverted)"
    THREE_PARALLEL = "three parallel axes 2, 3, 4 (UR type)"
    THREE_PARALLEL_OUTER = "three parallel axes 3, 4, 5 (solved inverted)"
    PAIR_SEARCH = "axes 5, 6 meet: 1-D search over joint 4"
    PAIR_SEARCH_INVERTED = "axes 1, 2 meet: 1-D search over joint 3 (solved inverted)"
    PARALLEL_DIRECTION = "5R with parallel axes 2, 3, 4: position + tool direction"
    YAW_PARALLEL_DIRECTION = "4R yaw + parallel axes 2, 3, 4: position + tool direction"
    POSITION_3R = "three joints place the tool point"
    GENERAL_6R = "general 6R: Raghavan-Roth elimination, 24 x 24 eigenvalue problem"


#: The goal kinds that have closed forms, the richest first.
CLOSED_FORM_KINDS = (GoalKind.POSE, GoalKind.DIRECTION, GoalKind.POSITION)

#: Most joint triples tried for a position goal, in order (1, 2, 3), (1, 2, 4), ...: an arm
#: of 7 joints has 35, while a long chain whose axes are parallel or meet would be searched
#: for minutes (200 joints have 1.3 million triples).
MAX_TRIPLES = 2000

#: Maximum solution count per family (for buffers and documentation).
MAX_SOLUTIONS = {
    Family.SPHERICAL_WRIST: 8, Family.SPHERICAL_SHOULDER: 8, Family.THREE_PARALLEL: 8,
    Family.THREE_PARALLEL_OUTER: 8, Family.PAIR_SEARCH: 16, Family.PAIR_SEARCH_INVERTED: 16,
    Family.PARALLEL_DIRECTION: 8,
    Family.YAW_PARALLEL_DIRECTION: 4, Family.POSITION_3R: 4, Family.GENERAL_6R: 16,
}


@dataclass(frozen=True)
class Tolerances:
    """How close counts as special geometry.

    Attributes:
        angle: Largest angle between axes that count as parallel [rad].
        distance: Largest distance of axes from a common point that count as meeting [m].
    """

    angle: float = 1e-6
    distance: float = 1e-6


@dataclass(frozen=True)
class Decomposition:
    """How a chain is solved in closed form.

    Attributes:
        family: The chain family.
        kind: The goal type it solves.
        chain: The chain as the solver sees it (inverted for the ``*_SHOULDER``/``*_OUTER``
            families; idealised axes).
        inverted: Whether the solver works on the inverse chain.
        free: Model joint indices held at their reference value (redundant joints).
        solved: Model joint indices the closed form solves for (and the polish may move).
        whole: The model's whole chain to the frame, base outwards, as in the model.
        dof: The model's number of joints.
        label: The family and the held joints, for display.
        free_names: Names of the held joints.
    """

    family: Family
    kind: GoalKind
    chain: Chain
    inverted: bool
    free: tuple[int, ...]
    solved: tuple[int, ...]
    whole: Chain
    dof: int = 0
    label: str = ""
    free_names: tuple[str, ...] = ()

    @cached_property
    def columns(self) -> npt.NDArray[np.int64]:
        """The solved joint indices as an array."""
        return np.array(self.solved, dtype=np.int64)

    @cached_property
    def mask(self) -> npt.NDArray[np.bool_]:
        """``(dof,)`` True for the solved joints."""
        out = np.zeros(self.dof, dtype=np.bool_)
        out[list(self.solved)] = True
        return out

    def describe(self, model: KinematicModel) -> str:
        """One line: the family, and the joints held as free parameters."""
        text = self.family.value
        if self.free:
            shown = [model.joint_names[j] for j in self.free]
            more = ""
            if len(shown) > 6:  # a long chain: the first and last few
                shown, more = [*shown[:3], "...", *shown[-2:]], f" ({len(self.free)} joints)"
            text += f"; free parameter: {', '.join(shown)}{more}"
        return text


def _parallel(a: Array, b: Array, tol: Tolerances) -> bool:
    return bool(np.linalg.norm(np.cross(a, b)) <= tol.angle)


def _common_point(h: Array, o: Array, tol: Tolerances) -> Array | None:
    """The point nearest to the lines ``(o[i], h[i])`` if all pass within tolerance of it."""
    a = np.zeros((3, 3))
    b = np.zeros(3)
    for hi, oi in zip(h, o, strict=True):
        p = np.eye(3) - np.outer(hi, hi)
        a += p
        b += p @ oi
    if np.linalg.cond(a) > 1e8:  # all parallel: no single point
        return None
    w: Array = np.asarray(np.linalg.solve(a, b), dtype=np.float64)
    for hi, oi in zip(h, o, strict=True):
        d = (w - oi) - hi * float(hi @ (w - oi))
        if np.linalg.norm(d) > tol.distance:
            return None
    return w


def _meet(chain: Chain, idx: tuple[int, ...], tol: Tolerances) -> Chain | None:
    """``chain`` with axes ``idx`` moved through their common point, or None."""
    w = _common_point(chain.h[list(idx)], chain.o[list(idx)], tol)
    if w is None:
        return None
    o = np.array(chain.o)
    o[list(idx)] = w
    return chain.with_axes(chain.h, o, chain.sign)


def _parallel3(chain: Chain, first: int, tol: Tolerances) -> Chain | None:
    """``chain`` with axes ``first .. first + 2`` made exactly parallel, or None."""
    h0 = chain.h[first]
    if not all(_parallel(h0, chain.h[k], tol) for k in (first + 1, first + 2)):
        return None
    h = np.array(chain.h)
    sign = np.array(chain.sign)
    for k in (first + 1, first + 2):
        if float(h[k] @ h0) < 0:
            sign[k] = -sign[k]
        h[k] = h0
    return chain.with_axes(h, chain.o, sign)


def _pose6(chain: Chain, tol: Tolerances) -> tuple[Family, Chain, bool] | None:
    """The 6R pose family of ``chain``: (family, solver chain, inverted)."""
    c = _meet(chain, (3, 4, 5), tol)
    if c is not None:
        return Family.SPHERICAL_WRIST, c, False
    c = _parallel3(chain, 1, tol)
    if c is not None:
        return Family.THREE_PARALLEL, c, False
    rev = chain.reversed()
    c = _meet(rev, (3, 4, 5), tol)
    if c is not None:
        return Family.SPHERICAL_SHOULDER, c, True
    c = _parallel3(rev, 1, tol)
    if c is not None:
        return Family.THREE_PARALLEL_OUTER, c, True
    for fam, ch, inv in ((Family.PAIR_SEARCH, chain, False),
                         (Family.PAIR_SEARCH_INVERTED, rev, True)):
        if _parallel(ch.h[4], ch.h[5], tol):
            continue
        c = _meet(ch, (4, 5), tol)
        if c is not None and _places_point(c, tol):
            # The eigenvalue method is complete; the 1-D search is the fallback for chains on
            # which the elimination is not well posed (several special pairs, e.g. the torso).
            for g, g_inv in ((chain, False), (rev, True)):
                if _general_ok(g):
                    return Family.GENERAL_6R, g, g_inv
            return fam, c, inv
    return None


def _places_point(chain: Chain, tol: Tolerances) -> bool:
    """Whether joints 1-3 of ``chain`` can place a point (not concurrent, not all parallel)."""
    planar = all(_parallel(chain.h[0], chain.h[k], tol) for k in (1, 2))
    return not planar and _common_point(chain.h[:3], chain.o[:3], tol) is None


def _general_ok(chain: Chain) -> bool:
    """Whether the general 6R elimination recovers known configurations of ``chain``."""
    from armctl.ik.analytic.general6r import well_posed

    return well_posed(chain.h, chain.o, chain.m)


def _sub(chain: Chain, keep: slice) -> Chain:
    return Chain(chain.joints[keep], chain.h[keep], chain.o[keep], chain.m, chain.sign[keep])


def classify(model: KinematicModel, frame: str | None = None, kind: GoalKind = GoalKind.POSE,
             tol: Tolerances = Tolerances()) -> Decomposition:
    """Find the closed form for goals of type ``kind`` on ``frame``.

    Args:
        model: The arm.
        frame: The goal frame; the tool when ``None``.
        kind: The goal type.
        tol: Geometry tolerances.

    Returns:
        The decomposition.

    Raises:
        NoDecompositionError: If no family fits (a 6R chain on which the general elimination
            is not well posed, a prismatic joint, a goal type the chain cannot meet in closed
            form; an arm with universal or ball joints).
    """
    if model.multi_dof_joints:
        raise NoDecompositionError(
            f"arm {model.name!r} has the multi-DOF joint(s) "
            f"{', '.join(repr(n) for n in model.multi_dof_joints)}; the closed forms here are "
            "for chains of 1-DOF joints",
            "write a spherical wrist as three revolute joints for analytic IK, or keep the "
            "ball joint and use a numerical solver")
    dec = _classify(model, frame, kind, tol)
    return replace(dec, dof=model.dof, label=dec.describe(model),
                   free_names=tuple(model.joint_names[j] for j in dec.free))


def _classify(model: KinematicModel, frame: str | None, kind: GoalKind,
              tol: Tolerances) -> Decomposition:
    """:func:`classify` without the labels (see there)."""
    chain = chain_of(model, frame)
    n = chain.n
    hint = "use solver 'dls' or 'nlp' for this arm"
    if kind not in CLOSED_FORM_KINDS:
        raise NoDecompositionError(f"{kind.label} goals have no closed form here",
                                   "use solver 'dls' or 'nlp'")
    if kind is GoalKind.POSITION:
        if n < 3:
            raise NoDecompositionError(f"arm {model.name!r} has {n} joints before its frame; "
                                       "a position goal needs 3", hint)
        h = chain.h
        if np.all(np.linalg.norm(np.cross(h[0], h), axis=1) <= tol.angle):
            raise NoDecompositionError(f"no three joints of arm {model.name!r} can place its "
                                       f"frame in space: its {n} axes are parallel", hint)
        for count, tri in enumerate(itertools.combinations(range(n), 3)):
            if count == MAX_TRIPLES:  # a long chain of concurrent axes: stop searching
                raise NoDecompositionError(
                    f"none of the first {MAX_TRIPLES} triples of the {n} joints of arm "
                    f"{model.name!r} can place its frame in space", hint)
            sel = list(tri)
            planar = all(_parallel(chain.h[sel[0]], chain.h[k], tol) for k in sel[1:])
            if planar or _common_point(chain.h[sel], chain.o[sel], tol) is not None:
                continue  # these three cannot place a point in space
            solved = tuple(chain.joints[k] for k in sel)
            free = tuple(j for j in chain.joints if j not in solved)
            return Decomposition(Family.POSITION_3R, kind, chain, False, free, solved, chain)
        raise NoDecompositionError(f"no three joints of arm {model.name!r} can place its "
                                   "frame in space", hint)
    if kind is GoalKind.DIRECTION:
        if n == 5 and (c := _parallel3(chain, 1, tol)) is not None:
            return Decomposition(Family.PARALLEL_DIRECTION, kind, c, False, (), c.joints,
                                 chain)
        if n == 4 and (c := _parallel3(chain, 1, tol)) is not None:
            return Decomposition(Family.YAW_PARALLEL_DIRECTION, kind, c, False, (), c.joints,
                                 chain)
        raise NoDecompositionError(
            f"no closed form for a position + direction goal on the {n}-joint chain of arm "
            f"{model.name!r} (known: 5 joints or 4 joints with axes 2, 3, 4 parallel)", hint)
    if n == 6:
        found = _pose6(chain, tol)
        if found is not None:
            fam, c, inv = found
            return Decomposition(fam, kind, c, inv, (), chain.joints, chain)
        for c, inv in ((chain, False), (chain.reversed(), True)):
            if _general_ok(c):
                return Decomposition(Family.GENERAL_6R, kind, c, inv, (), chain.joints, chain)
        raise NoDecompositionError(
            f"arm {model.name!r} is a 6R chain in no family (no three axes meeting in a point, "
            "no three parallel axes, axes 5 and 6 (or 1 and 2) not meeting) on which the "
            "general 6R elimination is well posed", hint)
    if n == 7:
        for keep, held in ((slice(0, 6), 6), (slice(1, 7), 0)):
            found = _pose6(_sub(chain, keep), tol)
            if found is not None:
                fam, c, inv = found
                return Decomposition(fam, kind, c, inv, (chain.joints[held],),
                                     chain.joints[keep], chain)
        raise NoDecompositionError(
            f"arm {model.name!r} (7 joints) has no decomposable 6-joint sub-chain with its first "
            "or last joint held", hint)
    raise NoDecompositionError(
        f"a full pose goal needs 6 or 7 joints; the chain of arm {model.name!r} has {n}", hint)


_CACHE: weakref.WeakKeyDictionary[KinematicModel, dict[tuple[str | None, GoalKind],
                                                         Decomposition | NoDecompositionError]]
_CACHE = weakref.WeakKeyDictionary()


def decomposition(model: KinematicModel, frame: str | None, kind: GoalKind) -> Decomposition:
    """:func:`classify` with default tolerances, cached per model, frame and goal type."""
    per_model = _CACHE.setdefault(model, {})
    key = (frame, kind)
    if key not in per_model:
        try:
            per_model[key] = classify(model, frame, kind)
        except NoDecompositionError as exc:
            per_model[key] = exc
    found = per_model[key]
    if isinstance(found, NoDecompositionError):
        raise found
    return found


def describe(model: KinematicModel, frame: str | None = None) -> str:
    """The analytic IK family of a frame for the richest goal type it supports, for display."""
    for kind in CLOSED_FORM_KINDS:
        try:
            dec = decomposition(model, frame, kind)
        except NoDecompositionError:
            continue
        return f"{dec.describe(model)} ({kind.label} goals)"
    return "none (use a numerical solver)"
