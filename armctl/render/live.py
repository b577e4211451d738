"""A live 3-D view of an arm in the browser (optional extra ``view``: the viser package).

Every link is a node of the browser's scene graph holding its geometry in the link frame; moving
the arm sets one pose per link node (the rigid binding of the lecture, L. Kavan, *Metody
skeletální animace*, 2002). The view offers one slider per joint, a draggable target that runs
IK from the current pose, and can follow a servo bus (it only reads joint positions; it never
commands the arm).

viser is imported when a :class:`LiveView` starts, so other commands do not pay for it.
"""

from __future__ import annotations

import contextlib
import io
import threading
from collections.abc import Callable
from typing import Any

import numpy as np
import numpy.typing as npt

from armctl.errors import ArmctlError
from armctl.kinematics.model import KinematicModel
from armctl.render.binding import BoundGeometry
from armctl.render.errors import MissingToolError
from armctl.spatial import make_transform, matrix_to_quat, quat_to_matrix
from armctl.typing import Array

__all__ = ["LiveView", "add_arm_meshes"]


_LINK_RGB = ((230, 159, 0), (143, 163, 184))
_BASE_RGB = (77, 77, 77)


def _node(link: str, root: str = "/arm") -> str:
    return f"{root}/" + link.replace("/", "_")


def add_arm_meshes(scene: Any, geo: BoundGeometry, base: str, root: str = "/arm",
                   rgb: tuple[int, int, int] | None = None, **mesh: Any) -> dict[str, Any]:
    """Add one scene node per link under ``root``, holding the link's meshes in its frame.

    Moving the arm then sets one pose per node (see :meth:`LiveView.set_q`).

    Args:
        scene: A viser scene (``server.scene``).
        geo: The arm's bound geometry.
        base: The base link (drawn dark grey).
        root: The scene path the link nodes go under.
        rgb: One colour for every link (default: the base grey, the others alternating).
        **mesh: Further options of viser's ``add_mesh_simple`` (e.g. ``opacity``).

    Returns:
        The node of each link, by link name.
    """
    frames: dict[str, Any] = {}
    k = 0
    for link in geo.links:
        node = _node(link, root)
        frames[link] = scene.add_frame(node, show_axes=False)
        if rgb is not None:
            color = rgb
        elif link == base:
            color = _BASE_RGB
        else:
            color = _LINK_RGB[k % 2]
            k += 1
        shapes = [s.mesh for s in geo.shapes if s.link == link]
        for i, m in enumerate(shapes):
            scene.add_mesh_simple(f"{node}/shape{i}", m.vertices.astype(np.float32),
                                  m.faces.astype(np.uint32), color=color, flat_shading=True,
                                  **mesh)
    return frames


