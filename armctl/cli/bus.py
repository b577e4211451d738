"""Servo bus commands: ``ports``, ``scan``, ``status``, ``torque``, ``sim``, ``calibrate``."""

from __future__ import annotations

import argparse
import json
import math
import sys
import time
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any

from armctl.cli._common import (
    JSON_SCHEMA,
    add_config,
    add_json,
    emit,
    fmt,
    json_safe,
    positive,
    table,
)
from armctl.cli._scene import add_scene_option
from armctl.errors import BusError, InputError, UnknownNameError

if TYPE_CHECKING:
    from armctl.config.scene import SceneSpec
    from armctl.config.schema import ArmSpec
    from armctl.kinematics.model import KinematicModel
    from armctl.servo import ArmBus, JointState
    from armctl.servo.effective_limits import EffectiveLimits

ORDER = 50

_DXL_BAUDS = (57_600, 1_000_000, 115_200, 2_000_000, 3_000_000, 4_000_000, 9_600)
_FT_BAUDS = (1_000_000, 500_000, 250_000, 128_000, 115_200, 57_600, 38_400)


def register(sub: argparse._SubParsersAction) -> None:
    """Add the bus commands."""
    p = sub.add_parser("ports", help="list serial ports (USB adapters) with their descriptions")
    add_json(p)
    p.set_defaults(func=cmd_ports)

    p = sub.add_parser("scan", help="find the servos on a port: ids, models, firmware")
    p.add_argument("--port", required=True, help="serial port, e.g. /dev/ttyACM0")
    p.add_argument("--protocol", choices=["dynamixel", "feetech", "dynamixel1"],
                   help="wire protocol (default: try dynamixel and feetech; dynamixel1 = "
                        "Dynamixel Protocol 1.0, pinged id by id)")
    p.add_argument("--baud", default="1000000",
                   help="baud rate in bit/s, or 'all' to try every standard rate")
    add_json(p)
    p.set_defaults(func=cmd_scan)

    p = sub.add_parser("status", help="live table of the servos: angle, ticks, temperature, "
                                      "voltage, load, errors",
                       description="Read the servos and show them live. When another armctl "
                       "command owns the port (a move, playback, teaching, teleoperation), "
                       "show that command's live state instead (it goes on undisturbed).")
    add_config(p)
    where = p.add_mutually_exclusive_group()
    where.add_argument("--port", help="read the servos on this port instead of the config's (a "
                                      "device, or the pty of 'armctl sim'); when another armctl "
                                      "command owns it, watch that command")
    where.add_argument("--sim", action="store_true",
                       help="read the built-in simulated bus (also for a config without a "
                            "'bus:' section)")
    p.add_argument("--no-calibration", action="store_true", help="ignore the calibration file")
    p.add_argument("--once", action="store_true", help="print one reading and exit")
    p.add_argument("--follow", "--watch", action="store_true",
                   help="with --json: print one JSON line per refresh until Ctrl-C (or until "
                        "the watched command releases the port)")
    p.add_argument("--interval", type=positive, default=0.2, help="refresh period [s]")
    p.add_argument("--deg", action="store_true", help="show rotary joints in degrees")
    add_scene_option(p)  # --scene FILE: the clearance is measured in it
    add_json(p)
    p.set_defaults(func=cmd_status)

    p = sub.add_parser("torque", help="switch servo torque on or off")
    add_config(p)
    p.add_argument("state", choices=["on", "off"])
    p.add_argument("joints", nargs="*", metavar="JOINT", help="joints (default: all)")
    p.add_argument("--clear-alarms", action="store_true",
                   help="first reboot the servos that report a hardware alarm (overload, "
                        "overheating...): clears it once the cause is removed")
    _add_bus_args(p)
    add_json(p)
    p.set_defaults(func=cmd_torque)

    p = sub.add_parser("sim", help="run the simulated bus standalone on a pty; type 'help' "
                                   "for its commands")
    add_config(p)
    p.add_argument("--wire-timing", action="store_true",
                   help="time replies as on a real line at the configured baud rate")
    p.add_argument("--scenario", help="fault scenario YAML to load (see docs/bus.md)")
    add_json(p)
    p.set_defaults(func=cmd_sim)

    p = sub.add_parser("calibrate", help="measure zero offsets and ranges; writes the "
                                         "calibration file beside the config")
    add_config(p)
    # no --sim: a calibration of the built-in simulated bus would overwrite the arm's file
    _add_bus_args(p, calibrated=False, sim=False)
    p.add_argument("--reference", default="zero",
                   help="reference pose: 'zero' or the name of a pose in the config")
    p.add_argument("-o", "--output", help="calibration file (default: beside the config)")
    lerobot = p.add_mutually_exclusive_group()
    lerobot.add_argument("--from-lerobot", metavar="FILE.json",
                         help="import a LeRobot calibration file instead of measuring (no bus "
                              "needed); writes the armctl calibration file")
    lerobot.add_argument("--to-lerobot", metavar="FILE.json",
                         help="export the arm's calibration file as a LeRobot calibration file "
                              "(no bus needed)")
    p.add_argument("--calibration", metavar="FILE",
                   help="with --to-lerobot: the armctl calibration to export (default: the "
                        "one beside the config)")
    p.add_argument("--force", action="store_true",
                   help="with --from-lerobot or --to-lerobot: overwrite an existing output file")
    add_json(p)
    p.set_defaults(func=cmd_calibrate)


