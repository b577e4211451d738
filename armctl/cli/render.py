"""Commands that show the arm: ``render`` (pictures and playback), ``workspace``, ``view``."""

from __future__ import annotations

import argparse
import math
import sys
import time
from typing import TYPE_CHECKING, Any

from armctl.cli._common import (
    add_config,
    add_json,
    check_rpy,
    emit,
    finite,
    fmt,
    load_arm_arg,
    nonnegative,
    parse_angles,
    positive,
    positive_int,
    table,
)
from armctl.errors import InputError

if TYPE_CHECKING:
    import numpy as np

    from armctl.arm import Arm
    from armctl.collision import Clearance
    from armctl.config.scene import SceneSpec
    from armctl.render.draw import Camera, View
    from armctl.render.picture import Target
    from armctl.robot.live_watch import LiveWatcher

ORDER = 60

_VIEWS = ("iso", "front", "side", "top", "all")


def register(sub: argparse._SubParsersAction) -> None:
    """Add the drawing commands."""
    p = sub.add_parser("render", help="draw the arm in a pose (PNG/SVG/PDF) or a playback (GIF)",
                       description="Draw the arm at joint values Q (default: the 'home' pose, "
                       "else the middle of the joint ranges). Pictures are drawn headless.")
    add_config(p)
    p.add_argument("q", nargs="*", metavar="Q", help="joint values, radians/metres (see --deg)")
    p.add_argument("-o", "--output", required=True,
                   help="image file (.png .svg .pdf .jpg), or .gif/.mp4 with --keyframes")
    p.add_argument("--deg", action="store_true", help="rotary joint values and rpy in degrees")
    p.add_argument("--pose", help="a named pose of the arm instead of Q")
    p.add_argument("--view", choices=_VIEWS, default="iso",
                   help="camera: iso, front (from +x), side (from -y), top, or all four")
    p.add_argument("--elev", type=finite, help="camera elevation [deg] (overrides --view)")
    p.add_argument("--azim", type=finite, help="camera azimuth from +x [deg] (overrides --view)")
    p.add_argument("--frames", action="append", metavar="NAMES",
                   help="frames drawn as axis triads: 'tool' (default: the tool, or every end "
                   "effector of an arm with several), 'all', 'none', or comma-separated frame "
                   "names; may be repeated")
    p.add_argument("--target-xyz", nargs=3, type=finite, metavar=("X", "Y", "Z"),
                   help="draw a target position [m]")
    p.add_argument("--target-rpy", nargs=3, type=finite, metavar=("R", "P", "Y"),
                   help="target orientation, roll pitch yaw (radians, or degrees with --deg)")
    motion = p.add_mutually_exclusive_group()
    motion.add_argument("--keyframes", metavar="FILE",
                        help="animate the playback of a keyframe file from Q (-o .gif or .mp4)")
    motion.add_argument("--path", action="store_true",
                        help="plan a straight-line move from Q to the target and draw it with its "
                        "IK samples (-o image), or animate it (-o .gif/.mp4)")
    p.add_argument("--solver", default="auto", help="IK solver for --path and pose keyframes")
    p.add_argument("--speed", type=finite, default=1.0,
                   help="speed factor of the planned motion, (0, 1] (default 1)")
    p.add_argument("--fps", type=positive, default=20.0, help="animation frames per second (20)")
    p.add_argument("--size", type=positive, default=None,
                   help="size of one panel [in] (default 5, animations 4.5)")
    p.add_argument("--dpi", type=positive, default=None,
                   help="resolution (default 110, animations 80)")
    p.add_argument("--tip", help="URDF only: keep the chain to this link")
    scene = p.add_mutually_exclusive_group()
    scene.add_argument("--scene", metavar="FILE", default=None,
                       help="draw this scene file (table, obstacles; docs/config.md) instead of "
                            "the config's 'scene:' section; a pair in contact is drawn red")
    scene.add_argument("--no-scene", action="store_true",
                       help="draw the arm alone, without the table and the obstacles")
    add_json(p)
    p.set_defaults(func=cmd_render)

    p = sub.add_parser("workspace", help="plot the reachable workspace (sampled FK cloud)")
    add_config(p)
    p.add_argument("-o", "--output", required=True, help="image file (.png .svg .pdf .jpg)")
    p.add_argument("--frame", help="frame to sample (default: the tool frame)")
    p.add_argument("--samples", type=positive_int, default=20000,
                   help="random configurations (20000)")
    p.add_argument("--seed", type=int, default=0, help="random seed (0)")
    p.add_argument("--voxel", type=positive, help="voxel edge [m] of the volume estimate")
    p.add_argument("--z", type=finite, help="height [m] of the x-y slice (default: mid z)")
    p.add_argument("--y", type=finite, help="offset [m] of the x-z slice (default: mid y)")
    p.add_argument("--slab", type=positive, help="slice thickness [m] (default: 5%% of the extent)")
    p.add_argument("--tip", help="URDF only: keep the chain to this link")
    add_json(p)
    p.set_defaults(func=cmd_workspace)

    p = sub.add_parser("view", help="live 3-D view in the browser (extra 'view': viser)",
                       description="Serve a live 3-D view of the arm with joint sliders and a "
                       "draggable IK target. Stops on Ctrl-C (or after --duration). With a bus "
                       "(--sim, --bus, --port) the page is a control panel: it previews targets "
                       "and moves the arm through the same planning, limits and collision "
                       "checks as the other verbs, with a Stop button and keyframes; --watch "
                       "only reads joint positions. When another armctl command owns the port "
                       "the view shows that command's live state.")
    add_config(p)
    p.add_argument("--host", default="127.0.0.1",
                   help="address to listen on (default 127.0.0.1: this machine only)")
    p.add_argument("--http-port", type=int, default=None, metavar="N",
                   help="TCP port of the web server (default 8080, or the next free one, "
                        "said on stderr; a port given must be free; 0: any free)")
    p.add_argument("--bus", action="store_true",
                   help="follow the arm's servo bus (the 'bus:' section; the simulated bus "
                   "when it says so) by reading joint positions")
    where = p.add_mutually_exclusive_group()
    where.add_argument("--port", metavar="PORT",
                       help="follow the servos on this port (a device, or the pty of 'armctl "
                            "sim'); when another armctl command owns it, show that command live")
    where.add_argument("--sim", action="store_true",
                       help="follow the built-in simulated bus whatever port the config names")
    p.add_argument("--rate", type=positive, default=20.0, help="bus polls per second (20)")
    p.add_argument("--solver", default="auto", help="IK solver for the target (default auto)")
    p.add_argument("--duration", type=nonnegative, help="stop after this many seconds")
    p.add_argument("--watch", action="store_true",
                   help="with a bus: only show it (read joint positions), never command the arm")
    p.add_argument("--token", metavar="TEXT",
                   help="control panel: taking control of the arm needs this token")
    p.add_argument("--tip", help="URDF only: keep the chain to this link")
    add_json(p)
    p.set_defaults(func=cmd_view)


