"""armctl: control robot arms built from serial-bus smart servos.

Load an arm with :func:`load_arm`, then compute poses (``arm.fk``), Jacobians
(``arm.jacobian``) and more. Units are SI throughout: metres, radians, seconds.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

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

if TYPE_CHECKING:
    from armctl.arm import Arm, load_arm

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


def __getattr__(name: str) -> Any:
    """``Arm`` and ``load_arm``, imported on first use.

    ``import armctl`` stays light (NumPy and the compiled kernels load with the first arm), so
    the command line starts fast.
    """
    if name in ("Arm", "load_arm"):
        from armctl import arm

        value = getattr(arm, name)
        globals()[name] = value
        return value
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
