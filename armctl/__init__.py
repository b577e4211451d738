"""armctl: control robot arms built from serial-bus smart servos.

Load an arm with :func:`load_arm`, then compute poses (``arm.fk``), Jacobians
(``arm.jacobian``) and more. Units are SI throughout: metres, radians, seconds.
"""

from armctl.arm import Arm, load_arm
from armctl.errors import (
    ArmctlError,
    BusError,
    ConfigError,
    InputError,
    JointLimitError,
    MotionAborted,
    NoSolutionError,
    PlanningError,
    UnknownNameError,
)

__version__ = "0.1.0"

__all__ = [
    "Arm",
    "ArmctlError",
    "BusError",
    "ConfigError",
    "InputError",
    "JointLimitError",
    "MotionAborted",
    "NoSolutionError",
    "PlanningError",
    "UnknownNameError",
    "__version__",
    "load_arm",
]