# ---- argument helpers --------------------------------------------------------------------------
def frames_arg(args: argparse.Namespace) -> list[str]:
    """The frame names of ``--frames`` (default ``tool``)."""
    if not args.frames:
        return ["tool"]
    return [n.strip() for item in args.frames for n in item.split(",") if n.strip()]


def _view(args: argparse.Namespace) -> tuple[View, Camera | None]:
    from armctl.render.draw import Camera, View, cameras_for

    view = View(args.view)
    if args.elev is None and args.azim is None:
        return view, None
    base = cameras_for(View.ISO if view is View.ALL else view)[0]
    elev = base.elev if args.elev is None else args.elev
    azim = base.azim if args.azim is None else args.azim
    if not (math.isfinite(elev) and math.isfinite(azim)):
        raise InputError(f"--elev and --azim must be finite angles in degrees, got {elev}, {azim}")
    return view, Camera(f"elev {elev:g}, azim {azim:g}", elev, azim)


def _target(args: argparse.Namespace) -> Target | None:
    from armctl.render.picture import Target

    if args.target_rpy is not None and args.target_xyz is None:
        raise InputError("--target-rpy needs --target-xyz (the target's position)")
    if args.target_xyz is None:
        return None
    values = [*args.target_xyz, *(args.target_rpy or ())]
    if not all(math.isfinite(v) for v in values):
        raise InputError(f"the target has a NaN or infinite value: {values}")
    check_rpy(args.target_rpy, args.deg, "--target-rpy")
    rpy = None
    if args.target_rpy is not None:
        import numpy as np

        rpy = np.radians(args.target_rpy) if args.deg else np.asarray(args.target_rpy)
    return Target.from_xyz_rpy(args.target_xyz, rpy)


def _q(args: argparse.Namespace, arm: Arm) -> np.ndarray:
    if args.q and args.pose:
        raise InputError("give joint values or --pose, not both")
    if args.q:
        return parse_angles(args.q, args.deg, arm)
    if args.pose:
        return arm.named_pose(args.pose)
    return arm.named_pose("home") if "home" in arm.spec.poses else arm.middle()