def _add_bus_args(p: argparse.ArgumentParser, calibrated: bool = True,
                  sim: bool = True) -> None:
    """``--port`` (and ``--sim`` unless ``sim`` is false) of a servo command."""
    if sim:
        where = p.add_mutually_exclusive_group()
        where.add_argument("--port",
                           help="override the config's port (e.g. the pty of 'armctl sim')")
        where.add_argument("--sim", action="store_true",
                           help="use the built-in simulated bus (also for a config without a "
                                "'bus:' section)")
    else:
        p.add_argument("--port", help="override the config's port (e.g. the pty of 'armctl sim')")
    if calibrated:
        p.add_argument("--no-calibration", action="store_true",
                       help="ignore the calibration file")


# ---- helpers ----------------------------------------------------------------------------------
def _spec(args: argparse.Namespace) -> ArmSpec:
    from dataclasses import replace

    from armctl.config import load_spec

    spec = load_spec(args.config)
    if getattr(args, "sim", False):
        from armctl.config.bus import SIM_PORT
        from armctl.robot.bus_choice import simulated_bus_spec

        bus = simulated_bus_spec(spec) if spec.bus is None else replace(spec.bus, port=SIM_PORT)
        return replace(spec, bus=bus)
    if spec.bus is None:
        raise InputError(f"arm {spec.name!r} has no 'bus:' section; "
                         f"{spec.no_bus_fix(sim=hasattr(args, 'sim'))}")
    if getattr(args, "port", None):
        spec = replace(spec, bus=replace(spec.bus, port=args.port))
    return spec


def _arm_bus(args: argparse.Namespace) -> ArmBus:
    from armctl.servo import ArmBus
    from armctl.servo.calibration import Calibration, calibration_path, check_against

    spec = _spec(args)
    cal = None
    if not getattr(args, "no_calibration", True) and spec.file is not None:
        path = calibration_path(spec)
        if path.exists():
            cal = Calibration.load(path)
            check_against(cal, spec)
    return ArmBus.from_spec(spec, cal)


def _unknown_joint(name: str, valid: tuple[str, ...], context: str) -> UnknownNameError:
    """The error for a joint name that has no servo, suggesting the nearest valid name."""
    return UnknownNameError("servo joint", name, valid, context)


def _is_rotary(ab: ArmBus, name: str) -> bool:
    from armctl.config.schema import JointType

    return ab.mapping.joint(name).joint_type is not JointType.PRISMATIC


