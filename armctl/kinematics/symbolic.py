"""Forward kinematics as CasADi expressions, generated from the compiled model's packed arrays.

The expressions are built from the same compiled tree the numba kernels use (``model.tree``,
:class:`~armctl.kinematics.compiled_tree.CompiledTree`), so there is one description of the arm: a
joint's frame after its motion is ``T_parent @ pre @ M(q)``, with ``M`` a rotation about the
joint axis (Rodrigues) or a translation along it, for a universal joint the rotation about its
first axis times the one about its second, for a ball joint the rotation matrix of its
quaternion's four entries of ``q`` (scaled to unit norm inside, as the kernels do), and a named
frame is its anchor joint's frame times its constant offset.

:func:`ball_limit_rows` writes a ball joint's unit norm, swing cone and twist range as smooth
rows over its quaternion, exact for the definitions of :mod:`armctl.kinematics.joint_space`.
CasADi is imported only when this module is used.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

import numpy as np

from armctl.config.schema import JointType
from armctl.kinematics.compiled_tree import JOINT_AXIS2, JOINT_KIND, JOINT_Q, KIND_BALL, KIND_ONE

if TYPE_CHECKING:
    from armctl.kinematics.model import KinematicModel

__all__ = ["BallRow", "SymbolicFK", "ball_limit_rows", "fk_function", "twist_bounded"]


def _casadi() -> Any:
    import casadi

    return casadi


class SymbolicFK:
    """Symbolic poses of every joint and named frame of a model for one symbolic ``q``.

    Each joint's frame is built once and shared by every frame below it, so an expression graph
    over several frames does not repeat the common chain.

    Args:
        model: The compiled arm.
        q: A CasADi ``SX`` or ``MX`` column of length ``model.nq`` (a ball joint's four
            quaternion entries ``w, x, y, z`` in place); a fresh ``SX`` symbol named ``q`` when
            ``None``.

    Attributes:
        q: The joint symbol.
    """

    def __init__(self, model: KinematicModel, q: Any = None):
        ca = _casadi()
        self.model = model
        self.q = ca.SX.sym("q", model.nq) if q is None else q
        self._joint: list[tuple[Any, Any] | None] = [None] * len(model.joint_names)

    def _base(self) -> tuple[Any, Any]:
        ca = _casadi()
        return ca.DM.eye(3), ca.DM.zeros(3, 1)

    def joint_frame(self, j: int) -> tuple[Any, Any]:
        """Rotation ``(3, 3)`` and origin ``(3, 1)`` of joint ``j``'s frame after its motion.

        Args:
            j: Actuated joint index; -1 gives the base frame (identity).
        """
        if j < 0:
            return self._base()
        cached = self._joint[j]
        if cached is not None:
            return cached
        ca = _casadi()
        tree = self.model.tree
        r_par, p_par = self.joint_frame(int(tree.parent[j]))
        pre = tree.joint_origin(j)
        r_pre = r_par @ ca.DM(pre[:3, :3])
        p_pre = p_par + r_par @ ca.DM(pre[:3, 3])
        axis = tree.joint_axis(j)
        kind = float(tree.joints[j, JOINT_KIND])
        k = int(tree.joints[j, JOINT_Q])
        qj = self.q[k]
        if kind == KIND_ONE and tree.is_prismatic(j):
            out = (r_pre, p_pre + r_pre @ ca.DM(axis) * qj)
        elif kind == KIND_BALL:
            out = (r_pre @ quat_matrix(ca, self.q[k:k + 4]), p_pre)
        elif kind == KIND_ONE:
            out = (r_pre @ _about(ca, axis, qj), p_pre)
        else:  # universal: about the first axis, then about the second in the moved frame
            axis2 = np.array(tree.joints[j, JOINT_AXIS2])
            out = (r_pre @ _about(ca, axis, qj) @ _about(ca, axis2, self.q[k + 1]), p_pre)
        self._joint[j] = out
        return out

    def frame(self, frame: str | None = None) -> tuple[Any, Any]:
        """Rotation ``(3, 3)`` and position ``(3, 1)`` [m] of a named frame (``None``: the tool)."""
        return self.frame_by_index(self.model.frame_index(frame))

    def frame_by_index(self, f: int) -> tuple[Any, Any]:
        """Rotation and position of the frame with index ``f`` in ``model.frame_names``."""
        ca = _casadi()
        tree = self.model.tree
        r_a, p_a = self.joint_frame(int(tree.anchor[f]))
        off = tree.frame_offset(f)
        return r_a @ ca.DM(off[:3, :3]), p_a + r_a @ ca.DM(off[:3, 3])

    def point(self, body: int, local: np.ndarray) -> Any:
        """A point fixed in joint ``body``'s frame (-1: the base), in base coordinates [m]."""
        ca = _casadi()
        r, p = self.joint_frame(body)
        return p + r @ ca.DM(np.asarray(local, dtype=float).reshape(3))


def _about(ca: Any, axis: np.ndarray, angle: Any) -> Any:
    """The rotation by ``angle`` about a constant unit ``axis`` (Rodrigues)."""
    c, s = ca.cos(angle), ca.sin(angle)
    k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]], [-axis[1], axis[0], 0.0]])
    # R = I + sin K + (1 - cos) K^2 with constant K
    return ca.DM.eye(3) + s * ca.DM(k) + (1 - c) * ca.DM(k @ k)