class LiveView:
    """A browser view of one arm, served by viser on ``host:port``.

    Args:
        arm: The arm (an :class:`~armctl.arm.Arm`; its ``ik`` method drives the target).
        host: Address to listen on (``127.0.0.1``: this machine only).
        port: TCP port; 0 picks a free one.
        solver: IK solver name used by the draggable target.

    Raises:
        MissingToolError: If viser is not installed.
    """

    def __init__(self, arm: KinematicModel, host: str = "127.0.0.1", port: int = 0,
                 solver: str = "auto"):
        self.arm = arm
        self.host = host
        self.port = port
        self.solver = solver
        self.q: Array = arm.middle()
        if "home" in arm.spec.poses:
            self.q = arm.named_pose("home")
        #: Text of the last IK attempt from the target ("" before the first).
        self.ik_status = ""
        self._server: Any = None
        self._frames: dict[str, Any] = {}
        self._sliders: list[Any] = []
        self._target: Any = None
        self._status: Any = None
        self._lock = threading.RLock()
        self._syncing = False
        self._stop = threading.Event()
        self._follower: threading.Thread | None = None

    # ---- life cycle ---------------------------------------------------------------------------
    @property
    def url(self) -> str:
        """The page's address (valid after :meth:`start`)."""
        host = "127.0.0.1" if self.host in ("0.0.0.0", "") else self.host
        return f"http://{host}:{self.port}/"

    def start(self) -> str:
        """Start serving; returns the page's URL."""
        try:
            import viser
        except ImportError as exc:
            raise MissingToolError("the live view needs viser: pip install 'armctl[view]'") \
                from exc
        geo = BoundGeometry(self.arm)
        with contextlib.redirect_stdout(io.StringIO()):  # viser prints a banner: we print the URL
            self._server = viser.ViserServer(host=self.host, port=self.port, verbose=False)
        self.port = int(self._server.get_port())
        self._build_scene(geo)
        self._build_gui()
        self.set_q(self.q)
        return self.url

    def stop(self) -> None:
        """Stop following the bus and stop the server (idempotent)."""
        self._stop.set()
        if self._follower is not None:
            self._follower.join(timeout=5.0)
            self._follower = None
        if self._server is not None:
            with contextlib.redirect_stdout(io.StringIO()):
                self._server.stop()
            self._server = None

    def __enter__(self) -> LiveView:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ---- scene --------------------------------------------------------------------------------
    def _build_scene(self, geo: BoundGeometry) -> None:
        scene = self._server.scene
        self._frames.update(add_arm_meshes(scene, geo, self.arm.spec.base))
        size = float(np.ptp(geo.world_vertices(self.q), axis=0).max())
        pose = self.arm.fk(self.q)
        self._tool_axes = scene.add_frame("/tool", axes_length=0.15 * size,
                                          axes_radius=0.006 * size)
        self._target = scene.add_transform_controls(
            "/target", scale=0.3 * size, position=pose[:3, 3], wxyz=matrix_to_quat(pose[:3, :3]))
        self._target.on_update(lambda _event: self.solve_target())

    def _build_gui(self) -> None:
        gui = self._server.gui
        gui.add_markdown(f"**{self.arm.name}**: {self.arm.dof} joints, tool `{self.arm.tool}`")
        self._orient = gui.add_checkbox("target orientation", True)
        self._status = gui.add_markdown("drag the target to run IK")
        for i, name in enumerate(self.arm.joint_names):
            lo = float(self.arm.lower[i]) if np.isfinite(self.arm.lower[i]) else -np.pi
            hi = float(self.arm.upper[i]) if np.isfinite(self.arm.upper[i]) else np.pi
            slider = gui.add_slider(name, lo, hi, (hi - lo) / 1000.0, float(self.q[i]))
            slider.on_update(lambda _event: self._from_sliders())
            self._sliders.append(slider)

    def _from_sliders(self) -> None:
        if self._syncing:
            return
        self.set_q(np.array([float(s.value) for s in self._sliders]))

    # ---- state --------------------------------------------------------------------------------
    def set_q(self, q: npt.ArrayLike) -> None:
        """Show the arm at joint values ``q`` ``(dof,)`` [rad] / [m]."""
        qv = self.arm.as_q(q)
        with self._lock:
            self.q = qv
            if self._server is None:
                return
            poses = self.arm.fk_frames(qv)
            for link, frame in self._frames.items():
                t = poses[self.arm.frame_index(link)]
                frame.position = t[:3, 3]
                frame.wxyz = matrix_to_quat(t[:3, :3])
            tool = poses[self.arm.frame_index(None)]
            self._tool_axes.position = tool[:3, 3]
            self._tool_axes.wxyz = matrix_to_quat(tool[:3, :3])
            self._syncing = True
            try:
                for slider, v in zip(self._sliders, qv, strict=True):
                    slider.value = float(np.clip(v, slider.min, slider.max))
            finally:
                self._syncing = False

    def link_pose(self, link: str) -> Array:
        """The pose ``(4, 4)`` the view currently shows for a link's node."""
        frame = self._frames[link]
        return make_transform(quat_to_matrix(np.asarray(frame.wxyz)), np.asarray(frame.position))

    def shown(self, link: str) -> tuple[Array, Array]:
        """The joint values and a link's pose as shown, read together.

        The two are consistent while a :meth:`follow` thread updates the view.

        Returns:
            ``(q, pose)``: ``(dof,)`` joint values and the ``(4, 4)`` pose of ``link``.
        """
        with self._lock:
            return np.array(self.q), self.link_pose(link)

    def target_pose(self) -> Array:
        """The draggable target's pose ``(4, 4)`` in the base frame."""
        return make_transform(quat_to_matrix(np.asarray(self._target.wxyz)),
                              np.asarray(self._target.position))

    def set_target(self, pose: npt.ArrayLike) -> None:
        """Move the draggable target to a ``(4, 4)`` pose (without solving)."""
        t = np.asarray(pose, dtype=float)
        self._target.position = t[:3, 3]
        self._target.wxyz = matrix_to_quat(t[:3, :3])

    def solve_target(self) -> bool:
        """Run IK from the current pose to the target; move the view if it succeeds.

        Returns:
            Whether IK reached the target (the arm is shown at the solution only then).
        """
        ik = getattr(self.arm, "ik", None)
        ok = False
        if ik is None:
            self.ik_status = "IK is not available for this model"
        else:
            from armctl.ik import PositionGoal

            pose = self.target_pose()
            goal: Any = pose if self._orient.value else PositionGoal(pose[:3, 3])
            try:
                result = ik(goal, self.q, self.solver)
            except ArmctlError as exc:
                self.ik_status = f"IK failed: {exc}"
            else:
                self.ik_status = (f"IK {result.status.value}: position error "
                                  f"{result.position_error * 1000:.2f} mm, rotation error "
                                  f"{np.degrees(result.rotation_error):.2f} deg")
                ok = bool(result.success)
                if ok:
                    self.set_q(result.q)
        if self._status is not None:
            self._status.content = self.ik_status
        return ok

    # ---- following a bus ----------------------------------------------------------------------
    def follow(self, read_joints: Callable[[], npt.ArrayLike], rate: float = 20.0) -> None:
        """Poll ``read_joints`` in a background thread and show what it returns.

        Args:
            read_joints: Returns the joint vector ``(dof,)`` (e.g. ``ArmBus.read_joints``).
            rate: Polls per second [Hz].
        """
        period = 1.0 / rate
        for slider in self._sliders:
            slider.disabled = True

        def loop() -> None:
            while not self._stop.wait(period):
                try:
                    self.set_q(read_joints())
                except Exception as exc:  # shown in the page, the view keeps running
                    if self._status is not None:
                        self._status.content = f"bus read failed: {exc}"
        self._follower = threading.Thread(target=loop, name="armctl-view-follow", daemon=True)
        self._follower.start()