# ---- ports and scan -----------------------------------------------------------------------------
def cmd_ports(args: argparse.Namespace) -> int:
    """List serial ports."""
    from serial.tools import list_ports

    rows, data = [], []
    for p in sorted(list_ports.comports(), key=lambda p: p.device):
        desc = p.description if p.description and p.description != "n/a" else ""
        rows.append([p.device, desc, p.manufacturer or "", p.hwid or ""])
        data.append({"device": p.device, "description": desc,
                     "manufacturer": p.manufacturer, "hwid": p.hwid})
    text = table(["port", "description", "manufacturer", "hwid"], rows) if rows else (
        "no serial ports found (is the adapter plugged in? 'port: sim' needs none)")
    emit(args, {"ports": data}, text)
    return 0


def cmd_scan(args: argparse.Namespace) -> int:
    """Find servos on a port."""
    from armctl.config.bus import Protocol
    from armctl.servo import ServoBus
    from armctl.servo.errors import PortError

    protocols = [Protocol(args.protocol)] if args.protocol else [Protocol.DYNAMIXEL,
                                                                 Protocol.FEETECH]
    rows, data = [], []
    tried: list[str] = []
    for protocol in protocols:
        bauds: tuple[int, ...] = _FT_BAUDS if protocol is Protocol.FEETECH else _DXL_BAUDS
        if args.baud != "all":
            try:
                bauds = (int(args.baud),)
            except ValueError:
                raise InputError(f"--baud: {args.baud!r} is not a number or 'all'") from None
        for baud in bauds:
            bus = ServoBus(args.port, protocol, baud, latency_ms=16.0)
            try:
                bus.open()
            except PortError as exc:
                if "refuses" in str(exc):
                    continue
                raise
            try:
                found = bus.scan()
                firmware = {f.servo_id: _firmware(bus, f) for f in found}
            finally:
                bus.close()
            for f in found:
                fw = firmware[f.servo_id]
                rows.append([protocol.value, str(baud), str(f.servo_id), str(f.model_number),
                             f.model or "?", fw or "-"])
                data.append({"protocol": protocol.value, "baudrate": baud, "id": f.servo_id,
                             "model_number": f.model_number, "model": f.model,
                             "firmware": fw})
            tried.append(f"{', '.join(str(b) for b in bauds)} bit/s ({protocol.value})")
    if not rows:
        raise BusError(f"no servos answered on {args.port} at {'; '.join(tried) or args.baud} "
                       "(check power, wiring, baud rate, protocol)")
    headers = ["protocol", "baud", "id", "model#", "model", "firmware"]
    if all(d["firmware"] is None for d in data):  # no model here reports its firmware
        headers, rows = headers[:-1], [r[:-1] for r in rows]
    emit(args, {"port": args.port, "servos": data}, table(headers, rows, [1, 2, 3]))
    return 0


def _firmware(bus: Any, found: Any) -> str | None:
    """The firmware version of a found servo, ``None`` when unknown.

    From its ping when the protocol reports it, else read from its control table's firmware
    registers (``major.minor`` where the table has both).
    """
    from armctl.servo.errors import ServoBusError
    from armctl.servo_tables import Register, table_for

    if found.firmware is not None:
        return str(found.firmware)
    if found.model is None:
        return None
    tab = table_for(found.model)
    if Register.FIRMWARE not in tab.registers:
        return None
    bus.tables[found.servo_id] = tab
    try:
        major = bus.read(found.servo_id, Register.FIRMWARE)
        if Register.FIRMWARE_MINOR in tab.registers:
            return f"{major}.{bus.read(found.servo_id, Register.FIRMWARE_MINOR)}"
        return str(major)
    except ServoBusError:
        return None


