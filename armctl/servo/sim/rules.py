"""What the simulator asks a servo family: the protocol rules a simulated servo follows.

The simulator (:mod:`.servo`, :mod:`.dispatch`) knows ids, registers and ticks. Everything a
family does differently on the wire is behind :class:`ServoRules`: the status error byte, which
instructions are answered at which Status Return Level, what a Ping returns, how a write is
checked (error numbers, silent ignores, clamps), the family's own instructions (Clear, Factory
Reset, Control Table Backup, factory recovery), special register values, which alarms cut the
torque, what each Operating Mode number means and how the registers make the motor's command,
how the framing looks, and how Present Position counts turns. Each vendor package under
:mod:`armctl.servo` implements them; :mod:`armctl.servo.vendor_rules` says which one answers
for a protocol.
"""

from __future__ import annotations

import typing
from abc import ABC, abstractmethod
from collections.abc import Callable, Mapping

from armctl.servo.sim.motor import Command, ControlMode
from armctl.servo.sim.wire import Wire
from armctl.servo_tables import ControlTable, Register, RegisterSpec
from armctl.servo_tables.motors import MotorSpec

__all__ = [
    "ACTION",
    "BULK_READ",
    "BULK_WRITE",
    "CLEAR",
    "CONTROL_TABLE_BACKUP",
    "ERR_ACCESS",
    "ERR_CRC",
    "ERR_INSTRUCTION",
    "ERR_LENGTH",
    "ERR_LIMIT",
    "ERR_RANGE",
    "ERR_RESULT_FAIL",
    "FACTORY_RESET",
    "FAST_BULK_READ",
    "FAST_SYNC_READ",
    "PING",
    "READ",
    "REBOOT",
    "REG_WRITE",
    "SYNC_READ",
    "SYNC_WRITE",
    "WRITE",
    "ServoRules",
    "ServoState",
]

# Instruction codes (ROBOTIS e-Manual "Protocol 2.0", "Protocol 1.0"; Feetech SCS/STS uses the
# Protocol 1.0 numbers plus Sync Read).
PING, READ, WRITE, REG_WRITE, ACTION = 0x01, 0x02, 0x03, 0x04, 0x05
FACTORY_RESET, REBOOT = 0x06, 0x08
CLEAR, CONTROL_TABLE_BACKUP = 0x10, 0x20
SYNC_READ, SYNC_WRITE, FAST_SYNC_READ = 0x82, 0x83, 0x8A
BULK_READ, BULK_WRITE, FAST_BULK_READ = 0x92, 0x93, 0x9A

# Error numbers of a Protocol 2.0 status packet (e-Manual Protocol 2.0 "Error"); the rules map
# them to each protocol's status byte.
ERR_RESULT_FAIL, ERR_INSTRUCTION, ERR_CRC, ERR_RANGE = 1, 2, 3, 4
ERR_LENGTH, ERR_LIMIT, ERR_ACCESS = 5, 6, 7


class ServoState(typing.Protocol):
    """What the rules may see and do of one simulated servo."""

    @property
    def table(self) -> ControlTable:
        """The model's control table."""

    @property
    def torque(self) -> bool:
        """Whether torque is on."""

    @property
    def model_number(self) -> int:
        """The model number the servo reports."""

    def get(self, reg: Register) -> int:
        """The decoded value of a (non-indexed) register."""

    def set(self, reg: Register, value: int) -> None:
        """Store a register value (no access rules)."""

    def encoder_position(self) -> int:
        """Encoder position within one turn [tick], before the homing offset."""

    def reset_registers(self, keep: frozenset[Register] = frozenset()) -> None:
        """Every item back to its factory default except those in ``keep``."""

    def clear_multi_turn(self) -> int:
        """Drop the turn count; 0, or an error number when the shaft is moving."""

    def snapshot(self, specs: typing.Iterable[RegisterSpec]) -> dict[RegisterSpec, bytes]:
        """The raw bytes of ``specs``."""

    def restore(self, saved: Mapping[RegisterSpec, bytes]) -> None:
        """Put back raw bytes taken by :meth:`snapshot`."""

    def reboot(self) -> None:
        """Reboot: RAM back to defaults, EEPROM kept."""

    backup: dict[RegisterSpec, bytes] | None


