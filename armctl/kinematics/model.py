"""The compiled kinematic tree: forward kinematics and geometric Jacobians of any named frame."""

from __future__ import annotations

import math
import sys
from collections.abc import Sequence
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np
import numpy.typing as npt

from armctl.config.schema import ArmSpec, JointRole, JointType
from armctl.config.tree import check_arm_size
from armctl.errors import InputError, JointLimitError, KeyPath, UnknownNameError
from armctl.kinematics.compiled_tree import (
    FRAME_OFFSET,
    JOINT_COLUMNS,
    JOINT_ORIGIN,
    CompiledTree,
    compile_tree,
)
from armctl.typing import Array

if TYPE_CHECKING:
    from armctl.kinematics import _kernels as K

__all__ = ["KinematicModel"]


#: Kernels that a single pose needs: interpreted while numba is not loaded (see _Kernels).
_SINGLE = frozenset({"chain_fk", "chain_jacobian", "chain_fk_jacobian_into", "fk_all"})
#: Single-pose calls run interpreted before the compiled kernels take over: some 0.1 s in all,
#: a fraction of what loading the compiled kernels costs, so a long process loses little.
_INTERPRETED_CALLS = 1000


class _Kernels(ModuleType):
    """Stands for :mod:`armctl.kinematics._kernels` until the compiled kernels are worth loading.

    Loading numba and its compiled kernels takes about half a second. A process that computes
    a few poses (``armctl fk``, ``armctl info``) is done sooner with the kernels' own code run
    by the interpreter (the same operations, the same results; some 0.1 ms a pose). So the
    first single-pose calls run interpreted while numba is not imported; a batch, the
    ``_INTERPRETED_CALLS``-th call, or any call once something else has imported numba (the
    IK solvers do) puts the compiled module in this object's place for good.
    """

    calls = 0

    def __getattr__(self, name: str) -> Any:
        global K
        from armctl.kinematics import _kernels

        if name in _SINGLE and self.calls < _INTERPRETED_CALLS and "numba" not in sys.modules:
            self.calls += 1
            return _kernels.interpreted(name)
        K = _kernels
        return getattr(_kernels, name)


if not TYPE_CHECKING:
    K = _Kernels("armctl.kinematics._kernels (not imported yet)")


def _finite(values: list[float]) -> bool:
    """Whether every number is finite (one sum; each number only when the sum is not finite)."""
    return math.isfinite(sum(values)) or all(math.isfinite(v) for v in values)