# ---- status and torque --------------------------------------------------------------------------
def _status_rows(ab: ArmBus, st: JointState, deg: bool) -> tuple[list[list[str]], list[dict]]:
    rows, data = [], []
    for i, name in enumerate(st.names):
        j = ab.mapping.joint(name)
        q = float(st.position[i])
        shown = fmt(math.degrees(q), 2) if deg and _is_rotary(ab, name) else fmt(q, 4)
        errs = ",".join(a.value for a in st.errors[i]) or "-"
        amps = float(st.current[i])  # NaN: the servo's feedback holds no current
        rows.append([name, str(j.servo_id), shown, str(int(st.ticks[i])),
                     fmt(float(st.temperature[i]), 0), fmt(float(st.voltage[i]), 1),
                     fmt(100 * float(st.load[i]), 1), "-" if math.isnan(amps) else fmt(amps, 3),
                     errs])
        data.append({"joint": name, "id": j.servo_id, "position": q, "ticks": int(st.ticks[i]),
                     "velocity": float(st.velocity[i]),
                     "temperature": float(st.temperature[i]), "voltage": float(st.voltage[i]),
                     "load": float(st.load[i]), "current": None if math.isnan(amps) else amps,
                     "errors": [a.value for a in st.errors[i]]})
    return rows, data


def _limit_rows(eff: EffectiveLimits, deg: bool) -> list[list[str]]:
    """One row per joint: config, calibration, servo register and effective limits."""
    from armctl.config.schema import JointType

    rows = []
    for j in eff.joints:
        prismatic = j.joint_type is JointType.PRISMATIC
        k = math.degrees(1.0) if deg and not prismatic else 1.0
        digits = 5 if prismatic else 3 if deg else 4

        def span(r: tuple[float, float] | None, k: float = k, d: int = digits) -> str:
            return "-" if r is None else f"{fmt(r[0] * k, d)} .. {fmt(r[1] * k, d)}"

        if j.register_ticks is None:
            regs = "-"
        else:
            lo, hi = j.register_ticks
            regs = ("no limit" if j.register is None else span(j.register)) + \
                f" ({lo}..{hi} ticks)"
        rows.append([j.name, "-" if j.servo_id is None else str(j.servo_id), span(j.config),
                     span(j.calibration), regs, span((j.lower.value, j.upper.value)),
                     f"{j.lower.source.value} / {j.upper.source.value}"])
    return rows


def _tool_pose(model: KinematicModel, st: JointState) -> dict[str, Any] | None:
    """Pose of the tool frame at the read joints (FK).

    ``None`` if a joint that moves the tool has no servo reading.

    Returns:
        ``{"frame", "xyz" [m], "rpy" [rad]}`` in the base frame.
    """
    from armctl.spatial import matrix_to_rpy

    read = dict(zip(st.names, (float(x) for x in st.position), strict=True))
    q = [read.get(n, math.nan) for n in model.joint_names]  # NaN: not on the bus
    pose = model.fk(q)
    if not all(math.isfinite(float(x)) for x in pose[:3, :].flat):
        return None
    return {"frame": model.frame_names[model.frame_index(None)],
            "xyz": [float(x) for x in pose[:3, 3]],
            "rpy": [float(x) for x in matrix_to_rpy(pose[:3, :3])]}


def _tool_text(tool: dict[str, Any] | None) -> str:
    if tool is None:
        return "tool pose: - (a joint that moves the tool has no servo)"
    xyz = " ".join(fmt(v, 4) for v in tool["xyz"])
    rpy = " ".join(fmt(math.degrees(v), 2) for v in tool["rpy"])
    return f"tool {tool['frame']!r}: xyz [m] {xyz}   rpy [deg] {rpy}"


def _clearance(model: KinematicModel, st: JointState, scene: SceneSpec | None
               ) -> tuple[dict[str, Any] | None, str]:
    """The least clearance at the read joints: JSON fields and the text line.

    ``None`` and a dash when a joint of the arm has no servo reading.
    """
    from armctl.cli._scene import clearance_data, clearance_text, scene_clearance

    read = dict(zip(st.names, (float(x) for x in st.position), strict=True))
    q = [read.get(n, math.nan) for n in model.joint_names]
    if not all(math.isfinite(v) for v in q):
        return None, "clearance: - (a joint has no servo reading)"
    c = scene_clearance(model, q, scene)
    return clearance_data(c), clearance_text(c)


