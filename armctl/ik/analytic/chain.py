"""A serial chain in product-of-exponentials form, and the rigid rewrites the solvers need.

At the zero configuration each revolute joint ``i`` has a unit axis ``h[i]`` through a point
``o[i]`` (base frame) and the tool has the pose ``m``; the tool pose at ``q`` is
``E1(q1) ... En(qn) m`` with ``Ei(t)`` the rotation by ``t`` about axis ``i``. ``sign[i]`` is -1
where the solvers use the opposite axis direction (the joint's value is then negated).
"""

from __future__ import annotations

from dataclasses import dataclass
from functools import cached_property

import numpy as np
import numpy.typing as npt

from armctl.config.schema import JointType
from armctl.ik.analytic.errors import NoDecompositionError
from armctl.kinematics.model import KinematicModel
from armctl.spatial import transform_inverse
from armctl.typing import Array

__all__ = ["Chain", "chain_of", "screw"]


@dataclass(frozen=True)
class Chain:
    """A revolute chain at its zero configuration.

    Attributes:
        joints: Model joint index of each chain joint, base outwards.
        h: ``(n, 3)`` unit axes in the base frame.
        o: ``(n, 3)`` points on the axes [m].
        m: ``(4, 4)`` tool pose at the zero configuration.
        sign: ``(n,)`` +1, or -1 where ``h`` is the joint's axis reversed.
    """

    joints: tuple[int, ...]
    h: Array
    o: Array
    m: Array
    sign: Array

    @cached_property
    def index(self) -> npt.NDArray[np.int64]:
        """:attr:`joints` as an index array."""
        return np.array(self.joints, dtype=np.int64)

    @property
    def n(self) -> int:
        """Number of joints."""
        return len(self.joints)

    def reversed(self) -> Chain:
        """The inverse chain: tool pose ``inv(T(q))`` as a chain from the tool to the base.

        Joint ``k`` of the result is joint ``n - 1 - k`` of this chain (same value, axis
        reversed and expressed in the tool frame at the zero configuration).
        """
        minv = transform_inverse(self.m)
        r, p = minv[:3, :3], minv[:3, 3]
        h = -(self.h[::-1] @ r.T)
        o = self.o[::-1] @ r.T + p
        return Chain(self.joints[::-1], _ro(h), _ro(o), _ro(minv), _ro(self.sign[::-1].copy()))

    def with_axes(self, h: Array, o: Array, sign: Array) -> Chain:
        """The same chain with idealised axes (exact intersections, exact parallels)."""
        return Chain(self.joints, _ro(np.array(h)), _ro(np.array(o)), self.m, _ro(np.array(sign)))


def _ro(a: Array) -> Array:
    """``a`` as a C-contiguous float64 array (one signature for the numba kernels)."""
    return np.ascontiguousarray(a, dtype=np.float64)


def screw(h: Array, o: Array, t: float) -> Array:
    """The ``(4, 4)`` rigid motion: rotation by ``t`` [rad] about the axis ``h`` through ``o``."""
    k = np.array([[0.0, -h[2], h[1]], [h[2], 0.0, -h[0]], [-h[1], h[0], 0.0]])
    r = np.eye(3) + np.sin(t) * k + (1.0 - np.cos(t)) * (k @ k)
    out = np.eye(4)
    out[:3, :3] = r
    out[:3, 3] = o - r @ o
    return out


def chain_of(model: KinematicModel, frame: str | None = None) -> Chain:
    """The chain of joints that moves ``frame`` (the tool when ``None``).

    Raises:
        NoDecompositionError: If a joint of the chain is prismatic.
    """
    joints = model.chain(frame)
    for j in joints:
        if model.joint_types[j] is JointType.PRISMATIC:
            raise NoDecompositionError(
                f"joint {model.joint_names[j]!r} of arm {model.name!r} is prismatic; the "
                "analytic solvers handle revolute chains only", "use solver 'dls' or 'nlp'")
    tree = model.tree
    world: dict[int, Array] = {}
    h = np.empty((len(joints), 3))
    o = np.empty((len(joints), 3))
    for k, j in enumerate(joints):
        parent = model.parent_joint(j)
        t = np.eye(4) if parent < 0 else world[parent]
        t = t @ tree.joint_origin(j)
        world[j] = t
        h[k] = t[:3, :3] @ tree.joint_axis(j)
        h[k] /= np.linalg.norm(h[k])
        o[k] = t[:3, 3]
    f = model.frame_index(frame)  # the frame at zero: no compiled kernel needed
    anchor = int(tree.anchor[f])
    m = (np.eye(4) if anchor < 0 else world[anchor]) @ tree.frame_offset(f)
    return Chain(tuple(joints), _ro(h), _ro(o), _ro(m), _ro(np.ones(len(joints))))
