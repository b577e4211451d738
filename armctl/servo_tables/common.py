"""What every servo family's control tables are made of: registers, items, tables, alarms.

The families' own tables and conventions are in :mod:`.dynamixel` and :mod:`.feetech`.
"""

from __future__ import annotations

import re
from dataclasses import dataclass, field
from enum import Enum

from armctl.errors import InputError, UnknownNameError

__all__ = [
    "Access",
    "Alarm",
    "ControlTable",
    "Encoding",
    "Family",
    "IndirectBlock",
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
        reset_keeps: Factory Reset option -> the registers that keep their value through a
            reset with that option (Dynamixel Protocol 2.0: 0xFF resets all, 0x01 all but
            the ID, 0x02 all but the ID and the baud rate). Empty if the family documents
            no options.
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
    reset_keeps: dict[int, tuple[Register, ...]] = field(default_factory=dict)

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
    """Register names shared by all models (a model may lack some).

    One member names the same quantity on every model that has it; ``RegisterSpec.name``
    keeps what the maker calls it there. In particular: ``D_GAIN``/``I_GAIN``/``P_GAIN`` are
    the Dynamixel position-loop gains (Feetech's P/D/I coefficients); ``VELOCITY_P_GAIN``/
    ``VELOCITY_I_GAIN`` the velocity-loop ones (Feetech 37/39); ``PRESENT_LOAD`` is Dynamixel
    address 126 ("Present Load" in 0.1 % on the XL430, "Present Current" on current-sensing
    models: see ``RegisterSpec.unit``) and Feetech Present_Load 60, while ``PRESENT_CURRENT``
    is Feetech Present_Current 69; ``PROFILE_VELOCITY``/``PROFILE_ACCELERATION`` are
    Feetech's Goal_Velocity 46 and Acceleration 41; ``MOVING_THRESHOLD`` is also Feetech's
    Moving_Velocity_Threshold 80. ``INDIRECT_ADDRESS``, ``INDIRECT_DATA``,
    ``EXTERNAL_PORT_MODE`` and ``EXTERNAL_PORT_DATA`` are indexed: see
    :meth:`ControlTable.item`.
    """

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
    # Dynamixel X series items
    MODEL_INFORMATION = "model_information"
    SECONDARY_ID = "secondary_id"
    PROTOCOL_TYPE = "protocol_type"
    MOVING_THRESHOLD = "moving_threshold"
    PWM_LIMIT = "pwm_limit"
    CURRENT_LIMIT = "current_limit"
    STARTUP_CONFIGURATION = "startup_configuration"
    PWM_SLOPE = "pwm_slope"
    VELOCITY_I_GAIN = "velocity_i_gain"
    VELOCITY_P_GAIN = "velocity_p_gain"
    FEEDFORWARD_2ND_GAIN = "feedforward_2nd_gain"
    FEEDFORWARD_1ST_GAIN = "feedforward_1st_gain"
    BUS_WATCHDOG = "bus_watchdog"
    GOAL_PWM = "goal_pwm"
    GOAL_CURRENT = "goal_current"
    REALTIME_TICK = "realtime_tick"
    MOVING_STATUS = "moving_status"
    PRESENT_PWM = "present_pwm"
    VELOCITY_TRAJECTORY = "velocity_trajectory"
    POSITION_TRAJECTORY = "position_trajectory"
    BACKUP_READY = "backup_ready"
    INDIRECT_ADDRESS = "indirect_address"
    INDIRECT_DATA = "indirect_data"
    EXTERNAL_PORT_MODE = "external_port_mode"
    EXTERNAL_PORT_DATA = "external_port_data"
    # Feetech STS items
    TORQUE_LIMIT = "torque_limit"
    MAX_ACCELERATION = "max_acceleration"
    PROTECTION_CURRENT = "protection_current"
    PROTECTIVE_TORQUE = "protective_torque"
    PROTECTION_TIME = "protection_time"
    OVERLOAD_TORQUE = "overload_torque"
    OVERCURRENT_PROTECTION_TIME = "overcurrent_protection_time"
    CW_DEAD_ZONE = "cw_dead_zone"
    CCW_DEAD_ZONE = "ccw_dead_zone"
    UNLOADING_CONDITION = "unloading_condition"
    LED_ALARM_CONDITION = "led_alarm_condition"
    MIN_STARTUP_FORCE = "min_startup_force"
    ANGULAR_RESOLUTION = "angular_resolution"
    BYTE_ORDER = "byte_order"
    MAX_VELOCITY_LIMIT = "max_velocity_limit"
    DTS = "dts"
    VELOCITY_UNIT_FACTOR = "velocity_unit_factor"
    HTS = "hts"
    ACCELERATION_MULTIPLIER = "acceleration_multiplier"

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
        name: The maker's name of the item (e.g. ``"Goal PWM"``, ``"Torque_Limit"``).
        index: 1-based slot of an indexed item (Indirect Address 1, 2, ...), 0 otherwise.
        values: The values a write may carry when not every value in ``[lo, hi]`` is one
            (e.g. Operating Mode); empty when the whole range is.
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
    name: str = ""
    index: int = 0
    values: tuple[int, ...] = ()

    @property
    def writable(self) -> bool:
        """Whether the host may write it."""
        return self.access is Access.RW

    def accepts(self, value: int) -> bool:
        """Whether a write of ``value`` (decoded) is within the item's range and values."""
        if not self.lo <= value <= self.hi:
            return False
        return not self.values or value in self.values


@dataclass(frozen=True)
class IndirectBlock:
    """One run of Indirect Address / Indirect Data slots (Dynamixel).

    Slot ``first_index + k`` (k < ``count``) has its 2-byte Indirect Address at
    ``address_start + 2 * k`` and its 1-byte Indirect Data at ``data_start + k``.

    Attributes:
        first_index: 1-based index of the block's first slot.
        count: Number of slots.
        address_start: Address of the first slot's Indirect Address item.
        data_start: Address of the first slot's Indirect Data item.
    """

    first_index: int
    count: int
    address_start: int
    data_start: int

    def __contains__(self, index: object) -> bool:
        return isinstance(index, int) and self.first_index <= index < self.first_index + self.count

    def address_of(self, index: int) -> int:
        """Address of slot ``index``'s Indirect Address item."""
        return self.address_start + 2 * (index - self.first_index)

    def data_of(self, index: int) -> int:
        """Address of slot ``index``'s Indirect Data item."""
        return self.data_start + (index - self.first_index)


@dataclass(frozen=True)
class ControlTable:
    """The control table of one servo model.

    Attributes:
        model: Model name (lower case), e.g. ``"xm430-w350"``.
        model_number: The number the servo reports (Ping / Model Number register).
        vendor: The family's conventions (the family is ``vendor.family``).
        registers: Every non-indexed item, by name.
        eeprom_end: First RAM address; items below it are in EEPROM.
        memory_size: Size of the address space a read may cover: the last item's address +
            its size (a Dynamixel answers a read beyond it with an error).
        ticks_per_rev: Encoder ticks per output revolution.
        nominal_voltage: Typical supply in [V].
        max_speed: No-load speed in [tick/s].
        operating_modes: Operating Mode values the model accepts.
        items: Every item of the maker's table sorted by address, indexed ones included
            (derived from ``registers`` when not given).
        indirect: The model's Indirect Address / Data blocks.
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
    items: tuple[RegisterSpec, ...] = ()
    indirect: tuple[IndirectBlock, ...] = ()
    _by_byte: dict[int, RegisterSpec] = field(init=False, repr=False, compare=False)
    _by_start: dict[int, RegisterSpec] = field(init=False, repr=False, compare=False)
    _indexed: dict[tuple[Register, int], RegisterSpec] = field(init=False, repr=False,
                                                               compare=False)
    _by_name: dict[str, RegisterSpec] = field(init=False, repr=False, compare=False)

    def __post_init__(self) -> None:
        items = self.items or tuple(self.registers.values())
        items = tuple(sorted(items, key=lambda s: s.address))
        by_byte: dict[int, RegisterSpec] = {}
        by_start: dict[int, RegisterSpec] = {}
        indexed: dict[tuple[Register, int], RegisterSpec] = {}
        by_name: dict[str, RegisterSpec] = {}
        for spec in items:
            if spec.name:
                by_name.setdefault(_name_key(spec.name), spec)
            by_start.setdefault(spec.address, spec)
            for a in range(spec.address, spec.address + spec.size):
                other = by_byte.setdefault(a, spec)
                if other is not spec:
                    first, second = (other.name or other.register.value,
                                     spec.name or spec.register.value)
                    raise InputError(
                        f"control table {self.model!r}: items {first!r} and {second!r} overlap "
                        f"at address {a}; give each item its own bytes",
                        {"model": self.model, "address": a})
            if spec.index:
                indexed[(spec.register, spec.index)] = spec
        object.__setattr__(self, "items", items)
        object.__setattr__(self, "_by_byte", by_byte)
        object.__setattr__(self, "_by_start", by_start)
        object.__setattr__(self, "_indexed", indexed)
        object.__setattr__(self, "_by_name", by_name)

    @property
    def family(self) -> Family:
        """Protocol family."""
        return self.vendor.family

    @property
    def baud_codes(self) -> dict[int, int]:
        """Baud Rate codes this model accepts -> rate [bit/s] (the family's, within range)."""
        spec = self.registers.get(Register.BAUD_RATE)
        return {code: rate for code, rate in self.vendor.baud_codes.items()
                if spec is None or spec.accepts(code)}

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

    def item(self, register: Register, index: int) -> RegisterSpec:
        """The indexed item ``register`` number ``index`` (1-based), e.g. Indirect Data 5.

        Raises:
            UnknownNameError: If this model has no such item.
        """
        try:
            return self._indexed[(register, index)]
        except KeyError:
            valid = sorted({f"{r.value} {i}" for r, i in self._indexed})
            raise UnknownNameError("indexed item", f"{register.value} {index}", valid,
                                   f"model {self.model!r}") from None

    def named(self, name: str) -> RegisterSpec:
        """The item the maker calls ``name`` (case, spaces, dashes, underscores ignored).

        For example ``"Goal PWM"``, ``"goal_pwm"``, ``"Maximum_Acceleration"`` or
        ``"Indirect Data 3"``.

        Raises:
            UnknownNameError: If this model has no item of that name.
        """
        try:
            return self._by_name[_name_key(name)]
        except KeyError:
            valid = [s.name for s in self.items if s.name]
            raise UnknownNameError("control-table item", name, valid,
                                   f"model {self.model!r}") from None

    def at(self, address: int) -> RegisterSpec | None:
        """The item (indexed ones included) that starts at ``address``, if any."""
        return self._by_start.get(address)

    def covering(self, address: int) -> RegisterSpec | None:
        """The item (indexed ones included) whose bytes include ``address``, if any."""
        return self._by_byte.get(address)


def _name_key(name: str) -> str:
    """``name`` folded for lookup (``"Secondary(Shadow) ID"`` is also ``"Secondary_ID"``).

    Lower case, without spaces, underscores, dashes or a parenthesised aside.
    """
    folded = re.sub(r"\([^)]*\)", "", name.lower())
    return "".join(c for c in folded if c not in " _-")


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