def cmd_status(args: argparse.Namespace) -> int:
    """Show servo status, once or live."""
    from armctl.cli._scene import scene_arg
    from armctl.cli._watch import check_same_arm, port_owner, watch_owner
    from armctl.kinematics.model import KinematicModel
    from armctl.servo.effective_limits import limits_of_bus
    from armctl.servo.errors import PortError

    unit = "deg" if args.deg else "rad|m"
    headers = ["joint", "id", f"angle [{unit}]", "ticks", "temp [C]", "volt [V]",
               "load [% stall]", "current [A]", "errors"]
    limit_headers = ["joint", "id", f"config [{unit}]", "calibration", "servo registers",
                     "effective", "bounded by (lower / upper)"]
    spec = _spec(args)
    model = KinematicModel(spec)
    scene = scene_arg(args, model)  # --scene FILE: the clearance is measured in it

    def pose_lines(names: Any, values: Any) -> tuple[Any, str, Any, str]:
        reading: Any = _Reading(tuple(names), tuple(values))
        tool = _tool_pose(model, reading)
        clearance, clearance_line = _clearance(model, reading, scene)
        return tool, _tool_text(tool), clearance, clearance_line

    # Another armctl command owns the port: show its live state (the port is left alone).
    assert spec.bus is not None  # _spec checked it  # mypy.
    watcher = port_owner(spec.bus, None)
    ab = _arm_bus(args)
    if watcher is None:
        try:
            ab.open()
        except PortError as exc:
            watcher = port_owner(spec.bus, exc)
            if watcher is None:
                raise
    if watcher is not None:
        try:
            check_same_arm(watcher.hello, spec.name, model.joint_names)
        except BaseException:
            watcher.close()
            raise
        return watch_owner(args, watcher, pose_lines)
    with ab:
        eff = limits_of_bus(spec, ab)
        limits = (f"limits [{unit}] (effective: inside all three, {eff.margin_ticks} servo "
                  "ticks inside the measured ones)\n"
                  + table(limit_headers, _limit_rows(eff, args.deg)))
        while True:
            st = ab.read_state()
            rows, data = _status_rows(ab, st, args.deg)
            tool = _tool_pose(model, st)
            clearance, clearance_line = _clearance(model, st, scene)
            text = (table(headers, rows, [1, 2, 3, 4, 5, 6, 7]) + "\n" + _tool_text(tool)
                    + "\n" + clearance_line + "\n\n" + limits)
            fields = {"arm": ab.arm_name, "port": ab.spec.port, "attached": False,
                      "joints": data, "tool": tool,
                      "clearance": clearance,
                      "calibration": ab.calibration.hash if ab.calibration else None,
                      "limits": eff.as_dict()}
            if args.once or (args.json and not args.follow):
                emit(args, fields, text)
                return 0
            if args.json:  # --follow: one JSON line per reading
                print(json.dumps(json_safe({"schema": JSON_SCHEMA, "command": args.command,
                                            "ok": True, **fields})),
                      flush=True)
                time.sleep(max(0.02, args.interval))
                continue
            sys.stdout.write("\x1b[H\x1b[2J" + f"{ab.arm_name} on {ab.spec.port} "
                             "(Ctrl-C to stop)\n\n" + text + "\n")
            sys.stdout.flush()
            # Ctrl-C leaves the live table: exit 130, "interrupted by SIGINT" (cli main)
            time.sleep(max(0.02, args.interval))


@dataclass(frozen=True)
class _Reading:
    """Joint values by name, as :func:`_tool_pose` and :func:`_clearance` read them."""

    names: tuple[str, ...]
    position: tuple[float, ...]


