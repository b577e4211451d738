"""Servo buses: drivers over the vendor SDKs, joint mapping, calibration, simulated bus.

Dynamixel and Feetech drivers talk through the vendor SDKs; the joint mapping and calibration
turn ticks into SI units; a wire-level simulated bus with fault injection stands in for hardware.

The joint-level entry point is :class:`ArmBus`; :class:`SimulatedBus` is the simulator that the
real SDKs talk to on a pseudo-terminal (``port: sim`` in an arm config starts one in-process).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:
    from armctl.servo.arm_bus import ArmBus, JointState
    from armctl.servo.calibrate import Calibrator
    from armctl.servo.calibration import Calibration, JointCalibration
    from armctl.servo.driver import ServoBus
    from armctl.servo.mapping import JointMap, JointMapping
    from armctl.servo.sim.bus import SimServoSpec, SimulatedBus
    from armctl.servo.sim.faults import (
        Alarm,
        CorruptedReply,
        DroppedReply,
        Fault,
        HardwareAlarm,
        LatencySpike,
        LateReply,
        LockupAfterOverload,
        MissingServo,
        Obstacle,
        TruncatedReply,
        WrongModel,
    )
    from armctl.servo.simulated_arm import simulated_bus, simulated_bus_for
    from armctl.servo.status import Feedback, PingResult
    from armctl.servo_tables import Family, Register, Vendor

#: Name -> the module that defines it, imported on first use: a command that needs one module
#: (say the calibration) does not load the drivers, the vendor SDKs and the simulator.
_MODULES: dict[str, tuple[str, ...]] = {
    "arm_bus": ("ArmBus", "JointState"),
    "calibrate": ("Calibrator",),
    "calibration": ("Calibration", "JointCalibration"),
    "driver": ("ServoBus",),
    "mapping": ("JointMap", "JointMapping"),
    "sim.bus": ("SimServoSpec", "SimulatedBus"),
    "sim.faults": ("Alarm", "CorruptedReply", "DroppedReply", "Fault", "HardwareAlarm",
                   "LatencySpike", "LateReply", "LockupAfterOverload", "MissingServo",
                   "Obstacle", "TruncatedReply", "WrongModel"),
    "simulated_arm": ("simulated_bus", "simulated_bus_for"),
    "status": ("Feedback", "PingResult"),
}
_LAZY = {name: f"armctl.servo.{module}" for module, names in _MODULES.items() for name in names}
_LAZY.update({name: "armctl.servo_tables" for name in ("Family", "Register", "Vendor")})


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(module), name)
    globals()[name] = value
    return value


__all__ = [
    "Alarm",
    "ArmBus",
    "Calibration",
    "Calibrator",
    "CorruptedReply",
    "DroppedReply",
    "Family",
    "Fault",
    "Feedback",
    "HardwareAlarm",
    "JointCalibration",
    "JointMap",
    "JointMapping",
    "JointState",
    "LateReply",
    "LatencySpike",
    "LockupAfterOverload",
    "MissingServo",
    "Obstacle",
    "PingResult",
    "Register",
    "ServoBus",
    "SimServoSpec",
    "SimulatedBus",
    "TruncatedReply",
    "Vendor",
    "WrongModel",
    "simulated_bus",
    "simulated_bus_for",
]
