"""The compiled kinematic tree: the flat arrays the numba kernels read, with their layout named.

An arm's tree of links and joints (1-DOF, universal, ball) is compiled once, when its
:class:`~armctl.kinematics.model.KinematicModel` is built, into a few read-only NumPy arrays.
Fixed joints are folded into constant transforms, so only the actuated joints and the named
frames (links and extra frames) remain. The compiled kernels (:mod:`armctl.kinematics._kernels`,
the IK engine) take these arrays as plain arguments; Python code gets them from the
:class:`CompiledTree` by name (``model.tree.joints``) and addresses columns with the constants
below, never with bare numbers.

A joint's frame after its motion is ``T_parent @ origin @ M(q)``: ``T_parent`` the frame of its
parent joint after that joint's motion (the identity for the base), ``origin`` the joint's
constant placement, ``M`` a rotation by ``q`` [rad] about the joint axis (revolute, continuous)
or a translation by ``q`` [m] along it (prismatic); for a universal joint a rotation about its
first axis by ``q[k]`` then about its second axis by ``q[k + 1]``; for a ball joint the rotation
of the unit quaternion ``q[k:k + 4]`` (w, x, y, z). A named frame's pose is its anchor joint's
frame times the frame's constant offset.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from armctl.config.schema import ArmSpec, JointType
from armctl.typing import Array

__all__ = [
    "FRAME_COLUMNS", "FRAME_OFFSET", "JOINT_AXIS", "JOINT_AXIS2", "JOINT_COLUMNS", "JOINT_KIND",
    "JOINT_ORIGIN", "JOINT_PRISMATIC", "JOINT_Q", "JOINT_V", "KIND_BALL", "KIND_ONE",
    "KIND_UNIVERSAL", "TRANSLATION", "CompiledTree", "compile_tree",
]

IndexArray = npt.NDArray[np.int64]

#: Columns of a row of :attr:`CompiledTree.joints`.
JOINT_COLUMNS = 22
#: Rows 0-2 of the joint's constant placement ``origin`` (a 4x4 transform), row-major 3x4.
JOINT_ORIGIN = slice(0, 12)
#: The unit joint axis, in the joint's frame.
JOINT_AXIS = slice(12, 15)
#: 1.0 for a prismatic joint, 0.0 for a revolute or continuous one.
JOINT_PRISMATIC = 15
#: The kind of joint: :data:`KIND_ONE`, :data:`KIND_UNIVERSAL` or :data:`KIND_BALL`.
JOINT_KIND = 16
#: A universal joint's second unit axis, in the frame moved by the first (0 for others).
JOINT_AXIS2 = slice(17, 20)
#: The joint's first index in the configuration vector ``q`` (a whole number).
JOINT_Q = 20
#: The joint's first index in a velocity or tangent vector and Jacobian column (whole number).
JOINT_V = 21

#: :data:`JOINT_KIND` of a 1-DOF joint (revolute, continuous, prismatic).
KIND_ONE = 0.0
#: :data:`JOINT_KIND` of a universal joint (2 angles in ``q``, 2 tangent entries).
KIND_UNIVERSAL = 2.0
#: :data:`JOINT_KIND` of a ball joint (a unit quaternion in ``q``, 3 tangent entries).
KIND_BALL = 3.0

#: Columns of a row of :attr:`CompiledTree.frames`.
FRAME_COLUMNS = 12
#: Rows 0-2 of the frame's constant offset from its anchor joint's frame, row-major 3x4.
FRAME_OFFSET = slice(0, 12)

#: The translation entries (x, y, z) [m] of a row-major 3x4 block (:data:`JOINT_ORIGIN`,
#: :data:`FRAME_OFFSET`).
TRANSLATION = [3, 7, 11]


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


def _transform(block: np.ndarray) -> Array:
    out = np.eye(4)
    out[:3, :4] = block.reshape(3, 4)
    return out


@dataclass(frozen=True, eq=False, repr=False)
class CompiledTree:
    """An arm's kinematic tree as the flat arrays the compiled kernels take.

    ``n`` is the number of actuated joints, ordered parents first as in the joint vector ``q``
    (``nq`` entries; a joint's first entry in column :data:`JOINT_Q`) and in tangent vectors and
    Jacobian columns (``nv`` entries, the model's ``dof``; column :data:`JOINT_V`); ``m`` is
    the number of named frames, links first and then the extra
    frames, as in :attr:`frame_names`. Every array is read-only and C-contiguous. Build one with
    :func:`compile_tree`; a model holds its own as ``model.tree``.

    Attributes:
        joint_names: Names of the actuated joints, the row order of :attr:`joints`.
        frame_names: Names of the frames, the row order of :attr:`frames`.
        joints: ``(n, 16)`` float64, per actuated joint: columns :data:`JOINT_ORIGIN` (0-11),
            the constant placement of the joint in its parent joint's frame after that joint's
            motion (the base frame for a root joint), rotation unitless and translation in [m];
            :data:`JOINT_AXIS` (12-14), the unit axis in the joint's own frame;
            :data:`JOINT_PRISMATIC` (15), 1.0 for prismatic, 0.0 for other joints;
            :data:`JOINT_KIND` (16); :data:`JOINT_AXIS2` (17-19); :data:`JOINT_Q` (20),
            :data:`JOINT_V` (21).
        parent: ``(n,)`` int64, the index of each joint's parent actuated joint, -1 for the
            base; a parent's index is lower than its children's.
        frames: ``(m, 12)`` float64, per frame: columns :data:`FRAME_OFFSET` (0-11), its
            constant offset from its anchor joint's frame (translation in [m]).
        anchor: ``(m,)`` int64, the actuated joint whose frame carries each frame, -1 for a
            frame fixed to the base.
        paths: ``(m, max(n, 1))`` int64, per frame the joints from the base to its anchor
            (parents first), padded with -1.
        lower: ``(nq,)`` float64, lower position limits per entry of ``q`` [rad]/[m] (-inf for
            continuous joints and a ball joint's quaternion).
        upper: ``(nq,)`` float64, upper position limits [rad]/[m] (+inf likewise).
        nq: Length of the configuration vector ``q``.
        nv: Length of a tangent vector (Jacobian columns).
        frame_reach: ``(m,)`` float64, per frame an upper bound [m] of its distance from the
            base origin over every configuration inside the limits (see :meth:`reach`).
    """

    joint_names: tuple[str, ...]
    frame_names: tuple[str, ...]
    joints: Array
    parent: IndexArray
    frames: Array
    anchor: IndexArray
    paths: IndexArray
    lower: Array
    upper: Array
    frame_reach: Array
    nq: int = -1
    nv: int = -1

    # ---- one joint or frame as matrices -------------------------------------------------------
    def joint_origin(self, joint: int) -> Array:
        """The constant ``(4, 4)`` placement of a joint in its parent joint's frame [m]."""
        return _transform(self.joints[joint, JOINT_ORIGIN])

    def joint_axis(self, joint: int) -> Array:
        """The unit axis ``(3,)`` of a joint, in its own frame (a copy)."""
        return np.array(self.joints[joint, JOINT_AXIS])

    def is_prismatic(self, joint: int) -> bool:
        """Whether a joint slides (prismatic) rather than turns (revolute, continuous)."""
        return bool(self.joints[joint, JOINT_PRISMATIC] > 0.5)

    def frame_offset(self, frame: int) -> Array:
        """The constant ``(4, 4)`` offset of a frame from its anchor joint's frame [m]."""
        return _transform(self.frames[frame, FRAME_OFFSET])

    def chain(self, frame: int) -> IndexArray:
        """The joints that move a frame, from the base outwards (a copy)."""
        path = self.paths[frame]
        return np.array(path[path >= 0])

    # ---- reach --------------------------------------------------------------------------------
    def reach(self, frame: int, *, from_first_joint: bool = False) -> float:
        """An upper bound of a frame's distance from the base, over every configuration [m].

        The sum of the lengths of the joint placements along the frame's chain, plus the
        frame's offset from its anchor joint, plus the largest travel ``max(|lower|, |upper|)``
        of every prismatic joint of the chain: no configuration inside the limits puts the
        frame farther away. This is the one definition of an arm's reach in armctl.

        Args:
            frame: Frame index (a row of :attr:`frames`).
            from_first_joint: Measure from the origin of the first joint of the frame's chain
                (fixed in the base frame) instead of the base origin: a tighter bound for a
                goal's distance from the arm's "shoulder".

        Returns:
            The bound [m]; for a frame fixed to the base, its constant distance.
        """
        total = float(self.frame_reach[frame])
        first = int(self.paths[frame, 0])
        if from_first_joint and first >= 0:
            total -= float(np.linalg.norm(self.joints[first, TRANSLATION]))
        return max(total, 0.0)

    @property
    def max_reach(self) -> float:
        """The arm's reach: the largest :meth:`reach` of any frame, at least 1 mm [m].

        The length scale of the IK solvers (weights of orientation against position errors).
        """
        return max(float(self.frame_reach.max(initial=0.0)), 1e-3)

    def __repr__(self) -> str:
        return (f"<{type(self).__name__}: {len(self.joint_names)} joints, "
                f"{len(self.frame_names)} frames>")


def compile_tree(spec: ArmSpec) -> CompiledTree:
    """Compile an arm description into a :class:`CompiledTree`.

    Args:
        spec: A validated arm description (joints ordered parents first).

    Returns:
        The compiled tree.
    """
    actuated = spec.actuated_joints
    index = {j.name: i for i, j in enumerate(actuated)}
    n = len(actuated)
    joints = np.zeros((n, JOINT_COLUMNS))
    parent = np.full(n, -1, dtype=np.int64)
    lower_q: list[float] = []
    upper_q: list[float] = []
    nv = 0
    anchor_of: dict[str, tuple[int, np.ndarray]] = {spec.base: (-1, np.eye(4))}
    for j in spec.joints:  # parents first
        a, t = anchor_of[j.parent]
        pre = t @ j.origin.matrix()
        if j.type is JointType.FIXED:
            anchor_of[j.child] = (a, pre)
            continue
        i = index[j.name]
        joints[i, JOINT_ORIGIN] = pre[:3, :4].reshape(12)
        joints[i, JOINT_AXIS] = j.axis
        joints[i, JOINT_PRISMATIC] = 1.0 if j.type is JointType.PRISMATIC else 0.0
        joints[i, JOINT_Q] = len(lower_q)
        joints[i, JOINT_V] = nv
        nv += j.type.nv
        if j.type is JointType.UNIVERSAL:
            joints[i, JOINT_KIND] = KIND_UNIVERSAL
            joints[i, JOINT_AXIS] = j.axes[0]
            joints[i, JOINT_AXIS2] = j.axes[1]
            lower_q += [lim.lower for lim in j.axis_limits]
            upper_q += [lim.upper for lim in j.axis_limits]
        elif j.type is JointType.BALL:
            joints[i, JOINT_KIND] = KIND_BALL
            lower_q += [-np.inf] * 4
            upper_q += [np.inf] * 4
        else:
            lower_q.append(j.limits.lower)
            upper_q.append(j.limits.upper)
        parent[i] = a
        anchor_of[j.child] = (i, np.eye(4))
    names = [lk.name for lk in spec.links]
    offsets = [anchor_of[lk] for lk in names]
    for f in spec.frames:
        a, t = anchor_of[f.parent]
        names.append(f.name)
        offsets.append((a, t @ f.origin.matrix()))
    m = len(names)
    frames = np.zeros((m, FRAME_COLUMNS))
    anchor = np.full(m, -1, dtype=np.int64)
    width = max(n, 1)
    # the joints from the base to each joint, parents first: the parent's row plus the joint
    # (one row copy per joint; parents have lower indices than their children)
    depth = np.zeros(n, dtype=np.int64)
    joint_paths = np.full((n, width), -1, dtype=np.int64)
    for i in range(n):
        p, d = int(parent[i]), 0
        if p >= 0:
            d = int(depth[p])
            joint_paths[i, :d] = joint_paths[p, :d]
        joint_paths[i, d] = i
        depth[i] = d + 1
    paths = np.full((m, width), -1, dtype=np.int64)
    for k, (a, t) in enumerate(offsets):
        frames[k] = t[:3, :4].reshape(12)
        anchor[k] = a
        if a >= 0:
            paths[k] = joint_paths[a]
    lower = np.array(lower_q, dtype=float)
    upper = np.array(upper_q, dtype=float)
    return CompiledTree(
        joint_names=tuple(j.name for j in actuated), frame_names=tuple(names),
        joints=_readonly(joints), parent=_readonly(parent), frames=_readonly(frames),
        anchor=_readonly(anchor), paths=_readonly(paths), lower=_readonly(lower),
        upper=_readonly(upper),
        frame_reach=_readonly(_frame_reach(joints, parent, frames, anchor, lower, upper)),
        nq=len(lower_q), nv=nv)


def _frame_reach(joints: Array, parent: IndexArray, frames: Array, anchor: IndexArray,
                 lower: Array, upper: Array) -> Array:
    """Per frame, the bound of :meth:`CompiledTree.reach` from the base origin [m]."""
    first = joints[:, JOINT_Q].astype(np.int64)  # a prismatic joint's entry of q
    travel = np.maximum(np.abs(lower[first]), np.abs(upper[first])) if len(joints) else first
    prismatic = joints[:, JOINT_PRISMATIC] > 0.5
    # a prismatic joint's limits bound its travel (the config requires them); none count as 0
    step = (np.linalg.norm(joints[:, TRANSLATION], axis=1)
            + np.where(prismatic & np.isfinite(travel), travel, 0.0))
    upto = np.zeros(len(joints))  # joints parents first: each adds its step to its parent's
    for i in range(len(joints)):
        p = int(parent[i])
        upto[i] = step[i] + (upto[p] if p >= 0 else 0.0)
    carried = np.where(anchor >= 0, upto[np.maximum(anchor, 0)] if len(joints) else 0.0, 0.0)
    return np.asarray(carried + np.linalg.norm(frames[:, TRANSLATION], axis=1), dtype=float)