# ---- commands ----------------------------------------------------------------------------------
def cmd_render(args: argparse.Namespace) -> int:
    """Draw the arm in one pose, a planned straight-line move, or a keyframe playback."""
    from armctl.cli._scene import clearance_data, clearance_text, scene_arg
    from armctl.render.picture import pose_title, render_pose
    from armctl.render.scene import scene_drawing

    arm = load_arm_arg(args)
    scene = scene_arg(args, arm)  # --scene FILE
    view, camera = _view(args)
    target = _target(args)
    q = _q(args, arm)
    for name in ("size", "dpi", "fps"):
        value = getattr(args, name)
        if value is not None and not value > 0:
            raise InputError(f"--{name} must be positive, got {value}")
    if args.keyframes or args.path:
        return _render_motion(args, arm, q, view, camera, target, scene)
    drawing = None if args.no_scene else scene_drawing(arm, q, scene)
    pic = render_pose(arm, q, args.output, view=view, camera=camera, frames=frames_arg(args),
                      target=target, size=args.size or 5.0, dpi=args.dpi or 110.0,
                      scene=drawing, title=pose_title(arm, q, args.deg))  # Q's unit
    lines = [f"wrote {pic.path} ({', '.join(c.name for c in pic.cameras)})",
             "tool at x {} y {} z {} m".format(*(fmt(v) for v in pic.tool_position))]
    if drawing is not None:
        lines.append(clearance_text(drawing.clearance)
                     + (" (drawn red)" if drawing.in_contact else ""))
    if pic.target_distance is not None:
        lines.append(f"distance from the tool to the target: {fmt(pic.target_distance)} m")
    inside = arm.within_limits(q)
    if not inside:
        from armctl.errors import JointLimitError

        try:
            arm.check_limits(q)
        except JointLimitError as exc:
            lines.append("note: these joint values are outside the joint limits: "
                         + str(exc).split("; nothing was sent")[0])
    emit(args, {"output": str(pic.path), "q": q, "views": [c.name for c in pic.cameras],
                "tool_position": pic.tool_position, "target_distance": pic.target_distance,
                "within_limits": inside,
                "scene": None if drawing is None else {
                    "file": str(drawing.scene.file) if drawing.scene.file else None,
                    "obstacles": [o.name for o in drawing.obstacles],
                    "table": drawing.table_height is not None},
                "clearance": None if drawing is None else clearance_data(drawing.clearance)},
         "\n".join(lines))
    return 0


