"""Forward kinematics as CasADi expressions, generated from the compiled model's packed arrays.

The expressions are built from the same compiled tree the numba kernels use (``model.tree``,
:class:`~armctl.kinematics.compiled_tree.CompiledTree`), so there is one description of the arm: a
joint's frame after its motion is ``T_parent @ pre @ M(q)``, with ``M`` a rotation about the
joint axis (Rodrigues) or a translation along it, and a named frame is its anchor joint's frame
times its constant offset. CasADi is imported only when this module is used.
"""

from __future__ import annotations

import re
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from armctl.kinematics.model import KinematicModel

__all__ = ["SymbolicFK", "fk_function"]


def _casadi() -> Any:
    import casadi

    return casadi


class SymbolicFK:
    """Symbolic poses of every joint and named frame of a model for one symbolic ``q``.

    Each joint's frame is built once and shared by every frame below it, so an expression graph
    over several frames does not repeat the common chain.

    Args:
        model: The compiled arm.
        q: A CasADi ``SX`` or ``MX`` column of length ``model.dof``; a fresh ``SX`` symbol named
            ``q`` when ``None``.

    Attributes:
        q: The joint symbol.
    """

    def __init__(self, model: KinematicModel, q: Any = None):
        model.require_one_dof("symbolic forward kinematics (NLP)")
        ca = _casadi()
        self.model = model
        self.q = ca.SX.sym("q", model.dof) if q is None else q
        self._joint: list[tuple[Any, Any] | None] = [None] * model.dof

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
        qj = self.q[j]
        if tree.is_prismatic(j):
            out = (r_pre, p_pre + r_pre @ ca.DM(axis) * qj)
        else:
            c, s = ca.cos(qj), ca.sin(qj)
            k = np.array([[0.0, -axis[2], axis[1]], [axis[2], 0.0, -axis[0]],
                          [-axis[1], axis[0], 0.0]])
            # Rodrigues: R = I + sin K + (1 - cos) K^2 with constant K
            rot = ca.DM.eye(3) + s * ca.DM(k) + (1 - c) * ca.DM(k @ k)
            out = (r_pre @ rot, p_pre)
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
