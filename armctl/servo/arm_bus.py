"""The joint-level facade: an arm's servo bus read and commanded in joint units.

:class:`ArmBus` combines the arm config's ``bus:`` section, the joint mapping (and calibration)
and a :class:`~armctl.servo.driver.ServoBus`. With ``port: sim`` it starts the in-process
simulated bus on a pty and talks to it through the real SDK, exactly as it would to hardware.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
import numpy.typing as npt

from armctl.clock import Clock, WallClock
from armctl.config.bus import BusSpec, Protocol
from armctl.config.schema import ArmSpec
from armctl.errors import ConfigError, InputError, KeyPath
from armctl.servo import errors as E
from armctl.servo.calibration import Calibration
from armctl.servo.driver import Feedback, ServoBus
from armctl.servo.load_units import load_scale
from armctl.servo.mapping import JointMapping
from armctl.servo.sim.bus import SimulatedBus
from armctl.servo.simulated_arm import simulated_bus_for
from armctl.servo_tables import Alarm, Register, table_for
from armctl.typing import Array

__all__ = ["ArmBus", "JointState"]

SIM_LATENCY_MS = 8.0  # adapter latency assumed in reply timeouts on the simulated bus [ms]
#: Adapter latency assumed on a simulated bus in simulated time [ms]: waiting costs no simulated
#: time there, so a simulator thread starved of CPU must not be taken for a missing servo.
SIM_TIME_LATENCY_MS = 100.0


def _frozen(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class JointState:
    """The state of every servo joint from one bus transaction (arrays are read-only).

    Attributes:
        names: Joint names (the order of every array).
        position: Joint values [rad] or [m].
        velocity: Joint velocities [rad/s] or [m/s].
        load: The servo's torque as a fraction of its stall torque (-1..1; the same on every
            model): the reported load on models that report it in 0.1 % (STS3215, XL430-W250),
            the reported current over the motor's stall current on current-sensing models
            (XL330, XM430, XM540; beyond +-1 only if the current exceeds the stall current at
            the rated voltage). Signed like :attr:`velocity`: positive pushes the joint towards
            larger values. See :mod:`armctl.servo.load_units`.
        current: Motor current [A], signed like :attr:`load`, on models whose feedback holds a
            current (XL330, XM430, XM540); NaN on the others (XL430-W250 has no current
            sensing; the STS3215's Present_Current lies outside the feedback block, and reading
            it would cost a second transaction per cycle).
        temperature: Servo temperatures [degC].
        voltage: Servo input voltages [V].
        ticks: Raw present positions [tick].
        errors: Per joint, the hardware alarms the servo reports (empty when healthy).
    """

    names: tuple[str, ...]
    position: Array
    velocity: Array
    load: Array
    current: Array
    temperature: Array
    voltage: Array
    ticks: npt.NDArray[np.int64]
    errors: tuple[tuple[Alarm, ...], ...]

    @property
    def ok(self) -> bool:
        """Whether no servo reports an alarm."""
        return not any(self.errors)


class ArmBus:
    """An arm's servos, in joint units.

    Build it with :meth:`from_spec` (no I/O), then :meth:`open` it or use ``with``.

    Args:
        bus: The bus section of the config.
        mapping: The joint mapping.
        retries: Extra attempts after a failed transaction.
        wire_timing: For ``port: sim``: time the simulated replies as on the wire.
    """

    def __init__(self, bus: BusSpec, mapping: JointMapping, *, retries: int = 2,
                 wire_timing: bool = False, clock: Clock | None = None):
        self.spec = bus
        self.mapping = mapping
        self.joint_names: tuple[str, ...] = mapping.names
        self.retries = retries
        self.wire_timing = wire_timing
        #: Time base of the simulated servos for ``port: sim`` (``None``: the default clock).
        self.clock = clock
        self._bus: ServoBus | None = None
        self._sim: SimulatedBus | None = None
        self._ids = list(mapping.ids)
        self.calibration: Calibration | None = None
        self.arm_name = "arm"
        self._alarmed: dict[int, tuple[Alarm, ...]] = {}  # servo id -> alarms it reported
        # load register count -> fraction of the stall torque / amperes, in the joint's sense
        scales = [(j.direction, load_scale(j.model)) for j in mapping.joints]
        self._load_fraction = np.array([d * s.fraction for d, s in scales])
        self._load_amps = np.array([d * s.amps for d, s in scales])

    @classmethod
    def from_spec(cls, spec: ArmSpec, calibration: Calibration | None = None, *,
                  retries: int = 2, wire_timing: bool = False,
                  clock: Clock | None = None) -> ArmBus:
        """The bus of an arm config (no I/O).

        Args:
            spec: An arm with a ``bus:`` section.
            calibration: Calibration (see :mod:`armctl.servo.calibration`); ``None`` uses the
                config's offsets.
            retries: Extra attempts after a failed transaction.
            wire_timing: For ``port: sim``: time simulated replies at the baud rate.
            clock: For ``port: sim``: time base of the simulated servos (default
                :func:`~armctl.clock.default_clock`).

        Raises:
            ConfigError: No bus section, or an inconsistent one.
        """
        if spec.bus is None:
            raise ConfigError(f"arm {spec.name!r} has no 'bus:' section: it has no servos to "
                              "move", KeyPath(spec.file) if spec.file is not None else None,
                              spec.no_bus_fix(sim=False))
        mapping = JointMapping.from_spec(spec, calibration)
        self = cls(spec.bus, mapping, retries=retries, wire_timing=wire_timing, clock=clock)
        self.calibration = calibration
        self.arm_name = spec.name
        return self

    # ---- life cycle -------------------------------------------------------------------------
    def open(self) -> ArmBus:
        """Open the port and check and configure every servo.

        Starts the simulated bus for ``port: sim``; checks every servo's presence and model;
        sets each servo's operating mode and calibrated homing offset.

        Raises:
            PortError, ServoMissingError, WrongModelError: See :mod:`armctl.servo.errors`.
        """
        if self._bus is not None:
            return self
        port, latency = self.spec.port, 16.0
        if self.spec.simulated:
            self._sim = simulated_bus_for(self.mapping, self.spec.protocol, self.spec.baudrate,
                                          wire_timing=self.wire_timing, clock=self.clock)
            port, latency = self._sim.start(), SIM_LATENCY_MS
            if not isinstance(self._sim.clock, WallClock):
                latency = SIM_TIME_LATENCY_MS
        models = {j.servo_id: j.model for j in self.mapping.joints}
        bus = ServoBus(port, self.spec.protocol, self.spec.baudrate, models=models,
                       retries=self.retries, latency_ms=latency)
        try:
            bus.open()
            bus.verify()
            self._bus = bus
            self._configure()
        except BaseException:
            self._bus = None
            bus.close()
            if self._sim is not None:
                self._sim.stop()
                self._sim = None
            raise
        return self

    def close(self) -> None:
        """Close the port and stop the simulated bus (torque is left as it is)."""
        if self._bus is not None:
            self._bus.close()
            self._bus = None
        if self._sim is not None:
            self._sim.stop()
            self._sim = None

    def __enter__(self) -> ArmBus:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def simulator(self) -> SimulatedBus | None:
        """The in-process simulated bus (``None`` on hardware or before :meth:`open`)."""
        return self._sim

    @property
    def servo_bus(self) -> ServoBus:
        """The underlying register-level bus.

        Raises:
            PortError: If the bus is not open.
        """
        if self._bus is None:
            raise E.PortError("the bus is not open", self.spec.port,
                              fix="call open() or use 'with ArmBus.from_spec(...)' first")
        return self._bus

    def _configure(self) -> None:
        """Operating modes (multi-turn where needed), calibrated homing offsets, drive modes."""
        bus = self.servo_bus
        for j in self.mapping.joints:
            vendor = table_for(j.model).vendor
            wants: list[tuple[Register, int]] = []
            if vendor.sets_mode:
                mode = vendor.multi_turn_mode if j.multi_turn else vendor.position_mode
                assert mode is not None  # the mapping allows multi-turn only with it  # mypy.
                wants.append((Register.OPERATING_MODE, mode))
            wants.append((Register.HOMING_OFFSET, j.homing_offset))
            if j.servo_reverse is not None:  # a calibration that recorded the drive mode
                drive = bus.read(j.servo_id, Register.DRIVE_MODE)
                wants.append((Register.DRIVE_MODE, (drive & ~1) | int(j.servo_reverse)))
            todo = [(r, v) for r, v in wants if bus.read(j.servo_id, r) != v]
            if not todo:
                continue
            if bus.read(j.servo_id, Register.TORQUE_ENABLE):
                raise E.EepromLockedError(
                    f"joint {j.name!r} needs {', '.join(f'{r.value}={v}' for r, v in todo)}, "
                    "an EEPROM write, but torque is on", bus.port, j.servo_id, todo[0][0].value,
                    fix="turn torque off ('armctl torque CONFIG off') and open the bus again")
            self.write_eeprom(j.servo_id, todo)

    def write_eeprom(self, sid: int, items: Sequence[tuple[Register, int]]) -> None:
        """Write configuration registers of one servo (torque must be off).

        On Feetech the EEPROM is unlocked for the writes and locked again.

        Raises:
            EepromLockedError: If the servo refuses (torque on).
            ServoAlarmError: The servo reported an alarm (see :attr:`alarmed`); nothing is sent.
        """
        bus = self.servo_bus
        self._refuse_alarmed([sid], "the EEPROM write")
        lock = bus.vendor.eeprom_lock
        if lock:
            bus.write(sid, Register.LOCK, 0)
        for reg, value in items:
            bus.write(sid, reg, value)
        if lock:
            bus.write(sid, Register.LOCK, 1)

    # ---- reading -------------------------------------------------------------------------------
    def _feedback(self) -> dict[int, Feedback]:
        fb = self.servo_bus.read_feedback(self._ids)
        for sid, f in fb.items():
            if f.alarms:
                self._alarmed[sid] = f.alarms
        return fb

    # ---- alarms: nothing is sent to an alarmed servo until the alarm is cleared -----------
    @property
    def alarmed(self) -> dict[str, tuple[Alarm, ...]]:
        """Joints whose servo reported a hardware alarm since the bus opened (or was cleared).

        Nothing but reads and torque-off is sent to them (an STS3215 goal write would switch
        its torque back on) until :meth:`clear_alarms` (or :meth:`reboot`).
        """
        return {j.name: self._alarmed[j.servo_id] for j in self.mapping.joints
                if j.servo_id in self._alarmed}

    def refuse_alarmed(self, what: str) -> None:
        """Refuse ``what`` while a servo is in the alarm lock-out (before anything is sent).

        Raises:
            ServoAlarmError: Naming the first alarmed servo, its joint and how to clear it.
        """
        self._refuse_alarmed(self._ids, what)

    def _refuse_alarmed(self, ids: Sequence[int], what: str) -> None:
        """Raise for the first alarmed servo among ``ids`` (nothing has been sent)."""
        for j in self.mapping.joints:
            if j.servo_id in ids and j.servo_id in self._alarmed:
                raise E.ServoAlarmError(
                    f"joint {j.name!r} reported a hardware alarm; {what} was not sent: nothing "
                    "more is sent to this servo until its alarm is cleared", self.servo_bus.port,
                    j.servo_id, None, ", ".join(a.value for a in self._alarmed[j.servo_id]),
                    fix="remove the cause (load, heat, supply voltage), then clear it: 'armctl "
                        "torque CONFIG on --clear-alarms' or ArmBus.clear_alarms() (reboots "
                        "the servo; torque comes back off)")

    def clear_alarms(self, joints: Sequence[str] | None = None) -> list[str]:
        """Reboot the alarmed servos among ``joints`` (all when ``None``) and accept them again.

        A reboot clears a latched alarm (Dynamixel Alert, Feetech status); torque comes back
        off. A servo whose alarm persists is refused again at the next reading.

        Returns:
            The joints that were cleared.
        """
        names = self.joint_names if joints is None else tuple(joints)
        todo = [n for n in names if self.mapping.joint(n).servo_id in self._alarmed]
        self.reboot(todo)
        return todo

    def read_joints(self) -> Array:
        """Present joint values [rad] or [m] from one sync read.

        Raises:
            ServoAlarmError: If a servo reports a hardware alarm (its torque may be off).
            CommError: If the bus fails after its retries.
        """
        got = self.servo_bus.read_positions(self._ids)
        if any(alarms for _, alarms in got.values()):
            self._raise_position_alarm(got)
        return self.mapping.from_ticks({sid: p for sid, (p, _) in got.items()})

    def _raise_position_alarm(self, got: dict[int, tuple[int, tuple[Alarm, ...]]]) -> None:
        """Raise for the first joint whose position reply flags an alarm (and remember it)."""
        for j in self.mapping.joints:
            alarms = got[j.servo_id][1]
            if alarms:
                self._alarmed[j.servo_id] = alarms
                raise E.ServoAlarmError(f"joint {j.name!r}: hardware alarm", self.servo_bus.port,
                                        j.servo_id, "present_position",
                                        ", ".join(a.value for a in alarms),
                                        fix="remove the cause, then clear it: 'armctl torque "
                                            "CONFIG on --clear-alarms' or "
                                            "ArmBus.clear_alarms() (reboots the servo)")

    def read_state(self) -> JointState:
        """Position, velocity, load, current, temperature, voltage and alarms of every joint.

        One sync read (plus one register read per Dynamixel servo that flags an alarm).
        """
        fb = self._feedback()
        js = self.mapping.joints
        pos = self.mapping.from_ticks({sid: f.position for sid, f in fb.items()})
        vel = np.array([fb[j.servo_id].velocity * 2 * math.pi
                        / (j.direction * j.gear_ratio * j.ticks_per_rev) for j in js])
        raw = np.array([float(fb[j.servo_id].load) for j in js])  # load register [count]
        return JointState(
            names=self.joint_names, position=_frozen(pos), velocity=_frozen(vel),
            load=_frozen(raw * self._load_fraction), current=_frozen(raw * self._load_amps),
            temperature=_frozen(np.array([float(fb[j.servo_id].temperature) for j in js])),
            voltage=_frozen(np.array([fb[j.servo_id].voltage for j in js])),
            ticks=_frozen(np.array([fb[j.servo_id].position for j in js], dtype=np.int64)),
            errors=tuple(fb[j.servo_id].alarms for j in js),
        )

    # ---- commanding ------------------------------------------------------------------------------
    def write_joints(self, q: npt.ArrayLike, *, skip_alarmed: bool = False) -> None:
        """Send goal positions for every servo joint in one sync write.

        Args:
            q: One value per joint of :attr:`joint_names`, [rad] or [m].
            skip_alarmed: Leave the servos that reported an alarm out (the others still get
                their goals: a stop after an alarm) instead of refusing the write.

        Raises:
            JointLimitError: A value outside its joint's limits; nothing is sent.
            InputError: Wrong number of values or not finite; nothing is sent.
            ServoAlarmError: A servo reported an alarm (see :attr:`alarmed`); nothing is sent.
        """
        arr = self.mapping.as_vector(q)
        if not np.isfinite(arr).all():
            bad = self.joint_names[int(np.argmin(np.isfinite(arr)))]
            raise InputError(f"joint {bad!r}: goal is not a finite number; nothing was sent")
        ticks = self.mapping.goal_ticks(arr)
        if not self._alarmed:  # the usual case: nothing to leave out or refuse
            pass
        elif skip_alarmed:
            ticks = {sid: t for sid, t in ticks.items() if sid not in self._alarmed}
        else:
            self._refuse_alarmed(list(ticks), "the goal")
        self.servo_bus.sync_write(Register.GOAL_POSITION, ticks)

    def set_torque(self, on: bool, joints: Sequence[str] | None = None) -> None:
        """Switch torque on or off for some joints (all when ``joints`` is ``None``).

        Raises:
            UnknownNameError: For a joint without a servo.
            ServoAlarmError: Torque on for a servo that reported an alarm (see
                :attr:`alarmed`); nothing is sent.
        """
        names = self.joint_names if joints is None else tuple(joints)
        ids = [self.mapping.joint(n).servo_id for n in names]
        if on:
            self._refuse_alarmed(ids, "torque on")
        self.servo_bus.set_torque(ids, on)

    def torque(self) -> dict[str, bool]:
        """Whether torque is on, per joint."""
        bus = self.servo_bus
        return {j.name: bool(bus.read(j.servo_id, Register.TORQUE_ENABLE))
                for j in self.mapping.joints}

    def reboot(self, joints: Sequence[str] | None = None) -> None:
        """Reboot servos: clears latched alarms and the lock-out of :attr:`alarmed`.

        Torque comes back off.
        """
        names = self.joint_names if joints is None else tuple(joints)
        for n in names:
            sid = self.mapping.joint(n).servo_id
            self.servo_bus.reboot(sid)
            self._alarmed.pop(sid, None)

    def retry_counts(self) -> dict[int, int]:
        """Failed bus attempts (missing, corrupt or late replies) per servo id since opening."""
        return self.servo_bus.retry_counts()

    @property
    def protocol(self) -> Protocol:
        """The bus protocol."""
        return self.spec.protocol