def _render_motion(args: argparse.Namespace, arm: Arm, q: np.ndarray, view: View,
                   camera: Camera | None, target: Target | None, scene: SceneSpec | None
                   ) -> int:
    """``render --keyframes`` and ``render --path``: plan (moving nothing), then draw.

    The scene (the config's, or ``scene`` from ``--scene``; none with ``--no-scene``) is drawn
    with the motion, and a pair in contact in red.
    """
    from pathlib import Path

    from armctl.cli._scene import clearance_data
    from armctl.collision import CollisionModel
    from armctl.render.animation import ANIMATION_SUFFIXES, render_animation
    from armctl.render.motions import plan_keyframes, plan_straight_line, sample_plan
    from armctl.render.picture import render_path
    from armctl.render.plots import IMAGE_SUFFIXES, check_output

    animate = Path(args.output).suffix.lower() in ANIMATION_SUFFIXES
    if args.keyframes and not animate:
        raise InputError(f"--keyframes draws an animation: give -o a .gif or .mp4 file, "
                         f"not {args.output!r}")
    check_output(args.output, ANIMATION_SUFFIXES if animate else IMAGE_SUFFIXES)
    line = None
    data: dict[str, Any] = {"output": args.output, "start": q}
    if args.keyframes:
        from armctl.cli._checks import check_keyframe_path

        check_keyframe_path(args.keyframes)
        plan = plan_keyframes(arm, args.keyframes, q, args.solver, args.speed)
        head = f"playback of {Path(args.keyframes).name}"
    else:
        if target is None:
            raise InputError("--path needs the goal: give --target-xyz (and --target-rpy for "
                             "an orientation)")
        planned = plan_straight_line(arm, q, target.pose, target.oriented, args.solver,
                                     args.speed)
        plan, line = planned.plan, planned.line
        head = f"straight line, {len(planned.samples)} IK samples"
        data["samples"] = len(planned.samples)
        if not animate:
            from armctl.collision.single import clearance_once
            from armctl.render.scene import scene_drawing

            drawing = (None if args.no_scene
                       else scene_drawing(arm, planned.samples[-1], scene))
            pic = render_path(arm, planned.samples, args.output, line=line, view=view,
                              camera=camera, target=target, size=args.size or 5.0,
                              scene=drawing)
            text = (f"wrote {pic.path}: {head}, {plan.duration:.2f} s; largest distance of a "
                    f"sample from the line {fmt((pic.max_deviation or 0.0) * 1e3, 3)} mm")
            first = None
            if drawing is not None:  # the first IK sample in contact, if any
                model = CollisionModel.of(arm, scene)
                for i, qi in enumerate(planned.samples):
                    c = clearance_once(model, qi)
                    if c is not None and c.margin < 0.0:
                        first = {"sample": i, **(clearance_data(c) or {})}
                        text += (f"\nIK sample {i} of {len(planned.samples) - 1} is in "
                                 f"contact: {_contact_words(c)}")
                        break
            data.update(max_deviation=pic.max_deviation, duration=plan.duration,
                        goal=plan.goal, first_contact=first,
                        clearance=None if drawing is None else clearance_data(drawing.clearance))
            emit(args, data, text)
            return 0
    ts, qs = sample_plan(plan, max(args.fps, 1.0) * 2.0)
    checker = None if args.no_scene else CollisionModel.of(arm, scene)
    res = render_animation(arm, qs, ts, args.output, fps=args.fps, view=view, camera=camera,
                           frames=frames_arg(args), target=target, line=line,
                           size=args.size or 4.5, dpi=args.dpi or 80.0,
                           title=f"{arm.name}: {head}", scene=checker)
    data.update(frames=res.frames, fps=res.fps, duration=res.duration, goal=plan.goal,
                contact_frames=res.contact_frames,
                first_contact=None if res.first_contact is None else {
                    "time": res.first_contact_time, **(clearance_data(res.first_contact) or {})})
    text = (f"wrote {res.path}: {head}, {res.duration:.2f} s, {res.frames} frames "
            f"at {res.fps:.3g} fps (planned only; nothing moved)")
    if res.first_contact is not None:
        frames = ("1 frame shows" if res.contact_frames == 1
                  else f"{res.contact_frames} frames show")
        text += (f"\n{frames} a contact (drawn red), the first at "
                 f"t={res.first_contact_time:.2f} s: {_contact_words(res.first_contact)}")
    emit(args, data, text)
    return 0


def _contact_words(c: Clearance | None) -> str:
    """``'a' and 'b' overlap by 3.0 mm`` (or come within the padding)."""
    if c is None:
        return "-"
    if c.distance < 0.0:
        return f"{c.pair} overlap by {-c.distance * 1000:.1f} mm"
    return f"{c.pair} come within {c.distance * 1000:.1f} mm (padding {c.padding * 1000:.1f} mm)"


def cmd_workspace(args: argparse.Namespace) -> int:
    """Sample and plot the reachable workspace."""
    from armctl.render.plots import check_output
    from armctl.render.workspace import plot_workspace, sample_workspace

    arm = load_arm_arg(args)
    check_output(args.output)
    ws = sample_workspace(arm, args.samples, args.frame, args.seed, args.voxel)
    plot = plot_workspace(ws, args.output, z_slice=args.z, y_slice=args.y, slab=args.slab)
    rows = [[axis, fmt(lo), fmt(hi), fmt(hi - lo)]
            for axis, lo, hi in zip("xyz", ws.lower, ws.upper, strict=True)]
    hull = "-" if ws.hull_volume is None else f"{ws.hull_volume:.4g} m^3"
    text = "\n".join([
        f"workspace of {ws.frame!r} on arm {arm.name!r}: {len(ws.points)} samples "
        f"(seed {args.seed})",
        table(["axis", "min [m]", "max [m]", "extent [m]"], rows, right=[1, 2, 3]),
        f"largest distance from the base origin: {fmt(ws.max_reach)} m",
        f"volume: {ws.voxel_volume:.4g} m^3 from occupied {fmt(ws.voxel, 3)} m voxels (surface "
        "voxels half); "
        f"convex hull {hull}",
        f"wrote {plot.path} (x-y slice at z = {fmt(plot.z_slice, 3)} m, x-z slice at "
        f"y = {fmt(plot.y_slice, 3)} m, slab {fmt(plot.slab, 3)} m)",
    ])
    emit(args, {"output": str(plot.path), "frame": ws.frame, "samples": len(ws.points),
                "seed": args.seed, "lower": ws.lower, "upper": ws.upper,
                "max_reach": ws.max_reach, "voxel": ws.voxel, "voxel_volume": ws.voxel_volume,
                "hull_volume": ws.hull_volume, "z_slice": plot.z_slice, "y_slice": plot.y_slice,
                "slab": plot.slab}, text)
    return 0


