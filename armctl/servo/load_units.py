"""What a servo's load register means: counts to a fraction of the stall torque and amperes.

Address 126 of every Dynamixel X servo is "Present Load" in 0.1 % on models without current
sensing (XL430-W250) and "Present Current" in the model's current unit on the others (1 mA on
the XL330, about 2.69 mA on the XM430 and XM540: ROBOTIS e-Manual control tables); the Feetech
STS3215 reports Present_Load in 0.1 % (Feetech STS memory table). The register's unit comes from
the control table (:attr:`~armctl.servo_tables.RegisterSpec.unit`), the stall current from the
motor parameters (:mod:`armctl.servo_tables.motors`): a current converts to a fraction of the
stall torque as ``I / I_stall`` (the output torque is proportional to the current, reaching the
stall torque at the stall current).
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass
from functools import cache

from armctl.errors import InputError
from armctl.servo_tables import Register, table_for
from armctl.servo_tables.motors import motor_for

__all__ = ["LoadScale", "load_scale"]

_UNIT = re.compile(r"^\s*([0-9]*\.?[0-9]+)\s*(mA|A|%)\s*$")
_PER = {"mA": 1e-3, "A": 1.0, "%": 1e-2}


@dataclass(frozen=True)
class LoadScale:
    """How one model's load register (:attr:`Register.PRESENT_LOAD`) converts to SI.

    Attributes:
        model: Servo model.
        unit: The register's unit per count, as the control table gives it (e.g. ``"2.69 mA"``).
        fraction: Fraction of the stall torque per count.
        amps: Current per count [A], or NaN when the register is a load, not a current.
    """

    model: str
    unit: str
    fraction: float
    amps: float

    @property
    def current_sensing(self) -> bool:
        """Whether the register reports the motor current."""
        return not math.isnan(self.amps)


@cache
def load_scale(model: str) -> LoadScale:
    """The conversion of a model's load register (from its control table and motor figures).

    Raises:
        UnknownNameError: A model without a control table or motor parameters.
        InputError: A register unit that is neither a current nor a percentage.
    """
    spec = table_for(model).spec(Register.PRESENT_LOAD)
    found = _UNIT.match(spec.unit)
    if found is None:
        raise InputError(f"servo model {model!r}: the unit of {spec.name or spec.register.value} "
                         f"({spec.unit!r}) is neither a current (mA, A) nor a percentage; "
                         "its reading cannot be converted to a load")
    per_count = float(found.group(1)) * _PER[found.group(2)]
    if found.group(2) == "%":
        return LoadScale(model, spec.unit, per_count, math.nan)
    return LoadScale(model, spec.unit, per_count / motor_for(model).stall_current, per_count)
