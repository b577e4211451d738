"""Which bus a robot drives: the config's, another port, or the built-in simulated bus.

:func:`arm_on_bus` gives an arm whose ``bus:`` section names another port (a serial device, or
the pty of a running ``armctl sim``) or the built-in simulated bus. An arm without a ``bus:``
section (a converted URDF) can run on the simulated bus only: :func:`simulated_bus_spec` gives
it one simulated servo per actuated joint.
"""

from __future__ import annotations

from dataclasses import replace

from armctl.arm import Arm
from armctl.config.bus import SIM_PORT, BusSpec, Protocol, ServoSpec
from armctl.config.schema import ArmSpec, JointType
from armctl.errors import InputError

__all__ = ["SIM_MODEL", "SIM_PRISMATIC_RATIO", "arm_on_bus", "simulated_bus_spec"]

#: The servo model simulated for each joint of an arm without a ``bus:`` section: a Dynamixel
#: X-series servo, which has an extended (multi-turn) position mode, so any joint range fits.
SIM_MODEL = "xm430-w350"

#: Servo shaft [rad] per joint [m] of a simulated prismatic joint: one tick of 4096 per turn is
#: then 2 pi / 4096 / 100 = 0.015 mm.
SIM_PRISMATIC_RATIO = 100.0


def simulated_bus_spec(spec: ArmSpec) -> BusSpec:
    """A simulated ``bus:`` section for an arm that has none: one servo per actuated joint.

    Each joint gets a :data:`SIM_MODEL` servo with ids 1, 2, ... in joint order, zero offset,
    direction +1, on Dynamixel Protocol 2.0 at 1 Mbit/s; a prismatic joint turns its servo
    :data:`SIM_PRISMATIC_RATIO` [rad] per [m].

    Raises:
        InputError: An arm without actuated joints (nothing to drive).
    """
    joints = spec.actuated_joints
    if not joints:
        raise InputError(f"arm {spec.name!r} has no actuated joint: there is no servo to "
                         "simulate (a 'bus:' section maps joints to servos, see docs/bus.md)")
    multi = [f"{j.name!r} ({j.type.value})" for j in joints if j.type.nq != 1]
    if multi:
        raise InputError(f"arm {spec.name!r} has joints no servo can drive: {', '.join(multi)}; "
                         "the simulated bus simulates servos, so it cannot run this arm. "
                         "Solve it with 'armctl ik' and draw it with 'armctl render' instead")
    servos = tuple(
        ServoSpec(joint=j.name, id=i + 1, model=SIM_MODEL,
                  gear_ratio=SIM_PRISMATIC_RATIO if j.type is JointType.PRISMATIC else 1.0)
        for i, j in enumerate(joints))
    return BusSpec(port=SIM_PORT, protocol=Protocol.DYNAMIXEL, baudrate=1_000_000,
                   servos=servos)


def arm_on_bus(arm: Arm, port: str | None = None, sim: bool = False) -> Arm:
    """The arm driven through ``port`` or the built-in simulated bus (the arm itself without).

    Args:
        arm: The arm as loaded.
        port: Replaces the port of the arm's ``bus:`` section (protocol, baud rate and servo
            ids stay the config's).
        sim: Use the built-in simulated bus; an arm without a ``bus:`` section gets
            :func:`simulated_bus_spec`.

    Raises:
        InputError: Both ``port`` and ``sim``, an empty port, ``port`` for an arm without a
            ``bus:`` section, or ``sim`` for a bus section without servos.
    """
    if port is not None and sim:
        raise InputError("--port and --sim exclude each other: give --port PORT for a device "
                         "or a running 'armctl sim', or --sim for the built-in simulated bus")
    if port is None and not sim:
        return arm
    spec = arm.spec
    where = f" ({spec.file})" if spec.file is not None else ""
    if port is not None:
        if not port.strip():
            raise InputError("--port: empty port name; give a device such as /dev/ttyACM0 or "
                             "the pty that 'armctl sim' prints")
        if spec.bus is None:
            raise InputError(
                f"--port {port}: arm {spec.name!r}{where} has no 'bus:' section, so armctl does "
                f"not know its protocol, baud rate and servo ids; {spec.no_bus_fix()}")
        bus = replace(spec.bus, port=port)
    elif spec.bus is None:
        bus = simulated_bus_spec(spec)
    elif not spec.bus.servos:
        raise InputError(f"--sim: arm {spec.name!r}{where} has a 'bus:' section without "
                         "servos; list one servo per joint under bus.servos (docs/bus.md)")
    else:
        bus = replace(spec.bus, port=SIM_PORT)
    if bus == spec.bus:
        return arm
    return Arm(replace(spec, bus=bus))