def quat_matrix(ca: Any, quat: Any) -> Any:
    """The rotation matrix of a symbolic quaternion ``(w, x, y, z)``, scaled to unit norm inside.

    The same formula as the kernels (and :func:`armctl.spatial.quat_to_matrix`), so a
    quaternion a little off unit norm still gives a rotation.
    """
    w, x, y, z = quat[0], quat[1], quat[2], quat[3]
    s = 2 / (w * w + x * x + y * y + z * z)
    return ca.vertcat(
        ca.horzcat(1 - s * (y * y + z * z), s * (x * y - z * w), s * (x * z + y * w)),
        ca.horzcat(s * (x * y + z * w), 1 - s * (x * x + z * z), s * (y * z - x * w)),
        ca.horzcat(s * (x * z - y * w), s * (y * z + x * w), 1 - s * (x * x + y * y)))


@dataclass(frozen=True)
class BallRow:
    """One smooth row of a ball joint's limits, ``expr = 0`` (unit norm) or ``expr <= 0``.

    Attributes:
        joint: The ball joint's name.
        what: ``"unit norm"``, ``"swing"``, ``"twist lower"`` or ``"twist upper"``.
        expr: The CasADi expression.
        equality: Whether the row is an equality.
    """

    joint: str
    what: str
    expr: Any
    equality: bool


def twist_bounded(lower: float, upper: float) -> bool:
    """Whether a ball joint's twist range ``lower..upper`` [rad] limits anything (not -pi..pi)."""
    return lower > -math.pi or upper < math.pi


def ball_limit_rows(model: KinematicModel, q: Any) -> list[BallRow]:
    """The rows of every ball joint's unit norm, swing cone and twist range over ``q``.

    With ``(w, x, y, z)`` the joint's quaternion, ``a`` its twist axis and ``p = (x, y, z) . a``,
    the split ``q = swing ⊗ twist`` has the twist ``(w, p a)`` (normalised) and the swing angle
    ``s`` with ``cos^2(s / 2) = w^2 + p^2`` on the unit sphere; so (every row homogeneous in the
    quaternion, exact at any norm):

    * unit norm: ``w^2 + x^2 + y^2 + z^2 - 1 = 0``;
    * swing ``s <= S`` (any ``S`` in (0, pi], 90 deg and more included, as ``cos^2(s / 2)``
      falls monotonically over [0, pi]): ``cos^2(S / 2) |q|^2 - (w^2 + p^2) <= 0``;
    * twist ``t = 2 atan2(p, w)`` for ``w >= 0`` (:func:`armctl.spatial.swing_twist`), so
      ``t >= L`` is ``sin(L / 2) w - cos(L / 2) p <= 0`` and ``t <= U`` is
      ``cos(U / 2) p - sin(U / 2) w <= 0``: exact while ``w >= 0``, which the caller keeps as a
      bound on ``w`` for a joint with a twist limit (``q`` and ``-q`` are the same rotation, so
      no rotation is lost).

    Args:
        model: The arm.
        q: The symbolic joint vector ``(nq,)``.

    Returns:
        The rows, joint by joint (none for an arm without ball joints).
    """
    out: list[BallRow] = []
    for i, j in enumerate(model.spec.actuated_joints):
        if j.type is not JointType.BALL:
            continue
        sl = model.q_index(i)
        w, v = q[sl.start], q[sl.start + 1:sl.stop]
        a = [float(c) for c in j.axis]
        p = a[0] * v[0] + a[1] * v[1] + a[2] * v[2]
        norm2 = w * w + v[0] * v[0] + v[1] * v[1] + v[2] * v[2]
        out.append(BallRow(j.name, "unit norm", norm2 - 1, True))
        if j.swing < math.pi:
            c2 = math.cos(j.swing / 2) ** 2
            out.append(BallRow(j.name, "swing", c2 * norm2 - (w * w + p * p), False))
        lo, hi = j.limits.lower, j.limits.upper
        if twist_bounded(lo, hi):
            if lo > -math.pi:
                out.append(BallRow(j.name, "twist lower",
                                   math.sin(lo / 2) * w - math.cos(lo / 2) * p, False))
            if hi < math.pi:
                out.append(BallRow(j.name, "twist upper",
                                   math.cos(hi / 2) * p - math.sin(hi / 2) * w, False))
    return out


def fk_function(model: KinematicModel, frame: str | None = None) -> Any:
    """A CasADi function ``q -> (4, 4)`` pose of one frame.

    Args:
        model: The compiled arm.
        frame: Frame name; the tool frame when ``None``.

    Returns:
        ``casadi.Function`` named ``fk_<frame>`` (non-alphanumerics replaced) with one input
        ``q`` and one output ``T``.
    """
    ca = _casadi()
    sym = SymbolicFK(model)
    r, p = sym.frame(frame)
    pose = ca.vertcat(ca.horzcat(r, p), ca.DM([[0.0, 0.0, 0.0, 1.0]]))
    name = re.sub(r"[^A-Za-z0-9]+", "_", frame or model.tool).strip("_")
    return ca.Function(f"fk_{name or 'frame'}", [sym.q], [pose], ["q"], ["T"])