class ServoRules(ABC):
    """One family's (and protocol's) behaviour on the wire, as the simulator asks for it.

    Attributes:
        wire: The protocol's framing.
        silent: Whether a bad request (unknown instruction, bad checksum, address outside the
            table, write to a read-only or partial item) is ignored, rather than answered with
            an error number.
        group_reads: Instruction codes of the group reads the protocol has.
        group_writes: Instruction codes of the group writes the protocol has.
        fast_reads: The group reads answered with one combined status packet.
        basic: The single-servo instructions the simulator carries out itself (Ping, Read,
            Write, Reg Write, Action, Reboot) that the protocol has.
        modes: Operating Mode value -> what the controller does in it (a value not listed
            runs as position control).
        folds_at_power_on: Whether Present Position comes back within one turn at power-on
            and after a reboot (the turn count is lost).
    """

    wire: type[Wire]
    basic: frozenset[int] = frozenset({PING, READ, WRITE, REG_WRITE, ACTION, REBOOT})
    silent: bool = False
    group_reads: frozenset[int] = frozenset()
    group_writes: frozenset[int] = frozenset({SYNC_WRITE})
    fast_reads: frozenset[int] = frozenset()
    modes: Mapping[int, ControlMode] = {}
    folds_at_power_on: bool = False

    def refuse(self, number: int) -> int:
        """The error number a bad request gets (0: silently ignored)."""
        return 0 if self.silent else number

    def control_mode(self, value: int) -> ControlMode:
        """What the controller does at Operating Mode ``value``."""
        return self.modes.get(value, ControlMode.POSITION)

    @abstractmethod
    def command(self, table: ControlTable, motor: MotorSpec, get: Callable[[Register], int]
                ) -> Command:
        """The control inputs of a servo from its registers (units and scaling of the family).

        Args:
            table: The servo's control table (registers the model lacks take neutral values).
            motor: Its motor parameters.
            get: Reads a register's decoded value.
        """

    @abstractmethod
    def status_error(self, number: int, hardware_error: int) -> int:
        """The error byte of a status packet.

        Args:
            number: Error number of the instruction (0: none; see ``ERR_*``).
            hardware_error: The servo's hardware error (alarm) register.
        """

    @abstractmethod
    def answers(self, level: int, inst: int) -> bool:
        """Whether a servo at Status Return Level ``level`` answers instruction ``inst``."""

    @abstractmethod
    def ping_params(self, servo: ServoState) -> bytes:
        """The parameters of the status packet answering a Ping."""

    @abstractmethod
    def multi_turn(self, servo: ServoState) -> bool:
        """Whether Goal Position counts turns (extended position control)."""

    @abstractmethod
    def wraps_position(self, servo: ServoState) -> bool:
        """Whether Present Position is reported within one turn at every read.

        Otherwise it is a continuous count that comes back within one turn only where
        :meth:`folds_turns` (and :attr:`folds_at_power_on`) say.
        """

    def homing_offset(self, servo: ServoState) -> int:
        """The offset [tick] the present position gets (``homing_sign`` x Homing Offset)."""
        return servo.table.vendor.homing_sign * servo.get(Register.HOMING_OFFSET)

    def folds_turns(self, servo: ServoState, reg: Register, old: int, new: int) -> bool:
        """Whether a write brings the continuous Present Position back within one turn.

        Args:
            servo: The servo, with ``new`` already stored.
            reg: The register written.
            old: Its value before.
            new: The value written.
        """
        return False

    @abstractmethod
    def check_write(self, servo: ServoState, values: dict[RegisterSpec, int], eeprom: bool
                    ) -> tuple[int, dict[RegisterSpec, int]]:
        """Check a write of whole items.

        Args:
            servo: The servo written to.
            values: Decoded value per item, in address order.
            eeprom: Whether any item lies in EEPROM.

        Returns:
            ``(error number, the values to store)``; with an error number nothing is stored.
        """

    def special_write(self, servo: ServoState, spec: RegisterSpec, value: int) -> bool:
        """Act on a register value with a special meaning; ``True`` if it is not to be stored."""
        return False

    def goal_limits(self, servo: ServoState) -> tuple[int, int] | None:
        """Bounds [tick] the servo keeps its motion within whatever goal position is stored."""
        return None

    @abstractmethod
    def instruction(self, servo: ServoState, inst: int, params: bytes, broadcast: bool
                    ) -> tuple[int, bytes] | None:
        """Carry out one of the family's own instructions.

        Ping, Read, Write, Reg Write, Action and Reboot, which every family has, are the
        simulator's; the rest (Clear, Factory Reset, Control Table Backup, ...) are here.

        Returns:
            ``(error number, status parameters)``, or ``None`` for an instruction the servo
            does not know.
        """

    @abstractmethod
    def shutdown_mask(self, servo: ServoState) -> int:
        """The alarm bits that switch the torque off when they occur."""

    def read_outside(self, length: int) -> tuple[int, bytes]:
        """``(error number, data)`` of a read that leaves the control table."""
        return ERR_ACCESS, b""
