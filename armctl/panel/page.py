"""The control panel's page: a viser scene and GUI bound to a :class:`ControlPanel`.

The page shows the arm (one scene node per link, posed by FK of the joints read from the bus),
the table and the obstacles, the tool frame, a ghost arm at the previewed configuration, a
transform gizmo for the IK target with typed pose fields (millimetres and degrees), joint
sliders in degrees (millimetres for prismatic joints) inside the effective limits, the joint
values with their limits, the clearance, the connection (simulated bus or port) and who has
control; a Move button, a Stop button at the top of the panel that every tab can press, and
the keyframe panel. The camera opens fitted to the arm's reach.

Every button and field only calls the :class:`ControlPanel`: the page has no checks of its own.
viser is imported when the page starts (extra ``view``).
"""

from __future__ import annotations

import contextlib
import io
import logging
import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from armctl.collision.single import clearance_once
from armctl.config.schema import JointType
from armctl.errors import ArmctlError
from armctl.motion.interpolate import Interpolation
from armctl.panel.state import ControlPanel, Phase
from armctl.render.binding import BoundGeometry
from armctl.render.errors import MissingToolError
from armctl.render.live import add_arm_meshes
from armctl.render.scene import obstacle_meshes
from armctl.spatial import (
    make_transform,
    matrix_to_quat,
    matrix_to_rpy,
    quat_to_matrix,
    rpy_to_matrix,
)
from armctl.typing import Array

__all__ = ["CameraView", "PanelPage", "reach_camera"]

logger = logging.getLogger(__name__)

_GHOST_RGB = (40, 120, 220)
_OBSTACLE_RGB = (107, 123, 140)
#: Period of the joint table and clearance texts while the arm moves [s].
_TEXT_PERIOD = 0.5
#: Keyframes listed in the keyframe tab (the last ones of a longer list).
_LISTED = 40

#: Vertical field of view of the camera the page opens with [rad].
FOV = math.radians(50.0)


class CameraView:
    """Where the page's camera opens: ``position`` looking at ``look_at`` [m], z up.

    Attributes:
        position: Camera position ``(3,)`` in the base frame [m].
        look_at: The point it looks at ``(3,)`` [m] (the middle of the arm's reach).
        radius: Radius of the sphere around ``look_at`` that holds the reach [m].
        fov: Vertical field of view [rad].
    """

    def __init__(self, position: Array, look_at: Array, radius: float, fov: float):
        self.position = position
        self.look_at = look_at
        self.radius = radius
        self.fov = fov


def reach_camera(geo: BoundGeometry, lower: Array, upper: Array, q: Array,
                 samples: int = 64, fov: float = FOV) -> CameraView:
    """A camera that fits the arm's reach: its surface over sampled poses inside the limits.

    Args:
        geo: The arm's bound geometry.
        lower: Lower joint limits ``(dof,)`` [rad]/[m] (an infinite bound is taken as -pi).
        upper: Upper joint limits ``(dof,)`` (an infinite bound is taken as +pi).
        q: The present joints (always included).
        samples: Random poses sampled (seeded: the view is the same every time).
        fov: Vertical field of view [rad].
    """
    lo = np.where(np.isfinite(lower), lower, -np.pi)
    hi = np.where(np.isfinite(upper), upper, np.pi)
    rng = np.random.default_rng(0)
    qs = [q, *(lo + (hi - lo) * rng.random(lo.shape) for _ in range(samples))]
    pts = np.vstack([geo.world_vertices(qi) for qi in qs])
    centre = 0.5 * (pts.min(axis=0) + pts.max(axis=0))
    radius = float(np.max(np.linalg.norm(pts - centre, axis=1)))
    direction = np.array([1.0, -1.2, 0.7])
    direction /= np.linalg.norm(direction)
    distance = radius / math.sin(fov / 2.0) * 0.9  # the reach's sphere, a little cropped
    return CameraView(centre + distance * direction, centre, radius, fov)


#: The keyframe interpolation choice that means "the program's interpolation".
_AS_PROGRAM = "as the program"


