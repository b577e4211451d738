"""What every servo family's control tables are made of: registers, items, tables, alarms.

The families' own tables and conventions are in :mod:`.dynamixel` and :mod:`.feetech`.
"""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

from armctl.errors import UnknownNameError

__all__ = [
    "Access",
    "Alarm",
    "ControlTable",
    "Encoding",
    "Family",
    "Register",
    "RegisterSpec",
    "Vendor",
    "alarms_from_bits",
]


class Family(Enum):
    """Protocol family of a servo model."""

    DYNAMIXEL = "dynamixel"
    FEETECH = "feetech"


@dataclass(frozen=True)
class Vendor:
    """The conventions of one servo family that code above the tables asks instead of branching.

    Attributes:
        family: The family.
        velocity_unit: [tick/s] (4096 ticks a turn) per count of the velocity registers
            (Goal/Present/Profile Velocity, Velocity Limit).
        acceleration_unit: [tick/s^2] per count of Profile Acceleration.
        homing_sign: Sign of the homing offset in present = raw + sign * offset
            (Dynamixel adds the offset, Feetech subtracts it).
        homing_limit: Largest homing offset the servo stores [tick] (magnitude).
        eeprom_lock: Whether EEPROM writes need the Lock register cleared first (Feetech).
        reports_errors: Whether a servo answers a bad request (unknown instruction, address
            outside its table, bad checksum) with an error number (Dynamixel), rather than
            ignoring it (Feetech).
        position_mode: Operating Mode value of (single-turn) position control.
        sets_mode: Whether armctl writes the Operating Mode when it opens the bus (else it
            leaves the register alone).
        zero_limits_off: Whether min = max = 0 position limits switch the limits off (Feetech).
        multi_turn_mode: Operating Mode value of extended (multi-turn) position control, or
            ``None`` if the family has none.
        position_limit_name: What the vendor's manual calls the min/max position limits.
        generic_model: A model whose table is used before a servo's own model is known.
        baud_codes: Baud Rate register code -> rate [bit/s].
    """

    family: Family
    velocity_unit: float
    acceleration_unit: float
    homing_sign: int
    homing_limit: int
    eeprom_lock: bool
    reports_errors: bool
    position_mode: int
    sets_mode: bool
    zero_limits_off: bool
    multi_turn_mode: int | None
    position_limit_name: str
    generic_model: str
    baud_codes: dict[int, int]

    def alarm_bit(self, alarm: Alarm) -> int:
        """The bit of ``alarm`` in this family's alarm register and status byte."""
        return alarm.feetech_bit if self.feetech else alarm.dynamixel_bit

    @property
    def feetech(self) -> bool:
        """Whether the family is Feetech (SCS/STS framing and status byte)."""
        return self.family is Family.FEETECH


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
        vendor: The family's conventions (the family is ``vendor.family``).
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
    vendor: Vendor
    registers: dict[Register, RegisterSpec]
    eeprom_end: int
    memory_size: int
    ticks_per_rev: int = 4096
    nominal_voltage: float = 12.0
    max_speed: float = 6000.0
    operating_modes: tuple[int, ...] = (3,)

    @property
    def family(self) -> Family:
        """Protocol family."""
        return self.vendor.family

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
