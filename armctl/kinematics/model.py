"""The compiled kinematic tree: forward kinematics and geometric Jacobians of any named frame.

Joints are 1-DOF (revolute, continuous, prismatic), universal (2 angles) or ball (a unit
quaternion): the joint vector ``q`` has :attr:`KinematicModel.nq` entries, a velocity or tangent
vector (and a Jacobian) :attr:`KinematicModel.nv` (== ``dof``). :meth:`KinematicModel.integrate`,
:meth:`~KinematicModel.difference` and :meth:`~KinematicModel.interpolate` move between the two.
"""

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
from armctl.kinematics import joint_space as js
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
    """A tree of links and joints (1-DOF, universal, ball), compiled for fast FK and Jacobians.

    Fixed joints are folded into constant transforms. The joint vector ``q`` lists the actuated
    joints parents-first (the order of :attr:`joint_names`), in [rad] for revolute and continuous
    joints, [m] for prismatic joints, two angles [rad] for a universal joint and a unit
    quaternion ``(w, x, y, z)`` for a ball joint: :attr:`nq` entries, a joint's entries at
    :meth:`q_index`. Velocities, IK steps and Jacobian columns live in the tangent space of
    :attr:`nv` (== :attr:`dof`) entries, a joint's at :meth:`v_index`; a ball joint's three are
    its angular velocity in its own moved frame [rad/s]. For an arm of 1-DOF joints only
    ``nq == nv == dof`` and both spaces are the same. Poses are ``(4, 4)`` transforms in the
    base frame. The
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
        self.joint_names: tuple[str, ...] = tuple(j.name for j in joints)
        self.joint_types: tuple[JointType, ...] = tuple(j.type for j in joints)
        self.joint_roles: tuple[JointRole, ...] = tuple(j.role for j in joints)
        #: The compiled tree: the arrays the kernels take (their layout is documented there).
        self.tree: CompiledTree = compile_tree(spec)
        #: Length of the configuration vector ``q``.
        self.nq: int = self.tree.nq
        #: Length of a velocity or tangent vector: the degrees of freedom, Jacobian columns.
        self.nv: int = self.tree.nv
        #: The degrees of freedom (== :attr:`nv`); the length of ``q`` is :attr:`nq`.
        self.dof: int = self.nv
        #: Names of the universal and ball joints (empty for an arm of 1-DOF joints).
        self.multi_dof_joints: tuple[str, ...] = tuple(
            j.name for j in joints if j.type in (JointType.UNIVERSAL, JointType.BALL))
        self._q_slices: tuple[slice, ...] = ()
        self._v_slices: tuple[slice, ...] = ()
        qa = va = 0
        for j in joints:
            self._q_slices += (slice(qa, qa + j.type.nq),)
            self._v_slices += (slice(va, va + j.type.nv),)
            qa, va = qa + j.type.nq, va + j.type.nv
        #: The entries of 1-DOF and universal joints in q and in a tangent (same order).
        self._scalar_q = np.array([i for sl in self._q_slices if sl.stop - sl.start != 4
                                   for i in range(sl.start, sl.stop)], dtype=np.intp)
        self._scalar_v = np.array([i for ql, sl in zip(self._q_slices, self._v_slices,
                                                       strict=True) if ql.stop - ql.start != 4
                                   for i in range(sl.start, sl.stop)], dtype=np.intp)
        #: The ball joints: (name, q slice, twist axis, swing limit, twist lower, twist upper).
        self._balls: tuple[js.BallJoint, ...] = tuple(
            js.BallJoint(j.name, self._q_slices[i], self._v_slices[i], np.array(j.axis),
                         j.swing, j.limits.lower, j.limits.upper)
            for i, j in enumerate(joints) if j.type is JointType.BALL)
        #: Lower position limits per entry of ``q`` [rad]/[m] (-inf for continuous joints and
        #: ball joints, whose cone and twist limits :meth:`within_limits` checks).
        self.lower: Array = self.tree.lower
        #: Upper position limits per entry of ``q`` [rad]/[m] (+inf likewise).
        self.upper: Array = self.tree.upper
        self._lower: list[float] = self.lower.tolist()
        self._upper: list[float] = self.upper.tolist()
        nan = float("nan")

        def arr(key: str) -> Array:
            vals: list[float | None] = []
            for j in joints:
                if j.type is JointType.UNIVERSAL:
                    vals += [getattr(lim, key) for lim in j.axis_limits]
                else:
                    vals += [getattr(j.limits, key)] * j.type.nv
            return _readonly(np.array([nan if v is None else v for v in vals], dtype=float))

        #: Velocity limits [rad/s] or [m/s] per tangent entry (:attr:`nv`); NaN where unknown.
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

    def q_index(self, joint: str | int) -> slice:
        """A joint's entries in the configuration vector ``q`` (by name or joint index).

        One entry for a 1-DOF joint, two for a universal joint, four (a quaternion ``w, x, y,
        z``) for a ball joint.

        Raises:
            UnknownNameError: If there is no such actuated joint.
        """
        return self._q_slices[joint if isinstance(joint, int) else self.joint_index(joint)]

    def v_index(self, joint: str | int) -> slice:
        """A joint's entries in a velocity or tangent vector and its Jacobian columns.

        One entry for a 1-DOF joint, two for a universal joint, three for a ball joint.

        Raises:
            UnknownNameError: If there is no such actuated joint.
        """
        return self._v_slices[joint if isinstance(joint, int) else self.joint_index(joint)]

    def require_one_dof(self, purpose: str) -> None:
        """Refuse an arm with universal or ball joints for what supports only 1-DOF joints.

        Args:
            purpose: What needs 1-DOF joints, e.g. ``"the servo mapping"``.

        Raises:
            InputError: Naming the multi-DOF joints.
        """
        if self.multi_dof_joints:
            kinds = ", ".join(f"{n!r} ({self.joint_types[self.joint_index(n)].value})"
                              for n in self.multi_dof_joints)
            raise InputError(f"{purpose} supports 1-DOF joints only; arm {self.name!r} has "
                             f"the multi-DOF joint(s) {kinds}. Use an arm of revolute, "
                             "continuous and prismatic joints for this, or the numerical "
                             "kinematics (fk, jacobian) that support them.")

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
    def _q_layout(self) -> str:
        parts = []
        for name, jtype in zip(self.joint_names, self.joint_types, strict=True):
            if jtype is JointType.BALL:
                parts.append(f"{name}: 4 (quaternion w, x, y, z)")
            elif jtype is JointType.UNIVERSAL:
                parts.append(f"{name}: 2")
            else:
                parts.append(name)
        return ", ".join(parts)

    def as_q(self, q: npt.ArrayLike, what: str = "q") -> Array:
        """``q`` as a float vector of length :attr:`nq`.

        Raises:
            InputError: For a wrong length, non-finite values, or a ball joint's quaternion
                that is not of unit norm (within 1e-6; naming the joint).
        """
        arr = np.asarray(q, dtype=np.float64)
        if arr.shape != (self.nq,):
            raise InputError(f"{what} must have {self.nq} values ({self._q_layout()})"
                             f" for arm {self.name!r}; got shape {arr.shape}")
        if not _finite(arr.tolist()):
            raise InputError(f"{what} contains a NaN or infinite value: {arr.tolist()}")
        if self._balls:
            js.check_unit(arr, self._balls, what)
        return arr

    def _fast_q(self, q: npt.ArrayLike) -> Array:
        """``q`` for pure computations: a float vector of length :attr:`nq` (NaN passes)."""
        if type(q) is np.ndarray and q.dtype == np.float64 and q.shape == (self.nq,):
            return q
        arr = np.asarray(q, dtype=np.float64)
        if arr.shape != (self.nq,):
            return self.as_q(arr)  # raises with a clear message
        return arr

    def as_batch(self, qs: npt.ArrayLike, what: str = "qs") -> Array:
        """``qs`` as a C-contiguous float array of shape ``(N, nq)``."""
        arr = np.ascontiguousarray(qs, dtype=np.float64)
        if arr.ndim != 2 or arr.shape[1] != self.nq:
            raise InputError(f"{what} must have shape (N, {self.nq}) for arm {self.name!r}; "
                             f"got {arr.shape}")
        return arr

    def within_limits(self, q: npt.ArrayLike, tol: float = 1e-9) -> bool:
        """Whether every joint value lies inside its position limits (with tolerance ``tol``).

        A ball joint is inside when its twist axis lies inside its swing cone and its twist
        inside its twist range.
        """
        arr = self.as_q(q)
        # plain floats: for a few joints several times faster than NumPy's comparisons
        inside = all([lo - tol <= v <= hi + tol for v, lo, hi in
                      zip(arr.tolist(), self._lower, self._upper, strict=True)])
        if inside and self._balls:
            return all(js.ball_violation(arr[b.q], b, tol) is None for b in self._balls)
        return inside

    def check_limits(self, q: npt.ArrayLike, context: str = "", tol: float = 1e-9) -> Array:
        """Return ``q`` if it is inside the limits, else raise for the first offending joint.

        Raises:
            JointLimitError: Naming the joint, the value and its limits (for a ball joint its
                swing or twist angle).
        """
        arr = self.as_q(q)
        bad = np.flatnonzero((arr < self.lower - tol) | (arr > self.upper + tol))
        if bad.size:
            i = int(bad[0])
            j = self._joint_of_q(i)
            if self.joint_types[j] is JointType.UNIVERSAL:
                k = i - self._q_slices[j].start + 1
                context = f"angle {k} of the universal joint{'; ' + context if context else ''}"
            raise JointLimitError(self.joint_names[j], float(arr[i]), float(self.lower[i]),
                                  float(self.upper[i]), context)
        for b in self._balls:
            found = js.ball_violation(arr[b.q], b, tol)
            if found is not None:
                what, value, lo, hi = found
                key = "swing" if what.startswith("swing") else "twist"
                degrees = (f"{what}: {math.degrees(value):.4f} deg against "
                           f"[{math.degrees(lo):.4f}, {math.degrees(hi):.4f}] deg")
                raise JointLimitError(
                    b.name, value, lo, hi, f"{degrees}{'; ' + context if context else ''}",
                    advice=f"Choose a rotation inside the limits, or widen limits.{key} of "
                           f"joint {b.name!r} in the arm config.")
        return arr

    def _joint_of_q(self, i: int) -> int:
        """The joint whose entries of ``q`` include entry ``i``."""
        if self.nq == len(self.joint_names):
            return i
        return next(j for j, sl in enumerate(self._q_slices) if sl.start <= i < sl.stop)

    def clip(self, q: npt.ArrayLike) -> Array:
        """``q`` clipped into the position limits.

        A ball joint is projected into its cone and twist range: the twist clamped, then the
        swing shortened toward the cone's centre.
        """
        out = np.maximum(self.as_q(q), self.lower)  # np.clip, without its wrapper's cost
        np.minimum(out, self.upper, out=out)
        for b in self._balls:
            out[b.q] = js.project_ball(out[b.q], b)
        return out

    # ---- the configuration space ---------------------------------------------------------------
    def neutral(self) -> Array:
        """The rest configuration (the same as :meth:`middle`).

        The middle of every 1-DOF range (0 for continuous joints), of each angle of a
        universal joint, and the identity quaternion for a ball joint.
        """
        return self.middle()

    def normalize(self, q: npt.ArrayLike) -> Array:
        """``q`` with every ball joint's quaternion scaled to unit norm (``w >= 0``).

        Raises:
            InputError: For a wrong length, non-finite values or a zero quaternion.
        """
        arr = np.array(q, dtype=np.float64)
        if arr.shape != (self.nq,) or not _finite(arr.tolist()):
            return self.as_q(arr)  # raises
        for b in self._balls:
            quat = arr[b.q]
            n = float(np.linalg.norm(quat))
            if n < 1e-12:
                raise InputError(f"ball joint {b.name!r}: its quaternion is zero")
            arr[b.q] = quat / n if quat[0] >= 0 else -quat / n
        return arr

    def integrate(self, q: npt.ArrayLike, v: npt.ArrayLike) -> Array:
        """The configuration reached from ``q`` by the tangent step ``v``.

        1-DOF and universal entries add; a ball joint's quaternion becomes
        ``q ⊗ exp(v / 2)`` (``v`` its rotation vector in its own moved frame [rad]), normalised.

        Args:
            q: Configuration ``(nq,)``.
            v: Tangent step ``(nv,)`` [rad]/[m].

        Returns:
            The new configuration ``(nq,)``.
        """
        arr = self._fast_q(q)
        step = np.asarray(v, dtype=np.float64)
        if step.shape != (self.nv,):
            raise InputError(f"a tangent step must have {self.nv} values for arm "
                             f"{self.name!r}; got shape {step.shape}")
        if not self._balls:
            return arr + step
        return js.integrate(arr, step, self._scalar_q, self._scalar_v, self._balls)

    def difference(self, q0: npt.ArrayLike, q1: npt.ArrayLike) -> Array:
        """The tangent step ``v`` with ``integrate(q0, v) == q1`` (shortest arc for a ball).

        Args:
            q0: Start configuration ``(nq,)``.
            q1: End configuration ``(nq,)``.

        Returns:
            ``(nv,)`` [rad]/[m].
        """
        a, b = self._fast_q(q0), self._fast_q(q1)
        if not self._balls:
            return np.asarray(b - a, dtype=float)
        return js.difference(a, b, self._scalar_q, self._scalar_v, self.nv, self._balls)

    def interpolate(self, q0: npt.ArrayLike, q1: npt.ArrayLike, s: float) -> Array:
        """The configuration a fraction ``s`` of the way from ``q0`` to ``q1``.

        Linear for 1-DOF and universal joints, slerp (the shortest arc) for ball joints:
        ``integrate(q0, s * difference(q0, q1))``.

        Args:
            q0: Start configuration ``(nq,)``.
            q1: End configuration ``(nq,)``.
            s: Fraction, 0 gives ``q0`` and 1 gives ``q1``.
        """
        a, b = self._fast_q(q0), self._fast_q(q1)
        if not self._balls:
            return np.asarray(a + s * (b - a), dtype=float)
        return self.integrate(a, s * self.difference(a, b))

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
        for i in range(self.nq):
            jtype = self.joint_types[self._joint_of_q(i)]
            if jtype in (JointType.PRISMATIC, JointType.BALL):
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

        A ball joint's rotation is uniform (Haar) over the rotations inside its limits: the
        direction of its twist axis uniform over the cone's spherical cap, the twist uniform in
        its range.

        Args:
            rng: The random generator.
            n: How many; ``None`` gives one ``(nq,)`` vector, else ``(n, nq)``.
        """
        lo = np.where(np.isfinite(self.lower), self.lower, -np.pi)
        hi = np.where(np.isfinite(self.upper), self.upper, np.pi)
        shape = (self.nq,) if n is None else (n, self.nq)
        out = rng.uniform(lo, hi, size=shape)
        for b in self._balls:
            out[..., b.q] = js.sample_ball(rng, b, 1 if n is None else n).reshape(
                out[..., b.q].shape)
        return out

    def middle(self) -> Array:
        """The middle of every joint's range.

        0 for continuous joints; the identity quaternion for a ball joint.
        """
        lo = np.where(np.isfinite(self.lower), self.lower, 0.0)
        hi = np.where(np.isfinite(self.upper), self.upper, 0.0)
        out = (lo + hi) / 2.0
        for b in self._balls:
            out[b.q] = (1.0, 0.0, 0.0, 0.0)
        return out

    # ---- kinematics ---------------------------------------------------------------------------
    def fk(self, q: npt.ArrayLike, frame: str | None = None) -> Array:
        """Pose of a frame.

        Args:
            q: Joint vector ``(nq,)`` in [rad] / [m] (quaternions for ball joints).
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
            qs: Joint vectors ``(N, nq)``.
            frame: Frame name; the tool frame when ``None``.

        Returns:
            ``(N, 4, 4)`` poses.
        """
        t = self.tree
        return K.fk_batch(self.as_batch(qs), t.joints, t.frames, t.paths, self.frame_index(frame))

    def fk_all(self, q: npt.ArrayLike) -> dict[str, Array]:
        """Poses of every named frame (links and extra frames) at once.

        Args:
            q: Joint vector ``(nq,)``.

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
        a universal joint has the columns of its two axes, a ball joint three, ``w_k`` the
        axes of its moved frame (its tangent is the angular velocity in that frame, see
        :meth:`integrate`); joints that do not move the frame have zero columns.

        Args:
            q: Joint vector ``(nq,)``.
            frame: Frame name; the tool frame when ``None``.

        Returns:
            ``(6, nv)`` matrix, rows ``[linear [m/rad]; angular [rad/rad]]``.
        """
        k = self.frame_index(frame)
        rows, idx = self._chains[k] or self._chain_of(k)
        return K.chain_jacobian(self._fast_q(q), rows, idx, self.nv)

    def jacobian_batch(self, qs: npt.ArrayLike, frame: str | None = None) -> Array:
        """Geometric Jacobians ``(N, 6, nv)`` for many joint vectors ``(N, nq)``."""
        t = self.tree
        return K.jacobian_batch(self.as_batch(qs), t.joints, t.frames, t.paths,
                                self.frame_index(frame))

    def fk_jacobian(self, q: npt.ArrayLike, frame: str | None = None) -> tuple[Array, Array]:
        """Pose ``(4, 4)`` and Jacobian ``(6, nv)`` of a frame in one pass."""
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
        if not self.multi_dof_joints:
            return np.array([poses[name][j] for j in self.joint_names])
        return np.concatenate([np.atleast_1d(np.asarray(poses[name][j], dtype=float))
                               for j in self.joint_names])

    def joint_values(self, q: npt.ArrayLike) -> dict[str, float | list[float]]:
        """A joint vector as ``{joint name: value}``, for any arm.

        A number for a 1-DOF joint, a list for a universal joint (2 angles [rad]) or a ball
        joint (its quaternion ``w, x, y, z``).
        """
        arr = self.as_q(q)
        return {name: (float(arr[sl.start]) if sl.stop - sl.start == 1 else arr[sl].tolist())
                for name, sl in zip(self.joint_names, self._q_slices, strict=True)}

    def values_by_name(self, values: Sequence[float] | npt.ArrayLike) -> dict[str, float]:
        """A joint vector as a ``{joint name: value}`` mapping (1-DOF joints only).

        Raises:
            InputError: For an arm with universal or ball joints.
        """
        self.require_one_dof("a joint-name-to-value mapping")
        arr = self.as_q(values)
        return {name: float(v) for name, v in zip(self.joint_names, arr, strict=True)}

    def __repr__(self) -> str:
        return f"<{type(self).__name__} {self.name!r}: {self.dof} DOF, tool {self.tool!r}>"
