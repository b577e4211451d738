"""The arm description as immutable data: links, joints, frames, geometry, named poses.

This is what an arm YAML file or a URDF becomes after validation (see ``docs/config.md``). It is
pure data: the compiled kinematic tree that computes poses lives in :mod:`armctl.kinematics`.
Denavit-Hartenberg parameters of the YAML format are already turned into joint origins here;
universal (2-DOF) and ball (3-DOF) joints are joints of their own (:class:`JointType`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from enum import Enum
from pathlib import Path
from typing import TYPE_CHECKING

from armctl.config.geometry import Box, Capsule, Cylinder, Geometry, Mesh, Origin, Sphere
from armctl.errors import KeyPath

if TYPE_CHECKING:
    from armctl.config.bus import BusSpec
    from armctl.config.motion import MotionSpec
    from armctl.config.scene import CollisionSpec, SceneSpec
    from armctl.config.skin import SkinSpec

__all__ = [
    "ArmSpec",
    "Box",
    "Capsule",
    "Cylinder",
    "FrameSpec",
    "Geometry",
    "JointRole",
    "JointSpec",
    "JointType",
    "Limits",
    "LinkSpec",
    "Mesh",
    "Origin",
    "PoseValue",
    "Sphere",
    "unit_axis",
]

#: Axes shorter than this [m or unitless] are taken for zero-length (a typing mistake).
MIN_AXIS_LENGTH = 1e-9


def unit_axis(v: tuple[float, ...]) -> tuple[float, float, float] | None:
    """The unit vector along ``v`` (three finite numbers), or ``None`` if ``v`` is (nearly) zero.

    The vector is scaled by its largest component before it is normalised, so that components
    near the float range (``1e308``) neither overflow to an infinite length nor turn a nonzero
    axis into a zero one.

    Args:
        v: The three components of a direction, any length.

    Returns:
        The unit vector, or ``None`` when the length is below :data:`MIN_AXIS_LENGTH`.
    """
    big = max(abs(x) for x in v)
    if not big > 0.0:
        return None
    scaled = [x / big for x in v]
    norm = math.sqrt(sum(x * x for x in scaled))  # in [1, sqrt(3)]: no overflow, no underflow
    if big * norm < MIN_AXIS_LENGTH:
        return None
    return (scaled[0] / norm, scaled[1] / norm, scaled[2] / norm)


class JointType(Enum):
    """Kinds of joints: 1-DOF, rotary 2-DOF (universal) and 3-DOF (ball), and fixed.

    1-DOF joints are revolute, continuous and prismatic.
    The rotary joints of 1-3 DOF are those of the lecture (L. Kavan, *Metody skeletální
    animace*, 2002). A universal joint turns about its first axis, then about its second axis in
    the frame moved by the first; a ball joint turns freely, its configuration a unit quaternion.
    """

    REVOLUTE = "revolute"
    CONTINUOUS = "continuous"
    PRISMATIC = "prismatic"
    FIXED = "fixed"
    UNIVERSAL = "universal"
    BALL = "ball"

    @property
    def actuated(self) -> bool:
        """Whether the joint has a degree of freedom."""
        return self is not JointType.FIXED

    @property
    def nq(self) -> int:
        """Entries of the joint in the configuration vector ``q`` (a ball joint: a quaternion)."""
        return _NQ.get(self.value, 1)

    @property
    def nv(self) -> int:
        """Entries of the joint in a velocity or tangent vector (its degrees of freedom)."""
        return _NV.get(self.value, 1)


#: A joint's value in a named pose: a number (1-DOF joints), two angles [rad] (universal), or
#: a unit quaternion (w, x, y, z) (ball).
PoseValue = float | tuple[float, ...]

_NQ = {"fixed": 0, "universal": 2, "ball": 4}
_NV = {"fixed": 0, "universal": 2, "ball": 3}


class JointRole(Enum):
    """What a joint is for: moving the arm, or opening and closing a gripper."""

    ARM = "arm"
    GRIPPER = "gripper"


class ArmRole(Enum):
    """What an arm is for: an arm that moves (``arm``), or a leader that is moved by hand.

    A leader (``role: leader``) is read by ``armctl teleop``, which switches its torque off;
    it is the arm a follower copies, never the follower.
    """

    ARM = "arm"
    LEADER = "leader"


@dataclass(frozen=True)
class Limits:
    """Joint limits in SI units; position limits are infinite for continuous joints.

    Attributes:
        lower: Lowest position in [rad] or [m].
        upper: Highest position in [rad] or [m].
        velocity: Highest speed in [rad/s] or [m/s], ``None`` when unknown.
        acceleration: Highest acceleration in [rad/s^2] or [m/s^2], ``None`` when unknown.
        jerk: Highest jerk in [rad/s^3] or [m/s^3], ``None`` when unknown.
        effort: Highest torque [N m] or force [N], ``None`` when unknown.
    """

    lower: float = -math.inf
    upper: float = math.inf
    velocity: float | None = None
    acceleration: float | None = None
    jerk: float | None = None
    effort: float | None = None


@dataclass(frozen=True)
class JointSpec:
    """One joint (1-DOF, universal, ball or fixed) between a parent and a child link.

    Attributes:
        name: Unique joint name.
        type: Joint type.
        parent: Parent link name.
        child: Child link name.
        origin: Placement of the joint frame in the parent link frame.
        axis: Unit axis in the joint frame (rotation axis, or direction of travel); for a ball
            joint the twist axis, also the centre of its swing cone.
        limits: Position, velocity, acceleration and jerk limits; for a ball joint ``lower`` and
            ``upper`` bound the twist about ``axis`` [rad]; for a universal joint those of the
            first axis (see ``axis_limits``).
        role: Arm joint or gripper joint.
        where: Where the joint was defined, for error messages.
        axes: A universal joint's two unit axes (the second in the frame moved by the first);
            empty for other joints.
        axis_limits: A universal joint's limits per axis; empty for other joints.
        swing: A ball joint's largest angle [rad] of its twist axis from its rest direction,
            in (0, pi]; pi for unlimited.
    """

    name: str
    type: JointType
    parent: str
    child: str
    origin: Origin = field(default_factory=Origin)
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    limits: Limits = Limits()
    role: JointRole = JointRole.ARM
    where: KeyPath = field(default=KeyPath(), compare=False)
    axes: tuple[tuple[float, float, float], ...] = ()
    axis_limits: tuple[Limits, ...] = ()
    swing: float = math.pi


@dataclass(frozen=True)
class FrameSpec:
    """A named frame rigidly attached to a link, such as a tool centre point.

    Attributes:
        name: Unique frame name (distinct from every link name).
        parent: The link it is attached to.
        origin: Its placement in the link frame.
        where: Where the frame was defined, for error messages.
    """

    name: str
    parent: str
    origin: Origin = field(default_factory=Origin)
    where: KeyPath = field(default=KeyPath(), compare=False)


@dataclass(frozen=True)
class LinkSpec:
    """A rigid link: its name and the geometry bound to it rigidly.

    Rigid binding as in the lecture (L. Kavan, *Metody skeletální animace*, 2002): every vertex
    of the geometry moves with this link alone.

    Attributes:
        name: Unique link name.
        visual: Shapes drawn for the link, in the link frame.
        collision: Shapes used for collision checks; the visual shapes when empty.
    """

    name: str
    visual: tuple[Geometry, ...] = ()
    collision: tuple[Geometry, ...] = ()


@dataclass(frozen=True)
class ArmSpec:
    """A validated arm description: a tree of links joined by joints (1-DOF, universal, ball).

    Attributes:
        name: Arm name.
        base: The root link.
        links: Every link (the base first).
        joints: Every joint, parents before children.
        frames: Extra named frames (tool frames) attached to links.
        tool: The default frame for FK and IK.
        end_effectors: Frames that are end effectors (the tool first).
        poses: Named joint configurations (``home``, ``park``, ...) by joint name, [rad] or [m].
        description: Free text.
        source: Where the kinematic parameters come from.
        bus: The servo bus section, when the arm has one.
        motion: Motion defaults, when given.
        file: The file the description was read from.
        scene: The ``scene:`` section (table, obstacles, padding); ``None``: not given (a
            table at the base frame's xy plane and the default padding).
        collision: The ``collision:`` section (allowed-collision matrix); ``None``: not
            given (the matrix is found by sampling when first needed).
        role: ``leader`` for a leader arm moved by hand in teleoperation, else ``arm``.
        skin: The ``skin:`` section (one mesh bound rigidly to the links, drawn instead of
            the link shapes); ``None``: not given.
    """

    name: str
    base: str
    links: tuple[LinkSpec, ...]
    joints: tuple[JointSpec, ...]
    frames: tuple[FrameSpec, ...] = ()
    tool: str = ""
    end_effectors: tuple[str, ...] = ()
    poses: dict[str, dict[str, PoseValue]] = field(default_factory=dict)
    description: str = ""
    source: str = ""
    bus: BusSpec | None = None
    motion: MotionSpec | None = None
    file: Path | None = None
    scene: SceneSpec | None = None
    collision: CollisionSpec | None = None
    role: ArmRole = ArmRole.ARM
    skin: SkinSpec | None = None

    def link(self, name: str) -> LinkSpec:
        """The link called ``name``."""
        from armctl.errors import UnknownNameError

        for link in self.links:
            if link.name == name:
                return link
        raise UnknownNameError("link", name, [lk.name for lk in self.links], f"arm {self.name!r}")

    def joint(self, name: str) -> JointSpec:
        """The joint called ``name``."""
        from armctl.errors import UnknownNameError

        for joint in self.joints:
            if joint.name == name:
                return joint
        raise UnknownNameError("joint", name, [j.name for j in self.joints], f"arm {self.name!r}")

    @property
    def actuated_joints(self) -> tuple[JointSpec, ...]:
        """The joints with a degree of freedom, in the order of the joint vector."""
        return tuple(j for j in self.joints if j.type.actuated)

    def no_bus_fix(self, sim: bool = True) -> str:
        """The fix for a command that needs servos on an arm without a ``bus:`` section.

        An arm with ball or universal joints cannot have one (a servo turns one axis): its
        motions are drawn instead. Other arms get a ``bus:`` section, or (``sim``) the built-in
        simulated bus.
        """
        multi = [j.name for j in self.actuated_joints
                 if j.type in (JointType.UNIVERSAL, JointType.BALL)]
        draw = f"'armctl render {self.name} --keyframes FILE -o motion.gif'"
        if multi:
            return (f"servos turn one axis each, so an arm with the multi-DOF joint(s) "
                    f"{', '.join(multi)} has no servos and no simulated bus; draw its motions "
                    f"instead: {draw}")
        return ("add a 'bus:' section (docs/bus.md)"
                + (", or use --sim for the built-in simulated bus" if sim else "")
                + f", or draw the motion instead of running it: {draw}")
