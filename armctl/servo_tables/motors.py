"""Motor parameters per servo model, for the simulator's DC-motor model.

Each servo is a DC motor behind a gear train. The makers publish, per model and supply voltage,
the stall torque and stall current at the output shaft, the no-load speed, the gear ratio and the
unit of the current registers; the rest of a DC-motor model is derived from those
(:class:`MotorSpec` properties), or, where the maker publishes nothing, an assumption that the
docstring of each field marks as such (and that ``tools/fit_motor_model.py`` replaces with values
fitted to a real servo's recorded step response).

Sources (nominal supply; the bold row of each specification table):

* ROBOTIS e-Manual, XL330-M077 specifications: 0.215 N m at 5.0 V, 1.47 A; 383 rev/min at 5.0 V;
  gear ratio 77.5:1; Present Current 1 mA.
* ROBOTIS e-Manual, XL330-M288 specifications: 0.52 N m at 5.0 V, 1.47 A; 103 rev/min at 5.0 V;
  gear ratio 288.4:1; Present Current 1 mA.
* ROBOTIS e-Manual, XL430-W250 specifications: 1.4 N m at 11.1 V, 1.3 A; 57 rev/min at 11.1 V;
  gear ratio 258.5:1; Present Load in 0.1 % (no current sensing).
* ROBOTIS e-Manual, XM430-W350 specifications: 4.1 N m at 12.0 V, 2.3 A; 46 rev/min at 12.0 V;
  gear ratio 353.5:1; Present Current about 2.69 mA.
* ROBOTIS e-Manual, XM540-W270 specifications: 10.6 N m at 12.0 V, 4.4 A; 30 rev/min at 12.0 V;
  gear ratio 272.5:1; Present Current about 2.69 mA.
* Feetech STS3215 (7.4 V, 1:345) product specification: 19.5 kg cm (1.91 N m) stall torque at
  7.4 V; no-load speed 0.192 s/60 deg (52 rev/min) and no-load current 150 mA at 7.4 V;
  Present_Current unit 6.5 mA (Feetech STS memory table). The stall current, 2.7 A, is the
  figure resellers list (assumed: Feetech's own table has none).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from armctl.errors import UnknownNameError

__all__ = ["MOTORS", "MotorSpec", "motor_for"]


@dataclass(frozen=True)
class MotorSpec:
    """The DC motor and gear train of one servo model, as seen at the output shaft.

    Attributes:
        model: Servo model name (lower case).
        voltage: Supply voltage the other figures are given at [V].
        stall_torque: Output torque with the shaft held at full PWM [N m] (maker).
        stall_current: Current with the shaft held at full PWM [A] (maker).
        no_load_speed: Output speed without load at full PWM [rev/min] (maker).
        gear_ratio: Motor turns per output turn (maker; informational: every figure here is
            already at the output shaft).
        no_load_current: Current at the no-load speed [A] (maker where published, else
            assumed): it sets the friction of the gear train.
        coulomb_fraction: Dry (Coulomb) friction as a fraction of the stall torque (assumed);
            the rest of the no-load friction is viscous.
        mechanical_time_constant: Time the free shaft needs to reach 63 % of the no-load speed
            after a PWM step [s] (assumed; sets the inertia at the output, rotor included).
        thermal_resistance: Winding-to-ambient temperature rise per watt of I^2 R loss [K/W]
            (assumed).
        thermal_time_constant: Time constant of the temperature [s] (assumed).
        current_unit: [A] per count of the current registers, or ``None`` for a model without
            current sensing (its address 126 reports the load in 0.1 %).
        pwm_full: Count of full duty in Present/Goal PWM (Dynamixel 885 = 100 %) or of
            Present_Load / Torque_Limit (Feetech 1000 = 100 %).
    """

    model: str
    voltage: float
    stall_torque: float
    stall_current: float
    no_load_speed: float
    gear_ratio: float
    no_load_current: float
    coulomb_fraction: float
    mechanical_time_constant: float
    thermal_resistance: float
    thermal_time_constant: float
    current_unit: float | None
    pwm_full: int

    @property
    def resistance(self) -> float:
        """Winding resistance [ohm]: supply over stall current."""
        return self.voltage / self.stall_current

    @property
    def torque_constant(self) -> float:
        """Output torque per ampere [N m/A] (gear ratio and efficiency included)."""
        return self.stall_torque / self.stall_current

    @property
    def no_load_speed_rad(self) -> float:
        """No-load output speed [rad/s]."""
        return self.no_load_speed * 2.0 * math.pi / 60.0

    @property
    def back_emf_constant(self) -> float:
        """Back-EMF per output speed [V s/rad]: ``V = Ke w0 + R I0`` at no load."""
        return (self.voltage - self.resistance * self.no_load_current) / self.no_load_speed_rad

    @property
    def coulomb_friction(self) -> float:
        """Dry friction torque at the output [N m]."""
        return self.coulomb_fraction * self.stall_torque

    @property
    def viscous_friction(self) -> float:
        """Viscous friction at the output [N m s/rad].

        The no-load current's torque, less the dry friction, at the no-load speed.
        """
        drag = self.torque_constant * self.no_load_current - self.coulomb_friction
        return max(0.0, drag) / self.no_load_speed_rad

    @property
    def inertia(self) -> float:
        """Output inertia, rotor reflected through the gears [kg m^2]: ``tau R / (Kt Ke)``."""
        return (self.mechanical_time_constant * self.torque_constant * self.back_emf_constant
                / self.resistance)


_DXL_PWM, _FT_PWM = 885, 1000

#: Motor parameters by model name.
MOTORS: dict[str, MotorSpec] = {m.model: m for m in (
    MotorSpec("xl330-m077", 5.0, 0.215, 1.47, 383.0, 77.5, 0.12, 0.005, 0.02, 20.0, 120.0,
              0.001, _DXL_PWM),
    MotorSpec("xl330-m288", 5.0, 0.52, 1.47, 103.0, 288.4, 0.12, 0.005, 0.02, 20.0, 120.0,
              0.001, _DXL_PWM),
    MotorSpec("xl430-w250", 11.1, 1.4, 1.3, 57.0, 258.5, 0.1, 0.005, 0.02, 8.0, 300.0,
              None, _DXL_PWM),
    MotorSpec("xm430-w350", 12.0, 4.1, 2.3, 46.0, 353.5, 0.14, 0.005, 0.015, 5.0, 300.0,
              0.00269, _DXL_PWM),
    MotorSpec("xm540-w270", 12.0, 10.6, 4.4, 30.0, 272.5, 0.25, 0.005, 0.015, 3.0, 600.0,
              0.00269, _DXL_PWM),
    MotorSpec("sts3215", 7.4, 1.91, 2.7, 52.0, 345.0, 0.15, 0.01, 0.02, 8.0, 300.0,
              0.0065, _FT_PWM),
)}


def motor_for(model: str) -> MotorSpec:
    """The motor parameters of a servo model (case-insensitive).

    Raises:
        UnknownNameError: For a model without motor parameters.
    """
    try:
        return MOTORS[model.lower()]
    except KeyError:
        raise UnknownNameError("servo motor model", model, list(MOTORS)) from None