def _unit(joint_type: JointType) -> tuple[str, float]:
    """The page's unit of a joint and the factor from SI: degrees, or millimetres."""
    return ("mm", 1000.0) if joint_type is JointType.PRISMATIC else ("deg", 180.0 / math.pi)


class PanelPage:
    """The viser page of a :class:`ControlPanel`, served on ``host:port``.

    Args:
        panel: The panel (its robot stays open and owned by the caller).
        host: Address to listen on (``127.0.0.1``: this machine only).
        port: TCP port; 0 picks a free one.
        connection: What the page says about the bus, e.g. ``"simulated bus"``.
        rate: Joint reads per second while no motion runs [Hz].

    Raises:
        MissingToolError: If viser is not installed (on :meth:`start`).
    """

    def __init__(self, panel: ControlPanel, host: str = "127.0.0.1", port: int = 0,
                 connection: str = "", rate: float = 20.0):
        self.panel = panel
        self.arm = panel.robot.arm
        self.host = host
        self.port = port
        self.connection = connection
        self.rate = rate
        self.camera: CameraView | None = None
        #: Length of the target gizmo's arrows [m] (set by :meth:`start`).
        self.gizmo_scale = math.nan
        self._server: Any = None
        self._h: dict[str, Any] = {}
        self._frames: dict[str, Any] = {}
        self._ghost_frames: dict[str, Any] = {}
        self._sliders: list[Any] = []
        self._target: Any = None
        self._stop = threading.Event()
        self._poller: threading.Thread | None = None
        self._ghost_run = 0  # bumped to cancel a running ghost playback
        self._animating = False  # a ghost playback runs
        self._shown_q: Array | None = None
        self._syncing = False
        self._lock = threading.RLock()
        self._texts: dict[str, str] = {}
        self._texts_at = -math.inf
        #: The last refusal or error shown in the page ("" when none).
        self.error = ""

    # ---- life cycle -------------------------------------------------------------------------
    @property
    def target_gizmo(self) -> Any:
        """The IK target's transform gizmo (viser handle: ``position`` [m], ``wxyz``)."""
        return self._target

    @property
    def url(self) -> str:
        """The page's address (valid after :meth:`start`)."""
        host = "127.0.0.1" if self.host in ("0.0.0.0", "", "::") else self.host
        return f"http://{host}:{self.port}/"

    def start(self) -> str:
        """Start serving; returns the page's URL."""
        try:
            import viser
        except ImportError as exc:
            raise MissingToolError("the control panel needs viser: pip install 'armctl[view]'"
                                   ) from exc
        geo = BoundGeometry(self.arm)
        with contextlib.redirect_stdout(io.StringIO()):  # viser prints a banner
            self._server = viser.ViserServer(host=self.host, port=self.port, verbose=False)
        self.port = int(self._server.get_port())
        q = self.panel.refresh()
        self.camera = reach_camera(geo, self.arm.lower, self.arm.upper, q)
        self._build_scene(geo, q)
        self._build_gui(q)
        self._server.on_client_connect(self._connect)
        self._server.on_client_disconnect(
            lambda client: self.panel.leave(self._client(client.client_id)))
        self.panel.on_change(self._update_text)
        self._show_q(q)
        self._update_text()
        self._poller = threading.Thread(target=self._poll, name="armctl-panel-page",
                                        daemon=True)
        self._poller.start()
        return self.url

    def stop(self) -> None:
        """Stop the page (idempotent). A running motion is stopped and held first."""
        self._stop.set()
        if self.panel.phase is not Phase.IDLE:
            self.panel.stop()
            self.panel.wait(30.0)
        if self._poller is not None:
            self._poller.join(timeout=5.0)
            self._poller = None
        if self._server is not None:
            with contextlib.redirect_stdout(io.StringIO()):
                self._server.stop()
            self._server = None

    def __enter__(self) -> PanelPage:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    @staticmethod
    def _client(client_id: int | None) -> str:
        return f"tab {client_id}"

    def _connect(self, client: Any) -> None:
        name = self._client(client.client_id)
        cam = self.camera
        if cam is not None:
            client.camera.up_direction = (0.0, 0.0, 1.0)
            client.camera.fov = cam.fov
            client.camera.position = cam.position
            client.camera.look_at = cam.look_at
        client.gui.add_markdown(f"This page is **{name}**.", order=1.5)
        self.panel.join(name)

    # ---- scene ------------------------------------------------------------------------------
    def _build_scene(self, geo: BoundGeometry, q: Array) -> None:
        server = self._server
        scene = server.scene
        scene.set_up_direction("+z")
        scene.configure_default_lights(True, cast_shadow=False)  # shadows cost every frame
        cam = self.camera
        assert cam is not None  # set by start  # mypy.
        server.initial_camera.up = (0.0, 0.0, 1.0)
        server.initial_camera.fov = cam.fov
        server.initial_camera.position = cam.position
        server.initial_camera.look_at = cam.look_at
        base = self.arm.spec.base
        self._ghost_root = scene.add_frame("/ghost", show_axes=False, visible=False)
        self._frames.update(add_arm_meshes(scene, geo, base, "/arm", cast_shadow=False,
                                           receive_shadow=False))
        self._ghost_frames.update(add_arm_meshes(scene, geo, base, "/ghost", _GHOST_RGB,
                                                 opacity=0.35, cast_shadow=False,
                                                 receive_shadow=False))
        size = 2.0 * cam.radius
        model = self.panel.robot.collisions
        if model is not None:
            table = model.scene.table
            if table is not None:
                scene.add_box("/scene/table", color=(181, 155, 107),
                              dimensions=(2.0 * size, 2.0 * size, 0.004),
                              position=(cam.look_at[0], cam.look_at[1], table.height - 0.002),
                              opacity=0.5, cast_shadow=False, receive_shadow=False)
            for ob in obstacle_meshes(model.scene, self.arm.spec.file):
                scene.add_mesh_simple(f"/scene/{ob.name}", ob.mesh.vertices.astype(np.float32),
                                      ob.mesh.faces.astype(np.uint32), color=_OBSTACLE_RGB,
                                      opacity=0.6, flat_shading=True, cast_shadow=False,
                                      receive_shadow=False)
        self._tool = scene.add_frame("/tool", axes_length=0.08 * size, axes_radius=0.003 * size)
        pose = self.arm.fk(q)
        self.gizmo_scale = 0.15 * size
        self._target = scene.add_transform_controls(
            "/target", scale=self.gizmo_scale, position=pose[:3, 3],
            wxyz=matrix_to_quat(pose[:3, :3]))
        self._target.on_update(self._dragged)

    # ---- GUI --------------------------------------------------------------------------------
    def _build_gui(self, q: Array) -> None:
        gui = self._server.gui
        h = self._h
        # The right edge holds a column of two panes, each scrolling on its own: on top Stop
        # (always in view) with what is connected, who commands, what the arm does and the
        # last refusal; below it the tabs of the controls.
        state = gui.add_panel()
        with state.add_tab("Arm"):
            h["stop"] = gui.add_button("STOP", color="red",
                                       hint="decelerate and hold (any tab, at any time)")
            h["head"] = gui.add_markdown("")
            h["status"] = gui.add_markdown("")
            h["error"] = gui.add_markdown("")
        main = gui.main_panel
        main.dock_right()
        state.dock_above(main)
        h["state_pane"] = state
        h["stop"].on_click(lambda e: self.panel.stop(self._client(e.client_id)))
        tabs = gui.add_tab_group(order=4.0)
        pose = self.arm.fk(q)
        with tabs.add_tab("Target"):
            h["xyz"] = gui.add_vector3("xyz [mm]", tuple(np.round(pose[:3, 3] * 1000.0, 1)),
                                       step=0.1)
            h["rpy"] = gui.add_vector3("rpy [deg]",
                                       tuple(np.round(np.degrees(matrix_to_rpy(pose[:3, :3])), 1)),
                                       step=0.1)
            h["oriented"] = gui.add_checkbox("orientation counts",
                                              len(self.arm.chain(None)) >= 6)
            h["preview"] = gui.add_button("Preview typed pose", color="blue")
            h["preview"].on_click(lambda e: self._do(e, self._preview_typed))
            h["move"] = gui.add_button("Move", color="green",
                                       hint="move to the previewed target (planned and checked "
                                            "again from the present position)")
            h["move"].on_click(lambda e: self._do(e, self.panel.move))
        with tabs.add_tab("Joints"):
            for i, name in enumerate(self.arm.joint_names):
                unit, k = _unit(self.arm.joint_types[i])
                lo = float(self.arm.lower[i]) if np.isfinite(self.arm.lower[i]) else -math.pi
                hi = float(self.arm.upper[i]) if np.isfinite(self.arm.upper[i]) else math.pi
                slider = gui.add_slider(f"{name} [{unit}]", round(lo * k, 2), round(hi * k, 2),
                                        0.1, float(np.clip(round(q[i] * k, 2), lo * k, hi * k)))
                slider.on_update(self._slid(i))
                self._sliders.append(slider)
            h["move_joint"] = gui.add_button("Move", color="green",
                                             hint="move to the joint values of the sliders")
            h["move_joint"].on_click(lambda e: self._do(e, self.panel.move))
            h["joints"] = gui.add_markdown("")
            h["clearance"] = gui.add_markdown("")
        with tabs.add_tab("Keyframes"):
            self._build_keyframes(gui)
        with tabs.add_tab("Control"):
            if self.panel.protected:
                h["token"] = gui.add_text("token", "")
            h["take"] = gui.add_button("Take control")
            h["take"].on_click(lambda e: self._do(e, lambda c: self.panel.take_control(
                c, h["token"].value if "token" in h else None, force=True)))
            h["release"] = gui.add_button("Release control", color="gray")
            h["release"].on_click(lambda e: self._do(e, self.panel.release_control))

    def _build_keyframes(self, gui: Any) -> None:
        h, p = self._h, self.panel
        h["kf_list"] = gui.add_markdown("")
        h["kf_index"] = gui.add_number("keyframe #", 0, min=0, step=1)
        h["kf_name"] = gui.add_text("name", "")

        def last() -> int:
            return max(len(p.program.keyframes) - 1, 0)

        self._group(gui, "edit", {
            "Record": lambda c: p.record(c, h["kf_name"].value),
            "Rename": lambda c: p.rename(c, self._kf(), h["kf_name"].value),
            "Up": lambda c: p.move_keyframe(c, self._kf(), max(self._kf() - 1, 0)),
            "Down": lambda c: p.move_keyframe(c, self._kf(), min(self._kf() + 1, last())),
            "Delete": lambda c: p.delete_keyframe(c, self._kf())})
        h["rec_rate"] = gui.add_number("recording rate [Hz]", 10.0, min=1.0, max=100.0, step=1.0)
        self._group(gui, "continuous", {
            "Start recording": lambda c: p.start_recording(c, float(h["rec_rate"].value)),
            "Stop recording": p.stop_recording})
        h["kf_dwell"] = gui.add_number("dwell [s]", 0.0, min=0.0, step=0.1)
        h["kf_time"] = gui.add_text("time [s]", "", hint="time stamp; blank: none (a program "
                                    "plays by its time stamps when every keyframe has one)")
        h["kf_kind"] = gui.add_dropdown("its interpolation",
                                        [_AS_PROGRAM, *(i.value for i in Interpolation)],
                                        initial_value=_AS_PROGRAM,
                                        hint="how the segment arriving at this keyframe is "
                                             "joined; where it changes the arm rests")
        self._group(gui, "selected", {
            "Set times": self._set_times,
            "Set interpolation": lambda c: p.set_keyframe_interpolation(
                c, self._kf(), None if h["kf_kind"].value == _AS_PROGRAM
                else Interpolation(h["kf_kind"].value)),
            "Preview keyframe": lambda c: self._show_preview(p.preview_keyframe(c, self._kf()))})
        self._group(gui, "pose keyframe", {
            "Pose to target": self._pose_to_fields,
            "Set pose from target": self._pose_from_fields})
        h["kf_interp"] = gui.add_dropdown("interpolation", [i.value for i in Interpolation],
                                          initial_value=p.interpolation.value)
        h["kf_interp"].on_update(lambda e: self._do(e, lambda c: p.set_interpolation(
            c, Interpolation(h["kf_interp"].value))))
        self._group(gui, "playback", {"Preview": self._ghost_playback, "Play": p.play,
                                      "Pause": p.pause, "Resume": p.resume})
        h["speed"] = gui.add_slider("speed override", 0.02, 2.0, 0.01, 1.0)
        h["speed"].on_update(lambda e: self._do(e, lambda c: p.set_speed(c, h["speed"].value)))
        h["kf_file"] = gui.add_text("file", "keyframes.yaml")
        h["kf_overwrite"] = gui.add_checkbox("overwrite", False)
        self._group(gui, "keyframe file", {
            "Save": lambda c: p.save(c, h["kf_file"].value, h["kf_overwrite"].value),
            "Load": lambda c: p.load(c, h["kf_file"].value)})

    def _group(self, gui: Any, label: str, actions: dict[str, Callable[[str], object]]) -> None:
        """A row of buttons, one per action."""
        group = gui.add_button_group(label, tuple(actions))
        group.on_click(lambda e: self._do(e, actions[str(group.value)]))
        self._h[f"group {label}"] = group

    def _kf(self) -> int:
        return int(self._h["kf_index"].value)

    def _pose_to_fields(self, client: str) -> None:
        """Show the selected pose keyframe's pose in the Target tab (mm, deg) and the gizmo."""
        i = self._kf()
        kfs = self.panel.program.keyframes
        if not 0 <= i < len(kfs) or kfs[i].pose is None:
            from armctl.errors import InputError

            raise InputError(f"keyframe {i} is not a pose keyframe: pick one with a pose")
        pose = np.asarray(kfs[i].pose)
        with self._lock:
            self._syncing = True
            try:
                self._h["xyz"].value = tuple(np.round(pose[:3, 3] * 1000.0, 1))
                self._h["rpy"].value = tuple(np.round(np.degrees(matrix_to_rpy(pose[:3, :3])),
                                                      1))
                self._h["oriented"].value = bool(kfs[i].orientation)
                self._target.position = pose[:3, 3]
                self._target.wxyz = matrix_to_quat(pose[:3, :3])
            finally:
                self._syncing = False

    def _pose_from_fields(self, client: str) -> None:
        """Give the selected pose keyframe the Target tab's pose (re-solved by the Robot)."""
        xyz = np.asarray(self._h["xyz"].value, dtype=float) / 1000.0
        rpy = np.radians(np.asarray(self._h["rpy"].value, dtype=float))
        pose = make_transform(rpy_to_matrix(rpy), xyz)
        try:
            preview = self.panel.set_keyframe_pose(client, self._kf(), pose,
                                                   bool(self._h["oriented"].value))
        except ArmctlError:
            if self.panel.preview is not None:  # the refused pose and the reason
                self._show_preview(self.panel.preview)
            raise
        self._show_preview(preview)

    def _set_times(self, client: str) -> None:
        text = str(self._h["kf_time"].value).strip()
        try:
            t = math.nan if not text else float(text)
        except ValueError:
            from armctl.errors import InputError

            raise InputError(f"time [s] {text!r} is not a number (blank: no time stamp)"
                             ) from None
        self.panel.set_timing(client, self._kf(), float(self._h["kf_dwell"].value), t)

    # ---- actions ----------------------------------------------------------------------------
    def _do(self, event: Any, action: Callable[[str], object]) -> None:
        """Run a page action for the client of ``event``; show a refusal in the page."""
        client_id = getattr(event, "client_id", None)
        if client_id is None:  # a value the server set itself
            return
        client = self._client(client_id)
        try:
            action(client)
        except ArmctlError as exc:
            self._show_error(f"**refused** ({client}): {exc}")
        else:
            self._show_error("")

    def _show_error(self, text: str) -> None:
        self.error = text
        self._set_text("error", text)

    def _preview_typed(self, client: str) -> None:
        xyz = np.asarray(self._h["xyz"].value, dtype=float) / 1000.0
        rpy = np.radians(np.asarray(self._h["rpy"].value, dtype=float))
        pose = make_transform(rpy_to_matrix(rpy), xyz)
        with self._lock:
            self._target.position = xyz
            self._target.wxyz = matrix_to_quat(pose[:3, :3])
        self._show_preview(self.panel.preview_pose(client, pose, bool(self._h["oriented"].value)))

    def _dragged(self, event: Any) -> None:
        if getattr(event, "phase", "end") != "end":
            return
        t = self._target
        pose = make_transform(quat_to_matrix(np.asarray(t.wxyz)), np.asarray(t.position))
        with self._lock:
            self._syncing = True
            try:
                self._h["xyz"].value = tuple(np.round(pose[:3, 3] * 1000.0, 1))
                self._h["rpy"].value = tuple(np.round(np.degrees(matrix_to_rpy(pose[:3, :3])),
                                                      1))
            finally:
                self._syncing = False
        self._do(event, lambda c: self._show_preview(
            self.panel.preview_pose(c, pose, bool(self._h["oriented"].value))))

    def _slid(self, i: int) -> Callable[[Any], None]:
        _, k = _unit(self.arm.joint_types[i])
        name = self.arm.joint_names[i]

        def on_update(event: Any) -> None:
            if self._syncing:
                return
            value = float(self._sliders[i].value) / k
            self._do(event, lambda c: self._show_preview(self.panel.preview_joint(c, name,
                                                                                  value)))
        return on_update

    def _show_preview(self, preview: Any) -> None:
        self._ghost_run += 1
        self._ghost(preview.ghost if preview.ok else None)

    def _ghost(self, q: Array | None) -> None:
        if q is None:
            self._ghost_root.visible = False
            return
        poses = self.arm.fk_frames(q)
        for link, frame in self._ghost_frames.items():
            t = poses[self.arm.frame_index(link)]
            frame.position = t[:3, 3]
            frame.wxyz = matrix_to_quat(t[:3, :3])
        self._ghost_root.visible = True

    def _ghost_playback(self, client: str) -> None:
        ts, qs = self.panel.preview_playback(client)
        self._ghost_run += 1
        run = self._ghost_run

        def animate() -> None:
            t0 = 0.0
            self._animating = True
            try:
                for t, q in zip(ts, qs, strict=True):
                    if self._stop.wait(max(float(t) - t0, 0.0)) or run != self._ghost_run:
                        return
                    t0 = float(t)
                    self._ghost(q)
            finally:
                self._animating = False
        threading.Thread(target=animate, name="armctl-panel-ghost", daemon=True).start()

    # ---- showing the state ------------------------------------------------------------------
    def _set_text(self, key: str, text: str) -> None:
        with self._lock:
            if self._texts.get(key) == text:
                return
            self._texts[key] = text
            handle = self._h.get(key)
        if handle is not None:
            handle.content = text

    def _show_q(self, q: Array) -> None:
        with self._lock:
            poses = self.arm.fk_frames(q)
            for link, frame in self._frames.items():
                t = poses[self.arm.frame_index(link)]
                frame.position = t[:3, 3]
                frame.wxyz = matrix_to_quat(t[:3, :3])
            tool = poses[self.arm.frame_index(None)]
            self._tool.position = tool[:3, 3]
            self._tool.wxyz = matrix_to_quat(tool[:3, :3])
            self._shown_q = q.copy()
            now = time.monotonic()
            if now - self._texts_at < _TEXT_PERIOD and self.panel.phase is not Phase.IDLE:
                return  # the numbers follow at a pace a person reads (less work for the page)
            self._texts_at = now
        rows = ["| joint | value | limits |", "|---|---:|---|"]
        for i, name in enumerate(self.arm.joint_names):
            unit, k = _unit(self.arm.joint_types[i])
            rows.append(f"| {name} | {q[i] * k:.1f} {unit} | {self.arm.lower[i] * k:.0f} to "
                        f"{self.arm.upper[i] * k:.0f} |")
        self._set_text("joints", "\n".join(rows))
        model = self.panel.robot.collisions
        c = None if model is None else clearance_once(model, q)
        if c is None:
            text = "clearance: not checked"
        elif c.margin < 0.0:
            text = f"**IN CONTACT**: {c.a} and {c.b}, distance {c.distance * 1000:.1f} mm"
        else:
            text = (f"clearance: {c.margin * 1000:.1f} mm beyond the padding ({c.a} and "
                    f"{c.b})")
        self._set_text("clearance", text)

    def _update_text(self) -> None:
        p = self.panel
        arm = self.arm
        self._set_text("head", f"**{arm.name}** on the {self.connection}: {arm.dof} joints, "
                               f"tool `{arm.tool}`")
        holder = p.controller
        others = [v for k, v in p.clients.items() if k != holder]
        ctl = p.robot.control.state()
        phase = p.phase
        preview = p.preview
        lines = [f"control: **{p.label(holder)}**" + (f" (also watching: {', '.join(others)})"
                                                      if others else ""),
                 f"arm: **{phase.value}**" + (" (paused)" if ctl.paused else "")
                 + f", speed override x{ctl.speed:.2f}"
                 + (", **recording**" if p.recording else "")]
        if preview is not None:
            lines.append(f"target: **{preview.kind.value}**: {preview.message}")
        outcome = p.outcome
        if outcome is not None:
            lines.append(f"last {outcome.what}: {outcome.message}")
        if p.message and (outcome is None or p.message != outcome.message):
            lines.append(f"last: {p.message}")
        self._set_text("status", "\n\n".join(lines))
        program = p.program
        if program.keyframes:
            rows = ["| # | name | kind | dwell | time | into it |",
                    "|---|---|---|---:|---:|---|"]
            n = len(program.keyframes)
            first = max(n - _LISTED, 0)  # a long recording: its last keyframes
            if first:
                rows.append(f"| ... | {first} more | | | | |")
            for i, kf in enumerate(program.keyframes[first:], start=first):
                t = "-" if kf.time is None else f"{kf.time:.2f}"
                kind = "joints" if kf.pose is None else "pose"
                into = "-" if kf.interpolation is None else kf.interpolation.value
                rows.append(f"| {i} | {kf.label} | {kind} | {kf.dwell:.2f} | {t} | {into} |")
            self._set_text("kf_list", "\n".join(rows))
        else:
            self._set_text("kf_list", "no keyframes yet")
        if preview is None and not self._animating:  # a move started or ended: no target
            self._ghost(None)

    def _poll(self) -> None:
        period = 1.0 / self.rate
        while not self._stop.wait(period):
            try:
                q = self.panel.refresh()
                if self._shown_q is None or not np.allclose(q, self._shown_q, atol=1e-5):
                    self._show_q(q)
                    self._sync_sliders(q)
                self._update_text()
            except Exception as exc:  # shown in the page; the page keeps running
                logger.warning("the panel could not update: %s", exc)
                self._set_text("status", f"bus read failed: {exc}")

    def _sync_sliders(self, q: Array) -> None:
        if self.panel.preview is not None:  # keep the slider the user set while previewing
            return
        with self._lock:
            self._syncing = True
            try:
                for i, slider in enumerate(self._sliders):
                    _, k = _unit(self.arm.joint_types[i])
                    slider.value = float(np.clip(round(q[i] * k, 2), slider.min, slider.max))
            finally:
                self._syncing = False

