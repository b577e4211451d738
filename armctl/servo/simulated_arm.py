"""A simulated bus populated from an arm config: one simulated servo per mapped joint.

The simulator (:mod:`armctl.servo.sim`) knows servo ids, registers and ticks only; this module
joins it to the joint mapping, so that a simulated bus starts with every servo at its joint's
rest value and accepts joint names.
"""

from __future__ import annotations

from armctl.clock import Clock
from armctl.config.bus import Protocol
from armctl.config.schema import ArmSpec
from armctl.servo.calibration import Calibration
from armctl.servo.mapping import JointMapping
from armctl.servo.sim.bus import SimServoSpec, SimulatedBus
from armctl.servo_tables import Register

__all__ = ["simulated_bus", "simulated_bus_for"]


def simulated_bus(spec: ArmSpec, calibration: Calibration | None = None, *,
                  wire_timing: bool = False, clock: Clock | None = None) -> SimulatedBus:
    """A simulated bus with the servos of an arm config, each at its joint's rest value.

    Args:
        spec: An arm with a ``bus:`` section.
        calibration: Calibration to build the joint mapping with.
        wire_timing: Time replies as on the wire.
        clock: Time base of the servos (default :func:`~armctl.clock.default_clock`).

    Raises:
        ConfigError: No bus section, or an inconsistent one.
    """
    mapping = JointMapping.from_spec(spec, calibration)
    assert spec.bus is not None  # JointMapping.from_spec checked it  # mypy.
    return simulated_bus_for(mapping, spec.bus.protocol, spec.bus.baudrate,
                             wire_timing=wire_timing, clock=clock)


def simulated_bus_for(mapping: JointMapping, protocol: Protocol, baudrate: int, *,
                      wire_timing: bool = False, clock: Clock | None = None) -> SimulatedBus:
    """A simulated bus with one servo per mapped joint, each at its joint's rest value.

    Servos start as if configured before: multi-turn joints in extended position mode, the
    homing offsets the mapping assumes (calibrated, or moving the encoder wrap out of a joint's
    travel) and a calibrated Drive Mode reverse bit already stored.

    Args:
        mapping: The joint mapping.
        protocol: Wire protocol.
        baudrate: Baud rate the servos listen at [bit/s].
        wire_timing: Time replies as on the wire.
        clock: Time base of the servos (default :func:`~armctl.clock.default_clock`).
    """
    servos = []
    for j in mapping.joints:
        t = round(j.to_ticks(j.rest))
        servos.append(SimServoSpec(j.servo_id, j.model,
                                   t if j.multi_turn else t % j.ticks_per_rev,
                                   j.homing_offset, j.multi_turn))
    sim = SimulatedBus(servos, protocol, baudrate, wire_timing=wire_timing, mapping=mapping,
                       clock=clock)
    for j, s in zip(mapping.joints, servos, strict=True):
        if j.servo_reverse:  # a calibration made with Drive Mode reverse (LeRobot's Koch leader)
            servo = sim.servo(j.servo_id)
            servo.set(Register.DRIVE_MODE, servo.get(Register.DRIVE_MODE) | 1)
            servo.set_present_position(s.position)
            if servo.present_position() != s.position:  # a hand move counted unreversed
                servo.set_present_position(2 * servo.present_position() - s.position)
    return sim