def _readonly(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


class KinematicModel:
    """A tree of links and 1-DOF joints, compiled for fast FK and Jacobians.

    Fixed joints are folded into constant transforms. The joint vector ``q`` lists the actuated
    joints parents-first (the order of :attr:`joint_names`), in [rad] for revolute and continuous
    joints and [m] for prismatic joints. Poses are ``(4, 4)`` transforms in the base frame. The
    compiled arrays the kernels take are public as :attr:`tree`
    (:class:`~armctl.kinematics.compiled_tree.CompiledTree`).

    Args:
        spec: A validated arm description.

    Raises:
        ConfigError: If the arm has more joints or frames than armctl supports
            (:data:`armctl.config.tree.MAX_JOINTS`, :data:`armctl.config.tree.MAX_FRAMES`).
    """

    def __init__(self, spec: ArmSpec):
        check_arm_size(len(spec.joints), len(spec.frames), KeyPath(spec.file))
        self.spec = spec
        joints = spec.actuated_joints
        self.name: str = spec.name
        self.dof: int = len(joints)
        self.joint_names: tuple[str, ...] = tuple(j.name for j in joints)
        self.joint_types: tuple[JointType, ...] = tuple(j.type for j in joints)
        self.joint_roles: tuple[JointRole, ...] = tuple(j.role for j in joints)
        #: The compiled tree: the arrays the kernels take (their layout is documented there).
        self.tree: CompiledTree = compile_tree(spec)
        #: Lower position limits [rad]/[m] (-inf for continuous joints).
        self.lower: Array = self.tree.lower
        #: Upper position limits [rad]/[m] (+inf for continuous joints).
        self.upper: Array = self.tree.upper
        self._lower: list[float] = self.lower.tolist()
        self._upper: list[float] = self.upper.tolist()
        nan = float("nan")

        def arr(key: str) -> Array:
            vals = [getattr(j.limits, key) for j in joints]
            return _readonly(np.array([nan if v is None else v for v in vals], dtype=float))

        #: Velocity limits [rad/s] or [m/s]; NaN where unknown.
        self.velocity_limits: Array = arr("velocity")
        #: Acceleration limits [rad/s^2] or [m/s^2]; NaN where unknown.
        self.acceleration_limits: Array = arr("acceleration")
        #: Jerk limits [rad/s^3] or [m/s^3]; NaN where unknown.
        self.jerk_limits: Array = arr("jerk")
        self.tool: str = spec.tool
        self.end_effectors: tuple[str, ...] = spec.end_effectors
        self._joint_index = {name: i for i, name in enumerate(self.joint_names)}
        #: Links first, then the extra frames: the row order of ``tree.frames``.
        self.frame_names: tuple[str, ...] = self.tree.frame_names
        self._frame_index = {name: i for i, name in enumerate(self.frame_names)}
        self._tool_index = self._frame_index[spec.tool]
        #: Per frame, the compact rows the single-frame kernels read, built on first use: built
        #: for every frame at once they would take memory quadratic in the length of a chain.
        self._chains: list[tuple[np.ndarray, np.ndarray] | None] = [None] * len(self.frame_names)

    # ---- single-frame chains ------------------------------------------------------------------
    def _chain_of(self, k: int) -> tuple[np.ndarray, np.ndarray]:
        """The kernel rows and joint indices of frame ``k``'s chain (cached)."""
        found = self._chains[k]
        if found is None:
            tree = self.tree
            idx = tree.chain(k)
            rows = np.zeros((idx.size + 1, JOINT_COLUMNS))
            rows[: idx.size] = tree.joints[idx]
            rows[idx.size, JOINT_ORIGIN] = tree.frames[k, FRAME_OFFSET]
            found = self._chains[k] = (_readonly(rows), _readonly(idx))
        return found

    # ---- lookups ------------------------------------------------------------------------------
    def frame_index(self, frame: str | None) -> int:
        """Index of a named frame (``None``: the tool frame).

        Raises:
            UnknownNameError: If there is no such frame.
        """
        if frame is None:
            return self._tool_index
        try:
            return self._frame_index[frame]
        except KeyError:
            raise UnknownNameError("frame", frame, self.frame_names, f"arm {self.name!r}") from None

    def joint_index(self, joint: str) -> int:
        """Index of an actuated joint in the joint vector.

        Raises:
            UnknownNameError: If there is no such actuated joint.
        """
        try:
            return self._joint_index[joint]
        except KeyError:
            raise UnknownNameError("joint", joint, self.joint_names, f"arm {self.name!r}") from None

    def chain(self, frame: str | None = None) -> tuple[int, ...]:
        """Indices of the joints that move a frame, from the base outwards."""
        path = self.tree.paths[self.frame_index(frame)]
        return tuple(int(j) for j in path if j >= 0)

    def parent_joint(self, joint: int) -> int:
        """Index of the actuated joint that carries ``joint``, -1 for the base."""
        return int(self.tree.parent[joint])

    def reach(self, frame: str | None = None, *, from_first_joint: bool = False) -> float:
        """An upper bound of a frame's distance from the base over every configuration [m].

        Args:
            frame: Frame name; the tool frame when ``None``.
            from_first_joint: Measure from the origin of the first joint of the frame's chain
                instead of the base origin (see :meth:`CompiledTree.reach`).

        Raises:
            UnknownNameError: If there is no such frame.
        """
        return self.tree.reach(self.frame_index(frame), from_first_joint=from_first_joint)

    # ---- checks -------------------------------------------------------------------------------
    def as_q(self, q: npt.ArrayLike, what: str = "q") -> Array:
        """``q`` as a float vector of length :attr:`dof`.

        Raises:
            InputError: For a wrong length or non-finite values.
        """
        arr = np.asarray(q, dtype=np.float64)
        if arr.shape != (self.dof,):
            raise InputError(f"{what} must have {self.dof} values ({', '.join(self.joint_names)})"
                             f" for arm {self.name!r}; got shape {arr.shape}")
        if not _finite(arr.tolist()):
            raise InputError(f"{what} contains a NaN or infinite value: {arr.tolist()}")
        return arr

    def _fast_q(self, q: npt.ArrayLike) -> Array:
        """``q`` for pure computations: a float vector of length :attr:`dof` (NaN passes)."""
        if type(q) is np.ndarray and q.dtype == np.float64 and q.shape == (self.dof,):
            return q
        arr = np.asarray(q, dtype=np.float64)
        if arr.shape != (self.dof,):
            return self.as_q(arr)  # raises with a clear message
        return arr

    def as_batch(self, qs: npt.ArrayLike, what: str = "qs") -> Array:
        """``qs`` as a C-contiguous float array of shape ``(N, dof)``."""
        arr = np.ascontiguousarray(qs, dtype=np.float64)
        if arr.ndim != 2 or arr.shape[1] != self.dof:
            raise InputError(f"{what} must have shape (N, {self.dof}) for arm {self.name!r}; "
                             f"got {arr.shape}")
        return arr

    def within_limits(self, q: npt.ArrayLike, tol: float = 1e-9) -> bool:
        """Whether every joint value lies inside its position limits (with tolerance ``tol``)."""
        # plain floats: for a few joints several times faster than NumPy's comparisons
        return all([lo - tol <= v <= hi + tol for v, lo, hi in
                    zip(self.as_q(q).tolist(), self._lower, self._upper, strict=True)])

    def check_limits(self, q: npt.ArrayLike, context: str = "", tol: float = 1e-9) -> Array:
        """Return ``q`` if it is inside the limits, else raise for the first offending joint.

        Raises:
            JointLimitError: Naming the joint, the value and its limits.
        """
        arr = self.as_q(q)
        bad = np.flatnonzero((arr < self.lower - tol) | (arr > self.upper + tol))
        if bad.size:
            i = int(bad[0])
            raise JointLimitError(self.joint_names[i], float(arr[i]), float(self.lower[i]),
                                  float(self.upper[i]), context)
        return arr

    def clip(self, q: npt.ArrayLike) -> Array:
        """``q`` clipped into the position limits."""
        out = np.maximum(self.as_q(q), self.lower)  # np.clip, without its wrapper's cost
        np.minimum(out, self.upper, out=out)
        return out

    def wrap_toward(self, q: npt.ArrayLike, q_ref: npt.ArrayLike) -> Array:
        """``q`` with rotary joints shifted by whole turns toward ``q_ref``, inside the limits.

        Every frame keeps its pose (a revolute joint is 2 pi periodic); prismatic joints and
        joints with no equivalent value closer to ``q_ref`` inside their limits are unchanged.

        Args:
            q: Joint vector ``(dof,)`` [rad]/[m].
            q_ref: Reference joint vector ``(dof,)``.

        Returns:
            The shifted joint vector.
        """
        out = np.array(self.as_q(q))
        ref = self.as_q(q_ref, "q_ref")
        turn = 2.0 * np.pi
        for i, jtype in enumerate(self.joint_types):
            if jtype is JointType.PRISMATIC:
                continue
            k = np.round((ref[i] - out[i]) / turn)
            cands = out[i] + turn * (k + np.arange(-1.0, 2.0))
            cands = cands[(cands >= self.lower[i] - 1e-12) & (cands <= self.upper[i] + 1e-12)]
            if cands.size:
                best = cands[np.argmin(np.abs(cands - ref[i]))]
                if abs(best - ref[i]) < abs(out[i] - ref[i]):
                    out[i] = best
        return out

    def sample(self, rng: np.random.Generator, n: int | None = None) -> Array:
        """Uniform random configurations inside the limits (continuous joints in [-pi, pi]).

        Args:
            rng: The random generator.
            n: How many; ``None`` gives one ``(dof,)`` vector, else ``(n, dof)``.
        """
        lo = np.where(np.isfinite(self.lower), self.lower, -np.pi)
        hi = np.where(np.isfinite(self.upper), self.upper, np.pi)
        shape = (self.dof,) if n is None else (n, self.dof)
        return rng.uniform(lo, hi, size=shape)

    def middle(self) -> Array:
        """The middle of every joint's range (0 for continuous joints)."""
        lo = np.where(np.isfinite(self.lower), self.lower, 0.0)
        hi = np.where(np.isfinite(self.upper), self.upper, 0.0)
        return (lo + hi) / 2.0

    # ---- kinematics ---------------------------------------------------------------------------
    def fk(self, q: npt.ArrayLike, frame: str | None = None) -> Array:
        """Pose of a frame.

        Args:
            q: Joint vector ``(dof,)`` in [rad] / [m].
            frame: Frame name; the tool frame when ``None``.

        Returns:
            ``(4, 4)`` pose of the frame in the base frame (translation in [m]). A NaN in ``q``
            gives NaN entries (nothing is commanded from here; commands check their input).
        """
        k = self.frame_index(frame)
        rows, idx = self._chains[k] or self._chain_of(k)
        return K.chain_fk(self._fast_q(q), rows, idx)

    def fk_batch(self, qs: npt.ArrayLike, frame: str | None = None) -> Array:
        """Poses of a frame for many joint vectors.

        Args:
            qs: Joint vectors ``(N, dof)``.
            frame: Frame name; the tool frame when ``None``.

        Returns:
            ``(N, 4, 4)`` poses.
        """
        t = self.tree
        return K.fk_batch(self.as_batch(qs), t.joints, t.frames, t.paths, self.frame_index(frame))

    def fk_all(self, q: npt.ArrayLike) -> dict[str, Array]:
        """Poses of every named frame (links and extra frames) at once.

        Args:
            q: Joint vector ``(dof,)``.

        Returns:
            Frame name -> ``(4, 4)`` pose.
        """
        poses = self.fk_frames(q)
        return {name: poses[i] for i, name in enumerate(self.frame_names)}

    def fk_frames(self, q: npt.ArrayLike) -> Array:
        """Poses ``(m, 4, 4)`` of every frame, in the order of :attr:`frame_names`."""
        t = self.tree
        return K.fk_all(self.as_q(q), t.joints, t.parent, t.anchor, t.frames)

    def jacobian(self, q: npt.ArrayLike, frame: str | None = None) -> Array:
        """Geometric Jacobian of a frame's origin, in the base frame.

        Column ``i`` is ``[w_i x (p - o_i); w_i]`` for a revolute joint and ``[w_i; 0]`` for a
        prismatic one (``w_i`` the joint axis, ``o_i`` a point on it, ``p`` the frame origin);
        joints that do not move the frame have zero columns.

        Args:
            q: Joint vector ``(dof,)``.
            frame: Frame name; the tool frame when ``None``.

        Returns:
            ``(6, dof)`` matrix, rows ``[linear [m/rad]; angular [rad/rad]]``.
        """
        k = self.frame_index(frame)
        rows, idx = self._chains[k] or self._chain_of(k)
        return K.chain_jacobian(self._fast_q(q), rows, idx)

    def jacobian_batch(self, qs: npt.ArrayLike, frame: str | None = None) -> Array:
        """Geometric Jacobians ``(N, 6, dof)`` for many joint vectors ``(N, dof)``."""
        t = self.tree
        return K.jacobian_batch(self.as_batch(qs), t.joints, t.frames, t.paths,
                                self.frame_index(frame))

    def fk_jacobian(self, q: npt.ArrayLike, frame: str | None = None) -> tuple[Array, Array]:
        """Pose ``(4, 4)`` and Jacobian ``(6, dof)`` of a frame in one pass."""
        k = self.frame_index(frame)
        rows, idx = self._chains[k] or self._chain_of(k)
        pose = np.empty((4, 4))
        jac = np.empty((6, self.dof))
        K.chain_fk_jacobian_into(self._fast_q(q), rows, idx, pose, jac)
        return pose, jac

    def named_pose(self, name: str) -> Array:
        """The joint vector of a named pose from the config (``home``, ``park``, ...)."""
        poses = self.spec.poses
        if name not in poses:
            raise UnknownNameError("pose", name, list(poses), f"arm {self.name!r}")
        return np.array([poses[name][j] for j in self.joint_names])

    def values_by_name(self, values: Sequence[float] | npt.ArrayLike) -> dict[str, float]:
        """A joint vector as a ``{joint name: value}`` mapping."""
        arr = self.as_q(values)
        return {name: float(v) for name, v in zip(self.joint_names, arr, strict=True)}

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r}: {self.dof} DOF, tool {self.tool!r}>"
