"""Servo control tables as data: one :class:`ControlTable` per supported model.

Addresses, sizes, access, ranges and defaults are transcribed from the manufacturers' tables:

* Dynamixel X series (XL330-M288, XL430-W250, XM430-W350): ROBOTIS e-Manual pages
  ``docs/en/dxl/x/xl330-m288.md``, ``xl430-w250.md``, ``xm430-w350.md`` (control table sections),
  cross-checked with LeRobot ``motors/dynamixel/tables.py`` (``X_SERIES_CONTROL_TABLE``).
* Feetech STS3215: the official ``SMS_STS.h`` memory table (ftservo/FTServo_Arduino) and LeRobot
  ``motors/feetech/tables.py`` (``STS_SMS_SERIES_CONTROL_TABLE``, sign bits from LeRobot PR #2223).

Negative values are two's complement on Dynamixel and sign-magnitude (one sign bit) on Feetech;
:class:`Encoding` records which, per register.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from armctl.errors import UnknownNameError

__all__ = [
    "TABLES",
    "Access",
    "ControlTable",
    "Encoding",
    "Family",
    "Register",
    "RegisterSpec",
    "alarms_from_bits",
    "table_for",
    "table_for_model_number",
]


class Family(Enum):
    """Protocol family of a servo model."""

    DYNAMIXEL = "dynamixel"
    FEETECH = "feetech"


class Access(Enum):
    """Who may write a register."""

    R = "R"
    RW = "RW"


class Encoding(Enum):
    """How a register stores negative numbers."""

    UNSIGNED = "unsigned"
    TWOS_COMPLEMENT = "twos_complement"
    SIGN_MAGNITUDE = "sign_magnitude"


class Register(Enum):
    """Register names shared by all models (a model may lack some)."""

    MODEL_NUMBER = "model_number"
    FIRMWARE = "firmware"
    FIRMWARE_MINOR = "firmware_minor"
    ID = "id"
    BAUD_RATE = "baud_rate"
    RETURN_DELAY = "return_delay"
    STATUS_RETURN_LEVEL = "status_return_level"
    DRIVE_MODE = "drive_mode"
    OPERATING_MODE = "operating_mode"
    PHASE = "phase"
    HOMING_OFFSET = "homing_offset"
    TEMPERATURE_LIMIT = "temperature_limit"
    MAX_VOLTAGE_LIMIT = "max_voltage_limit"
    MIN_VOLTAGE_LIMIT = "min_voltage_limit"
    VELOCITY_LIMIT = "velocity_limit"
    MAX_POSITION_LIMIT = "max_position_limit"
    MIN_POSITION_LIMIT = "min_position_limit"
    MAX_TORQUE = "max_torque"
    SHUTDOWN = "shutdown"
    TORQUE_ENABLE = "torque_enable"
    LED = "led"
    REGISTERED_INSTRUCTION = "registered_instruction"
    HARDWARE_ERROR = "hardware_error"
    D_GAIN = "d_gain"
    I_GAIN = "i_gain"
    P_GAIN = "p_gain"
    GOAL_VELOCITY = "goal_velocity"
    PROFILE_ACCELERATION = "profile_acceleration"
    PROFILE_VELOCITY = "profile_velocity"
    GOAL_POSITION = "goal_position"
    GOAL_TIME = "goal_time"
    LOCK = "lock"
    MOVING = "moving"
    PRESENT_LOAD = "present_load"
    PRESENT_VELOCITY = "present_velocity"
    PRESENT_POSITION = "present_position"
    PRESENT_VOLTAGE = "present_voltage"
    PRESENT_TEMPERATURE = "present_temperature"
    PRESENT_CURRENT = "present_current"

    # Members are singletons: identity hashing is correct and much faster than Enum's default
    # (registers key the simulator's hot dictionaries).
    __hash__ = object.__hash__

    @classmethod
    def parse(cls, name: str) -> Register:
        """A register from its name (``"goal_position"``, ``"Goal_Position"``).

        Raises:
            UnknownNameError: For a name that is not a register.
        """
        key = name.strip().lower().replace("-", "_").replace(" ", "_")
        for reg in cls:
            if reg.value == key:
                return reg
        raise UnknownNameError("register", name, [r.value for r in cls])


@dataclass(frozen=True)
class RegisterSpec:
    """One control-table item.

    Attributes:
        register: Its name.
        address: First byte address.
        size: Width in bytes (1, 2 or 4).
        access: Read-only or read-write.
        lo: Smallest value accepted by a write (decoded, signed).
        hi: Largest value accepted by a write.
        default: Value after a factory reset.
        encoding: How negative values are stored.
        sign_bit: The sign bit for :attr:`Encoding.SIGN_MAGNITUDE`.
        unit: Unit of one count, for display.
    """

    register: Register
    address: int
    size: int
    access: Access
    lo: int
    hi: int
    default: int = 0
    encoding: Encoding = Encoding.UNSIGNED
    sign_bit: int = 15
    unit: str = ""

    @property
    def writable(self) -> bool:
        """Whether the host may write it."""
        return self.access is Access.RW


@dataclass(frozen=True)
class ControlTable:
    """The control table of one servo model.

    Attributes:
        model: Model name (lower case), e.g. ``"xm430-w350"``.
        model_number: The number the servo reports (Ping / Model Number register).
        family: Protocol family.
        registers: Every item, by name.
        eeprom_end: First RAM address; items below it are in EEPROM.
        memory_size: Size of the address space a read may cover.
        ticks_per_rev: Encoder ticks per output revolution.
        nominal_voltage: Typical supply in [V].
        max_speed: No-load speed in [tick/s].
        operating_modes: Operating Mode values the model accepts.
    """

    model: str
    model_number: int
    family: Family
    registers: dict[Register, RegisterSpec]
    eeprom_end: int
    memory_size: int
    ticks_per_rev: int = 4096
    nominal_voltage: float = 12.0
    max_speed: float = 6000.0
    operating_modes: tuple[int, ...] = (3,)

    def spec(self, register: Register) -> RegisterSpec:
        """The item for ``register``.

        Raises:
            UnknownNameError: If this model has no such register.
        """
        try:
            return self.registers[register]
        except KeyError:
            valid = [r.value for r in self.registers]
            raise UnknownNameError("register", register.value, valid,
                                   f"model {self.model!r}") from None

    def has(self, register: Register) -> bool:
        """Whether the model has ``register``."""
        return register in self.registers

    def is_eeprom(self, register: Register) -> bool:
        """Whether ``register`` lives in EEPROM (writable only with torque off / unlocked)."""
        return self.spec(register).address < self.eeprom_end

    def at(self, address: int) -> RegisterSpec | None:
        """The item that starts at ``address``, if any."""
        for spec in self.registers.values():
            if spec.address == address:
                return spec
        return None

    def covering(self, address: int) -> RegisterSpec | None:
        """The item whose bytes include ``address``, if any."""
        for spec in self.registers.values():
            if spec.address <= address < spec.address + spec.size:
                return spec
        return None


R, RW = Access.R, Access.RW
TWOS, SM = Encoding.TWOS_COMPLEMENT, Encoding.SIGN_MAGNITUDE
_I32 = (-(2**31), 2**31 - 1)

# Dynamixel X series (e-Manual control tables). Columns: register, address, size, access, lo, hi,
# default, encoding, unit. Per-model values are patched in _x_series() below.
_X_COMMON: tuple[tuple[Register, int, int, Access, int, int, int, Encoding, str], ...] = (
    (Register.MODEL_NUMBER, 0, 2, R, 0, 65535, 0, Encoding.UNSIGNED, ""),
    (Register.FIRMWARE, 6, 1, R, 0, 255, 52, Encoding.UNSIGNED, ""),
    (Register.ID, 7, 1, RW, 0, 252, 1, Encoding.UNSIGNED, ""),
    (Register.BAUD_RATE, 8, 1, RW, 0, 7, 1, Encoding.UNSIGNED, "code"),
    (Register.RETURN_DELAY, 9, 1, RW, 0, 254, 250, Encoding.UNSIGNED, "2 us"),
    (Register.DRIVE_MODE, 10, 1, RW, 0, 13, 0, Encoding.UNSIGNED, ""),
    (Register.OPERATING_MODE, 11, 1, RW, 0, 16, 3, Encoding.UNSIGNED, ""),
    (Register.HOMING_OFFSET, 20, 4, RW, -1044479, 1044479, 0, TWOS, "tick"),
    (Register.TEMPERATURE_LIMIT, 31, 1, RW, 0, 100, 80, Encoding.UNSIGNED, "degC"),
    (Register.MAX_VOLTAGE_LIMIT, 32, 2, RW, 31, 160, 160, Encoding.UNSIGNED, "0.1 V"),
    (Register.MIN_VOLTAGE_LIMIT, 34, 2, RW, 31, 160, 95, Encoding.UNSIGNED, "0.1 V"),
    (Register.VELOCITY_LIMIT, 44, 4, RW, 0, 2047, 200, Encoding.UNSIGNED, "0.229 rpm"),
    (Register.MAX_POSITION_LIMIT, 48, 4, RW, 0, 4095, 4095, Encoding.UNSIGNED, "tick"),
    (Register.MIN_POSITION_LIMIT, 52, 4, RW, 0, 4095, 0, Encoding.UNSIGNED, "tick"),
    (Register.SHUTDOWN, 63, 1, RW, 0, 255, 52, Encoding.UNSIGNED, "bits"),
    (Register.TORQUE_ENABLE, 64, 1, RW, 0, 1, 0, Encoding.UNSIGNED, ""),
    (Register.LED, 65, 1, RW, 0, 1, 0, Encoding.UNSIGNED, ""),
    (Register.STATUS_RETURN_LEVEL, 68, 1, RW, 0, 2, 2, Encoding.UNSIGNED, ""),
    (Register.REGISTERED_INSTRUCTION, 69, 1, R, 0, 1, 0, Encoding.UNSIGNED, ""),
    (Register.HARDWARE_ERROR, 70, 1, R, 0, 255, 0, Encoding.UNSIGNED, "bits"),
    (Register.D_GAIN, 80, 2, RW, 0, 16383, 0, Encoding.UNSIGNED, ""),
    (Register.I_GAIN, 82, 2, RW, 0, 16383, 0, Encoding.UNSIGNED, ""),
    (Register.P_GAIN, 84, 2, RW, 0, 16383, 800, Encoding.UNSIGNED, ""),
    (Register.GOAL_VELOCITY, 104, 4, RW, -2047, 2047, 0, TWOS, "0.229 rpm"),
    (Register.PROFILE_ACCELERATION, 108, 4, RW, 0, 32767, 0, Encoding.UNSIGNED, "214.577 rpm2"),
    (Register.PROFILE_VELOCITY, 112, 4, RW, 0, 32767, 0, Encoding.UNSIGNED, "0.229 rpm"),
    (Register.GOAL_POSITION, 116, 4, RW, -1048575, 1048575, 0, TWOS, "tick"),
    (Register.MOVING, 122, 1, R, 0, 1, 0, Encoding.UNSIGNED, ""),
    (Register.PRESENT_LOAD, 126, 2, R, -32768, 32767, 0, TWOS, "0.1 %"),
    (Register.PRESENT_VELOCITY, 128, 4, R, *_I32, 0, TWOS, "0.229 rpm"),
    (Register.PRESENT_POSITION, 132, 4, R, *_I32, 0, TWOS, "tick"),
    (Register.PRESENT_VOLTAGE, 144, 2, R, 0, 65535, 0, Encoding.UNSIGNED, "0.1 V"),
    (Register.PRESENT_TEMPERATURE, 146, 1, R, 0, 255, 0, Encoding.UNSIGNED, "degC"),
)

# Per-model differences (e-Manual): model number, limits, gains, load unit, speed, voltage.
@dataclass(frozen=True)
class _XModel:
    """What differs between the X-series models (e-Manual)."""

    model_number: int
    voltage: float  # nominal supply [V]
    rpm: float  # no-load speed at the nominal supply [rev/min]
    defaults: dict[Register, int]
    load_unit: str  # Present Load (0.1 %) or Present Current (mA) at address 126
    modes: tuple[int, ...]  # Operating Mode values
    baud_max: int  # highest Baud Rate code


_X_MODELS: dict[str, _XModel] = {
    "xl330-m288": _XModel(
        1200, 5.0, 103.0,
        {Register.TEMPERATURE_LIMIT: 70, Register.MAX_VOLTAGE_LIMIT: 70,
         Register.MIN_VOLTAGE_LIMIT: 35, Register.VELOCITY_LIMIT: 445, Register.SHUTDOWN: 53,
         Register.P_GAIN: 400, Register.D_GAIN: 0},
        "1 mA", (0, 1, 3, 4, 5, 16), 6),
    "xl430-w250": _XModel(
        1060, 11.1, 57.0,
        {Register.TEMPERATURE_LIMIT: 72, Register.MAX_VOLTAGE_LIMIT: 140,
         Register.MIN_VOLTAGE_LIMIT: 60, Register.VELOCITY_LIMIT: 265, Register.P_GAIN: 640,
         Register.D_GAIN: 4000},
        "0.1 %", (1, 3, 4, 16), 7),
    "xm430-w350": _XModel(
        1020, 12.0, 46.0,
        {Register.TEMPERATURE_LIMIT: 80, Register.VELOCITY_LIMIT: 200, Register.P_GAIN: 800,
         Register.D_GAIN: 0},
        "2.69 mA", (0, 1, 3, 4, 5, 16), 7),
}

RPM_UNIT = 0.229  # [rev/min] per velocity count (e-Manual "Velocity Limit")


def _x_series(model: str) -> ControlTable:
    info = _X_MODELS[model]
    regs: dict[Register, RegisterSpec] = {}
    for reg, addr, size, acc, lo, hi, default, enc, unit in _X_COMMON:
        if reg is Register.MODEL_NUMBER:
            default = info.model_number
        if reg is Register.BAUD_RATE:
            hi = info.baud_max
        if reg is Register.PRESENT_LOAD:
            unit = info.load_unit
        regs[reg] = RegisterSpec(reg, addr, size, acc, lo, hi, info.defaults.get(reg, default),
                                 enc, 31, unit)
    return ControlTable(
        model=model, model_number=info.model_number, family=Family.DYNAMIXEL, registers=regs,
        eeprom_end=64, memory_size=228, nominal_voltage=info.voltage,
        max_speed=info.rpm / 60.0 * 4096, operating_modes=info.modes,
    )


# Feetech STS3215 (official SMS_STS.h; LeRobot STS_SMS_SERIES_CONTROL_TABLE; sign bits PR #2223).
_STS3215: tuple[tuple[Register, int, int, Access, int, int, int, Encoding, int, str], ...] = (
    (Register.FIRMWARE, 0, 1, R, 0, 255, 3, Encoding.UNSIGNED, 15, ""),
    (Register.FIRMWARE_MINOR, 1, 1, R, 0, 255, 10, Encoding.UNSIGNED, 15, ""),
    (Register.MODEL_NUMBER, 3, 2, R, 0, 65535, 777, Encoding.UNSIGNED, 15, ""),
    (Register.ID, 5, 1, RW, 0, 253, 1, Encoding.UNSIGNED, 15, ""),
    (Register.BAUD_RATE, 6, 1, RW, 0, 7, 0, Encoding.UNSIGNED, 15, "code"),
    (Register.RETURN_DELAY, 7, 1, RW, 0, 254, 0, Encoding.UNSIGNED, 15, "2 us"),
    (Register.STATUS_RETURN_LEVEL, 8, 1, RW, 0, 1, 1, Encoding.UNSIGNED, 15, ""),
    (Register.MIN_POSITION_LIMIT, 9, 2, RW, 0, 4095, 0, Encoding.UNSIGNED, 15, "tick"),
    (Register.MAX_POSITION_LIMIT, 11, 2, RW, 0, 4095, 4095, Encoding.UNSIGNED, 15, "tick"),
    (Register.TEMPERATURE_LIMIT, 13, 1, RW, 0, 100, 70, Encoding.UNSIGNED, 15, "degC"),
    (Register.MAX_VOLTAGE_LIMIT, 14, 1, RW, 0, 254, 80, Encoding.UNSIGNED, 15, "0.1 V"),
    (Register.MIN_VOLTAGE_LIMIT, 15, 1, RW, 0, 254, 40, Encoding.UNSIGNED, 15, "0.1 V"),
    (Register.MAX_TORQUE, 16, 2, RW, 0, 1000, 1000, Encoding.UNSIGNED, 15, "0.1 %"),
    (Register.PHASE, 18, 1, RW, 0, 255, 12, Encoding.UNSIGNED, 15, "bits"),
    (Register.P_GAIN, 21, 1, RW, 0, 254, 32, Encoding.UNSIGNED, 15, ""),
    (Register.D_GAIN, 22, 1, RW, 0, 254, 32, Encoding.UNSIGNED, 15, ""),
    (Register.I_GAIN, 23, 1, RW, 0, 254, 0, Encoding.UNSIGNED, 15, ""),
    (Register.HOMING_OFFSET, 31, 2, RW, -2047, 2047, 0, SM, 11, "tick"),
    (Register.OPERATING_MODE, 33, 1, RW, 0, 3, 0, Encoding.UNSIGNED, 15, ""),
    (Register.TORQUE_ENABLE, 40, 1, RW, 0, 128, 0, Encoding.UNSIGNED, 15, ""),
    (Register.PROFILE_ACCELERATION, 41, 1, RW, 0, 254, 0, Encoding.UNSIGNED, 15, "100 tick/s2"),
    (Register.GOAL_POSITION, 42, 2, RW, -32767, 32767, 0, SM, 15, "tick"),
    (Register.GOAL_TIME, 44, 2, RW, 0, 65535, 0, Encoding.UNSIGNED, 15, "ms"),
    (Register.PROFILE_VELOCITY, 46, 2, RW, -32767, 32767, 0, SM, 15, "tick/s"),
    (Register.LOCK, 55, 1, RW, 0, 1, 1, Encoding.UNSIGNED, 15, ""),
    (Register.PRESENT_POSITION, 56, 2, R, -32767, 32767, 0, SM, 15, "tick"),
    (Register.PRESENT_VELOCITY, 58, 2, R, -32767, 32767, 0, SM, 15, "tick/s"),
    (Register.PRESENT_LOAD, 60, 2, R, -1023, 1023, 0, SM, 10, "0.1 %"),
    (Register.PRESENT_VOLTAGE, 62, 1, R, 0, 255, 0, Encoding.UNSIGNED, 15, "0.1 V"),
    (Register.PRESENT_TEMPERATURE, 63, 1, R, 0, 255, 0, Encoding.UNSIGNED, 15, "degC"),
    (Register.REGISTERED_INSTRUCTION, 64, 1, R, 0, 1, 0, Encoding.UNSIGNED, 15, ""),
    (Register.HARDWARE_ERROR, 65, 1, R, 0, 255, 0, Encoding.UNSIGNED, 15, "bits"),
    (Register.MOVING, 66, 1, R, 0, 1, 0, Encoding.UNSIGNED, 15, ""),
    (Register.PRESENT_CURRENT, 69, 2, R, 0, 65535, 0, Encoding.UNSIGNED, 15, "6.5 mA"),
)


def _sts3215() -> ControlTable:
    regs = {row[0]: RegisterSpec(*row) for row in _STS3215}
    return ControlTable(
        model="sts3215", model_number=777, family=Family.FEETECH, registers=regs, eeprom_end=40,
        memory_size=87, nominal_voltage=7.4, max_speed=45.0 / 60.0 * 4096, operating_modes=(0,),
    )


TABLES: dict[str, ControlTable] = {
    "sts3215": _sts3215(),
    **{m: _x_series(m) for m in _X_MODELS},
}


class Alarm(Enum):
    """Hardware alarms and their bits (Dynamixel Hardware Error Status 70, Feetech Status 65).

    Sources: e-Manual X series "Hardware Error Status"; SDK-FT ``ERRBIT_*`` constants.
    """

    INPUT_VOLTAGE = "input_voltage"
    OVERHEATING = "overheating"
    ENCODER = "encoder"
    OVERLOAD = "overload"

    @property
    def dynamixel_bit(self) -> int:
        """The bit in Dynamixel Hardware Error Status."""
        return {"input_voltage": 0x01, "overheating": 0x04, "encoder": 0x08,
                "overload": 0x20}[self.value]

    @property
    def feetech_bit(self) -> int:
        """The bit in the Feetech status byte."""
        return {"input_voltage": 0x01, "overheating": 0x04, "encoder": 0x02,
                "overload": 0x20}[self.value]


def alarms_from_bits(bits: int, feetech: bool) -> tuple[Alarm, ...]:
    """The alarms whose bits are set in ``bits``."""
    return tuple(a for a in Alarm
                 if bits & (a.feetech_bit if feetech else a.dynamixel_bit))


def table_for(model: str) -> ControlTable:
    """The control table of a model name (case-insensitive).

    Raises:
        UnknownNameError: For a model armctl does not know.
    """
    try:
        return TABLES[model.lower()]
    except KeyError:
        raise UnknownNameError("servo model", model, list(TABLES)) from None


def table_for_model_number(family: Family, number: int) -> ControlTable | None:
    """The table whose model number is ``number`` in ``family``, or ``None``."""
    for table in TABLES.values():
        if table.family is family and table.model_number == number:
            return table
    return None
