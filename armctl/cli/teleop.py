"""The teleop command: a follower arm copies a leader arm moved by hand."""

from __future__ import annotations

import argparse
import sys
from typing import TYPE_CHECKING, Any

from armctl.cli._common import add_json, emit, finite, positive
from armctl.cli._parser import add_later
from armctl.errors import InputError

if TYPE_CHECKING:
    from armctl.arm import Arm
    from armctl.robot.teleop import JointScale, TeleopStats

ORDER = 43


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add the teleop command."""
    p = sub.add_parser(
        "teleop", help="a follower arm copies a leader arm moved by hand",
        description="The leader's torque goes off; the follower first moves to the leader's "
        "pose (planned, jerk-limited, at --start-speed), then follows it: one sync read of the "
        "leader and one sync write of the follower every cycle, joints paired by name, every "
        "command clamped into the follower's effective limits and rate-limited by its velocity "
        "and acceleration limits. Ctrl-C stops the follower under control; it holds.")
    p.add_argument("leader", metavar="LEADER", help="leader arm config or bundled name "
                   "(e.g. so101_leader, koch_leader)")
    p.add_argument("follower", metavar="FOLLOWER", help="follower arm config or bundled name "
                   "(e.g. so101, koch_follower)")
    add_later(p, _arguments)
    p.set_defaults(func=cmd_teleop, stop_signals=True)


def _arguments(p: argparse.ArgumentParser) -> None:
    p.add_argument("--rate", type=positive, default=100.0, metavar="HZ",
                   help="loop rate (default 100 Hz)")
    p.add_argument("--start-speed", type=finite, default=0.3, metavar="S",
                   help="speed factor of the first move to the leader's pose (default 0.3)")
    p.add_argument("--speed", type=finite, default=1.0, metavar="S",
                   help="factor of the follower's velocity limits while following (default 1)")
    p.add_argument("--scale", action="append", default=[], metavar="JOINT=SCALE[:OFFSET]",
                   help="map a joint as follower = SCALE * leader + OFFSET (offset in rad or "
                        "m); repeat for more joints")
    p.add_argument("--scales", metavar="FILE.yaml",
                   help="joint scales from a file: {joint: {scale: S, offset: O}}")
    p.add_argument("--duration", type=positive, default=None, metavar="S",
                   help="stop after this many seconds (default: at Ctrl-C)")
    p.add_argument("--record", metavar="FILE.yaml",
                   help="record the follower into a keyframe file that 'armctl play' replays: "
                        "a keyframe at every Enter (type a name first to name it), or with "
                        "--every a continuous trajectory")
    p.add_argument("--every", type=positive, default=None, metavar="MS",
                   help="with --record: sample a trajectory every MS milliseconds (10-1000)")
    p.add_argument("--force", action="store_true", help="overwrite an existing --record file")
    p.add_argument("--leader-as-follower", action="store_true",
                   help="drive a FOLLOWER whose config says 'role: leader' (refused otherwise: "
                        "a leader arm is moved by hand, and LEADER and FOLLOWER may be swapped)")
    p.add_argument("--leader-port", metavar="PORT", default=None,
                   help="the leader's port instead of its config's (a device, or the pty of "
                        "'armctl sim')")
    p.add_argument("--follower-port", metavar="PORT", default=None,
                   help="the follower's port instead of its config's")
    p.add_argument("--sim", action="store_true",
                   help="both arms on the built-in simulated bus")
    p.add_argument("--scene", metavar="FILE", default=None,
                   help="scene file (table, obstacles, padding; docs/config.md) that the "
                        "follower is kept out of, instead of its config's 'scene:' section")
    add_json(p)


def _scales(args: argparse.Namespace) -> dict[str, JointScale]:
    from armctl.robot.teleop import load_joint_scales, parse_joint_scale

    out = load_joint_scales(args.scales) if args.scales else {}
    for text in args.scale:
        try:
            name, scale = parse_joint_scale(text)
        except InputError as exc:
            raise InputError(f"--scale: {exc}") from None
        out[name] = scale
    return out


def _arm(config: str, port: str | None, sim: bool, option: str) -> Arm:
    from armctl.arm import load_arm
    from armctl.cli._bus_choice import arm_on_chosen_bus

    if port is not None and sim:
        raise InputError(f"{option} and --sim exclude each other")
    return arm_on_chosen_bus(argparse.Namespace(port=port, sim=sim), load_arm(config))


def _check_roles(leader: Arm, follower: Arm, leader_as_follower: bool) -> None:
    """Refuse a leader arm as FOLLOWER; warn about a LEADER that is not a leader arm.

    The configs say which arms are leaders (``role: leader``). Teleoperation switches the
    LEADER's torque off: a follower given as LEADER goes limp, and a leader given as FOLLOWER
    is driven by servos made to be moved by hand.

    Raises:
        InputError: FOLLOWER is a leader arm and ``--leader-as-follower`` is not given; says
            whether the two look swapped and the command line that has them the right way.
    """
    from armctl.config.schema import ArmRole

    def where(arm: Arm) -> str:
        return f"its config {arm.spec.file} says" if arm.spec.file else "its config says"

    is_leader = leader.spec.role is ArmRole.LEADER
    if follower.spec.role is ArmRole.LEADER and not leader_as_follower:
        if not is_leader:
            raise InputError(
                f"LEADER and FOLLOWER look swapped: FOLLOWER {follower.name!r} is a leader arm "
                f"({where(follower)} 'role: leader') and LEADER {leader.name!r} is not; the "
                f"leader comes first: 'armctl teleop {follower.name} {leader.name}' (or add "
                "--leader-as-follower to drive the leader arm anyway)")
        raise InputError(
            f"FOLLOWER {follower.name!r} is a leader arm ({where(follower)} 'role: leader'): "
            "its servos are made to be moved by hand; give a follower arm as FOLLOWER (or add "
            "--leader-as-follower to drive it anyway)")
    if not is_leader:
        print(f"armctl: warning: LEADER {leader.name!r} is not a leader arm (its config has no "
              "'role: leader'): its torque goes off and it is moved by hand; support it",
              file=sys.stderr, flush=True)


def _servo_joints(arm: Arm) -> list[str]:
    """The joints of an arm that have a servo (from its config's ``bus:`` section).

    Raises:
        InputError: The arm has no ``bus:`` section.
    """
    if arm.spec.bus is None:
        raise InputError(f"arm {arm.name!r} has no 'bus:' section: teleoperation drives servos; "
                         f"{arm.spec.no_bus_fix()}")
    return [s.joint for s in arm.spec.bus.servos]


def _status(tele: Any, rate_hz: float) -> Any:
    """A callback that rewrites one status line on the terminal about twice a second."""
    every = max(1, round(rate_hz / 2))

    def show(c: Any) -> None:
        if round(c.t * rate_hz) % every:
            return
        clamped = sum(tele.clamped.values())
        limited = sum(tele.rate_limited.values())
        waits = f"  waiting: {c.blocked}" if c.blocked else ""
        print(f"\r  {c.t:7.1f} s  clamped {clamped}  rate-limited {limited}{waits}   ", end="",
              file=sys.stderr, flush=True)

    return show


def cmd_teleop(args: argparse.Namespace) -> int:
    """``armctl teleop LEADER FOLLOWER``."""
    from armctl.cli._scene import scene_arg
    from armctl.cli._teleop_keys import read_keyframe_keys
    from armctl.config.motion import ExitPolicy
    from armctl.robot import Robot
    from armctl.robot.teach import ExistingFile, check_output
    from armctl.robot.teleop import Teleop, TeleopOptions, TeleopRecorder, paired_joints

    if args.every is not None and not args.record:
        raise InputError("--every needs --record FILE.yaml")
    options = TeleopOptions(rate_hz=args.rate, start_speed=args.start_speed, speed=args.speed,
                            scales=_scales(args), duration=args.duration)
    existing = ExistingFile.OVERWRITE if args.force else ExistingFile.REFUSE
    period = args.every / 1000.0 if args.every is not None else None
    if args.record:  # before anything opens
        TeleopRecorder.check_period(period)
        check_output(args.record, existing, can_append=False)
    if args.leader_port and args.leader_port == args.follower_port:
        raise InputError(f"--leader-port and --follower-port are both {args.leader_port}: the "
                         "leader and the follower need a bus each (two adapters, or two "
                         "'armctl sim' ports)")
    leader_arm = _arm(args.leader, args.leader_port, args.sim, "--leader-port")
    follower_arm = _arm(args.follower, args.follower_port, args.sim, "--follower-port")
    _check_roles(leader_arm, follower_arm, args.leader_as_follower)  # before any bus opens
    paired_joints(leader_arm.name, _servo_joints(leader_arm), follower_arm.name,
                  _servo_joints(follower_arm), options.scales)  # before any bus opens
    scene = scene_arg(args, follower_arm)  # --scene FILE: the follower's
    say = (lambda s: None) if args.json else (lambda s: print(s, file=sys.stderr, flush=True))
    leader = Robot.open(leader_arm, hold=False, exit_policy=ExitPolicy.HOLD)
    try:
        follower = Robot.open(follower_arm, exit_policy=ExitPolicy.HOLD, scene=scene)
    except BaseException:
        leader.close(ExitPolicy.HOLD)
        raise
    stats: TeleopStats | None = None
    try:
        recorder = None
        if args.record:
            recorder = TeleopRecorder(follower, args.record, period, existing)
        tele = Teleop(leader, follower, options, recorder)
        if leader.simulated or follower.simulated:
            say("--- SIMULATED BUS: no hardware ---")
        unpaired = f"; holding {', '.join(tele.unpaired)}" if tele.unpaired else ""
        say(f"teleop {leader.arm.name} -> {follower.arm.name}: {', '.join(tele.joints)}"
            f"{unpaired}\n  leader torque off; moving the follower to the leader's pose ...")
        tele.start()
        say(f"  following at {options.rate_hz:g} Hz; Ctrl-C stops (the follower holds)")
        if recorder is not None and recorder.period is None:
            say("  press Enter to record a keyframe (type a name first to name it)")
            read_keyframe_keys(recorder, say)
        live = not args.json and sys.stderr.isatty()
        try:
            stats = tele.run(_status(tele, options.rate_hz) if live else None)
        finally:
            if live:
                print(file=sys.stderr)  # end the status line
        guard = getattr(args, "signal_guard", None)
        if guard is not None and stats.stopped_by:  # Ctrl-C is how teleoperation ends
            guard.stopped_by = None
    except BaseException:
        follower.close_holding("teleoperation ended with an error")
        leader.close(ExitPolicy.HOLD)
        raise
    follower.close(ExitPolicy.HOLD)
    leader.close(ExitPolicy.HOLD)
    _report(args, tele, stats)
    return 0


def _report(args: argparse.Namespace, tele: Any, stats: TeleopStats) -> None:
    rec = tele.recorder
    data = {**tele.summary(), "rate_hz": stats.rate_hz, "cycles": stats.cycles,
            "achieved_rate_hz": round(stats.achieved_rate, 2), "dropped_cycles": stats.dropped,
            "latency_median_ms": round(stats.latency_median * 1000, 3),
            "latency_p99_ms": round(stats.latency_p99 * 1000, 3),
            "clamped": stats.clamped, "rate_limited": stats.rate_limited,
            "blocked": stats.blocked,
            "stopped_by": stats.stopped_by or "duration",
            "record": None if rec is None else {"file": str(rec.path),
                                                "keyframes": stats.recorded,
                                                "written": rec.written}}
    lines = [f"{stats.cycles} cycles in {stats.elapsed:.2f} s ({stats.achieved_rate:.1f} Hz, "
             f"{stats.dropped} dropped); leader read to follower write "
             f"{stats.latency_median * 1000:.2f} ms median, {stats.latency_p99 * 1000:.2f} ms p99"]
    for what, counts in (("clamped to the effective limits", stats.clamped),
                         ("rate-limited", stats.rate_limited),
                         ("held back by a contact ahead", stats.blocked)):
        if counts:
            lines.append(f"{what} (cycles): " + ", ".join(f"{n} {c}" for n, c in counts.items()))
    if rec is not None:
        lines.append(f"{stats.recorded} keyframes in {rec.path}" if rec.written else
                     f"nothing was recorded; {rec.path} was not written")
    if stats.stopped_by:
        lines.append(f"stopped by {stats.stopped_by}: the follower decelerated within its limits")
    lines.append("the follower holds (torque on); the leader's torque is off")
    emit(args, data, "\n".join(lines))