def cmd_torque(args: argparse.Namespace) -> int:
    """Switch torque on or off."""
    ab = _arm_bus(args)
    on = args.state == "on"
    joints = args.joints or list(ab.joint_names)
    for name in joints:
        if name not in ab.joint_names:
            raise _unknown_joint(name, ab.joint_names, f"arm {ab.arm_name!r}")
    with ab:
        ab.read_state()  # learns which servos report an alarm: torque on is refused for them
        cleared = ab.clear_alarms(joints) if args.clear_alarms else []
        if cleared:
            ab.read_state()  # an alarm whose cause remains comes back at once
        ab.set_torque(on, joints)
        state = ab.torque()
    text = f"torque {args.state}: {', '.join(joints)}"
    if cleared:
        text = f"alarms cleared (servo rebooted): {', '.join(cleared)}\n" + text
    emit(args, {"torque": {n: state[n] for n in joints}, "alarms_cleared": cleared}, text)
    return 0


# ---- standalone simulator -----------------------------------------------------------------------
def cmd_sim(args: argparse.Namespace) -> int:
    """Run the simulated bus standalone until 'quit', end of input or Ctrl-C.

    Every stdin line goes to :class:`~armctl.servo.sim.console.SimConsole`; a bad line prints
    an error line and the simulator (and its pty) carries on.
    """
    from armctl.cli._sim_loop import serve_console
    from armctl.servo import simulated_bus
    from armctl.servo.calibration import Calibration, calibration_path

    spec = _spec(args)
    assert spec.bus is not None  # _spec checked it  # mypy.
    cal = None
    if spec.file is not None and spec.bus.port == "sim" and calibration_path(spec).exists():
        cal = Calibration.load(calibration_path(spec))
    sim = simulated_bus(spec, cal, wire_timing=args.wire_timing)
    with sim:
        if args.scenario:
            sim.load_scenario(args.scenario)
        emit(args, {"port": sim.port, "protocol": spec.bus.protocol.value,
                    "baudrate": spec.bus.baudrate, "servos": [s.id for s in sim.servos]},
             f"simulated {spec.bus.protocol.value} bus for {spec.name} on {sim.port} at "
             f"{spec.bus.baudrate} baud (servo ids "
             f"{', '.join(str(s.id) for s in sim.servos)}); type 'help' for commands")
        sys.stdout.flush()
        return serve_console(sim)


# ---- calibration ---------------------------------------------------------------------------------
def cmd_calibrate(args: argparse.Namespace) -> int:
    """Interactive calibration: reference pose, range sweep, offsets, file."""
    from pathlib import Path

    from armctl.cli._calibrate_wizard import run_wizard
    from armctl.servo.calibrate import Calibrator
    from armctl.servo.calibration import calibration_path

    args.no_calibration = True
    spec = _spec(args)
    if (args.from_lerobot or args.to_lerobot) and args.reference != "zero":
        raise InputError("--reference is for measuring; a LeRobot calibration has its own zero "
                         "(the middle of each joint's range)")
    if args.from_lerobot:
        if args.calibration:
            raise InputError("--calibration goes with --to-lerobot; with --from-lerobot name "
                             "the file to write with -o")
        return _calibrate_from_lerobot(args, spec)
    if args.to_lerobot:
        if args.output:
            raise InputError("-o names the armctl calibration to write; with --to-lerobot the "
                             "output is FILE.json, and --calibration names the file to read")
        return _calibrate_to_lerobot(args, spec)
    if args.calibration or args.force:
        raise InputError("--calibration and --force go with --from-lerobot or --to-lerobot")
    if args.reference == "zero":
        reference: dict[str, float] = {}
    elif args.reference in spec.poses:
        reference = {name: value for name, value in spec.poses[args.reference].items()
                     if not isinstance(value, tuple)}  # servos drive 1-DOF joints only
    else:
        raise InputError(f"--reference: {args.reference!r} is neither 'zero' nor a pose of "
                         f"the arm ({', '.join(spec.poses) or 'none defined'})")
    out = Path(args.output) if args.output else calibration_path(spec)
    ab = _arm_bus(args)
    with ab:
        cal = Calibrator(ab, reference)
        run_wizard(cal, args.reference)
        result = cal.finish()
    if not args.output:
        out.parent.mkdir(parents=True, exist_ok=True)
    kept = keep_previous(out)
    path = result.save(out)
    _print_calibration(args, result, path, kept)
    return 0