def _bus_reader(arm: Arm, port: str | None, sim: bool) -> tuple[Any, LiveWatcher | None]:
    """The bus the view follows, opened, or the live state of the armctl command that owns it.

    Returns:
        ``(bus, None)``, or ``(None, watcher)`` when another armctl command owns the port.
    """
    from armctl.cli._watch import port_owner
    from armctl.robot.bus_choice import arm_on_bus
    from armctl.servo import ArmBus
    from armctl.servo.calibration import load_calibration
    from armctl.servo.errors import PortError

    if arm.spec.bus is None and not sim:
        raise InputError(f"arm {arm.name!r} has no 'bus:' section, so there is no bus to follow;"
                         " add one to the arm config, use --sim, or run the view without --bus")
    spec = arm_on_bus(arm, port, sim).spec
    assert spec.bus is not None  # arm_on_bus gave it one  # mypy.
    owner = port_owner(spec.bus, None)
    if owner is not None:
        return None, owner
    bus = ArmBus.from_spec(spec, load_calibration(arm.spec))
    try:
        return bus.open(), None
    except PortError as exc:
        owner = port_owner(spec.bus, exc)
        if owner is None:
            raise
        return None, owner


def view_arm(arm: Arm, bus: Any = None) -> Arm:
    """The arm as the live view shows it: sliders and IK inside its effective limits.

    Those are the config's limits, narrowed by the calibration (when the arm has a calibration
    file) and, with an open :class:`~armctl.servo.ArmBus`, by the servos' position limit
    registers.
    """
    from armctl.servo.calibration import load_calibration
    from armctl.servo.effective_limits import effective_limits, limits_of_bus

    if bus is not None:
        return limits_of_bus(arm.spec, bus).apply(arm)
    return effective_limits(arm.spec, load_calibration(arm.spec)).apply(arm)


def cmd_view(args: argparse.Namespace) -> int:
    """Serve the live view until interrupted."""
    from armctl.cli._panel import choose_http_port, say_http_port, serve_panel, warn_exposed
    from armctl.cli._watch import OwnerFollower, check_same_arm
    from armctl.render.live import LiveView

    if args.port is not None and args.port.strip().isdigit():
        raise InputError(f"--port {args.port}: --port names the servo bus port the view follows "
                         "(a device such as /dev/ttyACM0, or the pty of 'armctl sim'); the web "
                         f"server's TCP port is --http-port {args.port.strip()}")
    arm = load_arm_arg(args)
    choose_http_port(args)
    if args.rate <= 0:
        raise InputError(f"--rate must be positive, got {args.rate}")
    control = (args.bus or args.sim or args.port is not None) and not args.watch
    warn_exposed(args.host, args.token, control)
    if control:  # the control panel, unless another armctl command owns the port
        code = serve_panel(args, arm)
        if code is not None:
            return code
    bus, owner = (_bus_reader(arm, args.port, args.sim)
                  if args.bus or args.sim or args.port is not None else (None, None))
    try:
        arm = view_arm(arm, bus)
        if owner is not None:
            check_same_arm(owner.hello, arm.name, arm.joint_names)
    except BaseException:
        if bus is not None:
            bus.close()
        if owner is not None:
            owner.close()
        raise
    view = LiveView(arm, args.host, args.http_port, args.solver)
    follower = None
    try:
        url = view.start()
        say_http_port(args, view.port)
        if bus is not None:
            view.follow(bus.read_joints, args.rate)
        elif owner is not None:
            say = None if args.json else print
            follower = OwnerFollower(owner, arm.name, arm.joint_names, view.q, say)
            view.follow(follower.read, args.rate)
        bus_port = (bus.spec.port if bus is not None else
                    owner.hello.port if owner is not None else None)
        emit(args, {"url": url, "http_port": view.port,
                    "bus": bus is not None or owner is not None, "bus_port": bus_port,
                    "attached": None if owner is None else owner.hello.as_json()},
             f"live view of {arm.name!r} at {url} (Ctrl-C stops)")
        sys.stdout.flush()
        end = math.inf if args.duration is None else time.monotonic() + args.duration
        while time.monotonic() < end:
            time.sleep(min(0.2, max(end - time.monotonic(), 0.0)))
    finally:
        view.stop()
        if bus is not None:
            bus.close()
        if follower is not None:
            follower.close()
        elif owner is not None:
            owner.close()
    return 0
