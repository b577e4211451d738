"""Servo maintenance commands: ``reboot`` and ``setup-motors``."""

from __future__ import annotations

import argparse
import sys
from typing import Any

from armctl.cli._common import add_config, add_json, emit
from armctl.errors import InputError

ORDER = 51


def register(sub: argparse._SubParsersAction) -> None:
    """Add the servo maintenance commands."""
    from armctl.cli.bus import _add_bus_args

    p = sub.add_parser("reboot", help="reboot servos (clears latched hardware alarms); torque "
                                      "is off afterwards")
    add_config(p)
    p.add_argument("joints", nargs="*", metavar="JOINT", help="joints (default: every servo)")
    _add_bus_args(p)
    add_json(p)
    p.set_defaults(func=cmd_reboot)

    p = sub.add_parser("setup-motors", help="give new servos the config's ids and baud rate, "
                                            "one servo connected at a time")
    add_config(p)
    p.add_argument("--port", help="override the config's port")
    add_json(p)
    p.set_defaults(func=cmd_setup_motors)


def cmd_reboot(args: argparse.Namespace) -> int:
    """Reboot servos and report the alarms that cleared."""
    from armctl.cli.bus import _arm_bus, _unknown_joint

    ab = _arm_bus(args)
    joints = args.joints or list(ab.joint_names)
    for name in joints:
        if name not in ab.joint_names:
            raise _unknown_joint(name, ab.joint_names, f"arm {ab.arm_name!r}")
    with ab:
        before = _alarms(ab.read_state(), joints)
        ab.reboot(joints)
        after = _alarms(ab.read_state(), joints)  # an alarm whose cause remains comes back
        torque = ab.torque()
    cleared = {n: sorted(set(before[n]) - set(after[n])) for n in joints}
    lines = [f"rebooted: {', '.join(joints)} (torque is off after a reboot)"]
    for n in joints:
        if cleared[n]:
            lines.append(f"  {n}: cleared {', '.join(cleared[n])}")
        if after[n]:
            lines.append(f"  {n}: still reports {', '.join(after[n])} (remove the cause: "
                         "let it cool, free the joint, check the supply)")
    emit(args, {"rebooted": joints, "alarms_before": before, "alarms_after": after,
                "alarms_cleared": cleared, "torque": {n: torque[n] for n in joints}},
         "\n".join(lines))
    return 0


def _alarms(st: Any, joints: list[str]) -> dict[str, list[str]]:
    """The alarms each joint's servo reports (its Hardware Error Status / status bits)."""
    return {n: [a.value for a in st.errors[st.names.index(n)]] for n in joints}


def wait_enter(prompt: str) -> None:
    """Print ``prompt`` and wait for Enter.

    Raises:
        InputError: When the input is closed instead (nothing more is written).
    """
    print(prompt, file=sys.stderr, flush=True)  # stdout stays the report (--json)
    try:
        input()
    except EOFError:
        raise InputError("the input was closed (end of file) while 'setup-motors' waited for "
                         "Enter; run it in a terminal") from None


def cmd_setup_motors(args: argparse.Namespace) -> int:
    """Give each servo its id and the bus baud rate, one connected servo at a time."""
    from armctl.cli.bus import _spec
    from armctl.servo.mapping import JointMapping
    from armctl.servo.motor_setup import (
        assign_id_and_baud,
        bus_rates,
        check_port,
        find_single_servo,
    )

    spec = _spec(args)
    assert spec.bus is not None  # _spec checks  # mypy.
    bus = spec.bus
    if bus.simulated:
        raise InputError(f"{spec.file or spec.name}: bus: port is 'sim', whose servos are set up "
                         "already; pass --port with a real port (or the pty of 'armctl sim')")
    mapping = JointMapping.from_spec(spec)
    check_port(bus.port, bus.protocol, bus.baudrate)
    done: list[dict[str, Any]] = []
    # the last joint (gripper) first, as LeRobot's setup does
    for j in reversed(mapping.joints):
        wait_enter(f"Connect only the servo of joint {j.name!r} ({j.model}, to become id "
                   f"{j.servo_id}) to {bus.port}, then press Enter")
        found = find_single_servo(bus.port, bus.protocol, bus_rates(j.model, bus.baudrate))
        ping = assign_id_and_baud(bus.port, bus.protocol, found, j.model, j.servo_id,
                                  bus.baudrate)
        done.append({"joint": j.name, "from_id": found.ping.servo_id,
                     "from_baudrate": found.baudrate, "id": ping.servo_id,
                     "baudrate": bus.baudrate})
        print(f"  {j.name}: id {found.ping.servo_id} at {found.baudrate} baud -> id "
              f"{ping.servo_id} at {bus.baudrate} baud (verified by ping)", file=sys.stderr,
              flush=True)
    emit(args, {"port": bus.port, "servos": done},
         f"{len(done)} servos set up; connect them all to the bus")
    return 0