def keep_previous(path: Any) -> Any:
    """Copy an existing calibration file aside (``NAME.previous.yaml``) before it is replaced.

    Returns:
        The copy's path, or ``None`` when there was no file.
    """
    import shutil
    from pathlib import Path

    path = Path(path)
    if not path.exists():
        return None
    backup = path.with_name(f"{path.stem}.previous{path.suffix}")
    shutil.copy2(path, backup)
    return backup


def _print_calibration(args: argparse.Namespace, result: Any, path: Any,
                       kept: Any = None) -> None:
    """Print a calibration's table and the file written (and where the previous one went)."""
    rows = [[n, str(j.servo_id), fmt(j.zero_tick, 0), fmt(j.min_tick, 0), fmt(j.max_tick, 0),
             str(j.homing_offset), "yes" if j.wrap_detected else "no"]
            for n, j in result.joints.items()]
    text = table(["joint", "id", "zero", "min", "max", "offset", "wrap seen"], rows,
                 [1, 2, 3, 4, 5]) + f"\n\nwrote {path} (hash {result.hash})"
    if kept is not None:
        text += f"\nthe previous calibration is kept as {kept}"
    emit(args, {"file": str(path), "hash": result.hash,
                "previous": None if kept is None else str(kept),
                "joints": {n: j.record() for n, j in result.joints.items()}}, text)


def _calibrate_from_lerobot(args: argparse.Namespace, spec: ArmSpec) -> int:
    """``armctl calibrate CONFIG --from-lerobot FILE``: import, check, write."""
    from pathlib import Path

    from armctl.errors import ConfigError, KeyPath
    from armctl.servo.calibration import calibration_path
    from armctl.servo.lerobot_calibration import import_lerobot

    out = Path(args.output) if args.output else calibration_path(spec)
    if not args.output:
        out.parent.mkdir(parents=True, exist_ok=True)
    if out.exists() and not args.force:
        raise ConfigError("the calibration file exists already; nothing was written",
                          KeyPath(out), "pass --force to replace it, or -o FILE to write "
                          "another file")
    result = import_lerobot(spec, args.from_lerobot)
    path = result.save(out)
    _print_calibration(args, result, path)
    return 0


def _calibrate_to_lerobot(args: argparse.Namespace, spec: ArmSpec) -> int:
    """``armctl calibrate CONFIG --to-lerobot FILE``: read the calibration, write LeRobot's."""
    from pathlib import Path

    from armctl.errors import ConfigError, KeyPath
    from armctl.servo.calibration import Calibration, calibration_path
    from armctl.servo.lerobot_calibration import export_lerobot

    source = Path(args.calibration) if args.calibration else calibration_path(spec)
    if not source.exists():
        raise ConfigError(f"arm {spec.name!r} has no calibration file", KeyPath(source),
                          "run 'armctl calibrate CONFIG' (or import one with --from-lerobot), "
                          "or name it with --calibration FILE")
    done = export_lerobot(spec, Calibration.load(source), args.to_lerobot,
                          overwrite=args.force)
    rows = [[n, str(r.id), str(r.drive_mode), str(r.homing_offset), str(r.range_min),
             str(r.range_max)] for n, r in done.records.items()]
    text = table(["motor", "id", "drive_mode", "homing_offset", "range_min", "range_max"],
                 rows, [1, 2, 3, 4, 5]) + f"\n\nwrote {done.file} (from {source})"
    for s in done.shifts:
        text += (f"\nnote: LeRobot puts joint {s.joint!r} at zero where armctl reads "
                 f"{fmt(s.value, 4)}: LeRobot's zero is the middle of the range (the gripper's "
                 "0 % is its lower end), armctl's is the reference pose")
    emit(args, {"file": str(done.file), "calibration": str(source),
                "motors": {n: r.as_dict() for n, r in done.records.items()},
                "zero_shifts": {s.joint: s.value for s in done.shifts}}, text)
    return 0
