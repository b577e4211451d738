"""The simulated servo bus: servos behind a pseudo-terminal that the real SDKs open.

A background thread reads the pty master, frames instruction packets (:mod:`.wire`), lets the
addressed :class:`~armctl.servo.sim.servo.SimServo` objects act on them (:mod:`.dispatch`)
and writes their status packets back. A servo only hears the host when the host's baud rate
equals its Baud Rate register. Injected faults (:mod:`.faults`) act here, on the replies and on
which servos are present.

With ``wire_timing=True`` replies are timed as on a real half-duplex line at the configured baud
rate: instruction bytes, each servo's return delay, then its reply bytes (10 bit times a byte).
With it off (the default, for tests) replies are immediate.
"""

from __future__ import annotations

import contextlib
import os
import select
import threading
import time
import tty
import typing
from collections import deque
from collections.abc import Iterable, Sequence
from dataclasses import dataclass
from pathlib import Path

from armctl.clock import Clock, default_clock
from armctl.config.bus import Protocol
from armctl.errors import InputError
from armctl.servo.sim import faults as F
from armctl.servo.sim.dispatch import REBOOT, Dispatcher, Reply
from armctl.servo.sim.serialspeed import client_baudrate
from armctl.servo.sim.servo import SimServo
from armctl.servo.sim.wire import BROADCAST, Instruction
from armctl.servo.vendor_rules import RULES, factory_protocol
from armctl.servo_tables import Register, table_for

__all__ = ["JointLookup", "SimJoint", "SimServoSpec", "SimulatedBus"]

_EARLY = 3e-4  # [s] how early a reply that is not the last of a group may be sent
_INLINE = 5e-3  # [s] replies due within this are waited for at once; later ones are queued
_SPIN = 1.5e-4  # [s] the last stretch before a group's last reply is due: the clock is polled
_REPLY_FAULTS = (F.DroppedReply, F.CorruptedReply, F.TruncatedReply, F.LateReply, F.LatencySpike)


@dataclass(frozen=True)
class SimServoSpec:
    """A servo to put on the simulated bus.

    Attributes:
        servo_id: Its id.
        model: Model name (``"sts3215"``, ``"xm430-w350"``, ...).
        position: Initial present position [tick].
        homing_offset: Homing offset already stored in the servo's EEPROM [tick].
        multi_turn: Start in extended position mode (models that have one).
    """

    servo_id: int
    model: str
    position: int = 2048
    homing_offset: int = 0
    multi_turn: bool = False


class SimJoint(typing.Protocol):
    """What the simulator needs of one joint to accept joint values: its servo and ticks."""

    @property
    def name(self) -> str:
        """Joint name."""

    @property
    def servo_id(self) -> int:
        """Id of the servo that drives it."""

    def to_ticks(self, q: float) -> float:
        """Servo position [tick] of joint value ``q`` [rad] or [m]."""

    def to_joint(self, ticks: float) -> float:
        """Joint value [rad] or [m] of servo position ``ticks``."""


class JointLookup(typing.Protocol):
    """Joints by name (a :class:`~armctl.servo.mapping.JointMapping` is one)."""

    @property
    def joints(self) -> Sequence[SimJoint]:
        """Every joint."""

    def joint(self, name: str) -> SimJoint:
        """The joint called ``name``."""


class SimulatedBus:
    """Simulated servos on a pty, speaking Dynamixel 2.0 or 1.0, or Feetech SCS/STS.

    Use it as a context manager or call :meth:`start` / :meth:`stop`. :attr:`port` is the pty
    path that any program can open at the bus baud rate; :attr:`servos` are the
    :class:`SimServo` objects (registers via ``get``/``set``); :attr:`requests` counts the
    instruction packets received.

    Args:
        servos: The servos.
        protocol: Wire protocol (default: the one the servos' family speaks out of the box).
        baudrate: Baud rate the servos listen at [bit/s].
        wire_timing: Time replies as on the wire (see the module docstring).
        mapping: Joint mapping, so that :meth:`set_joint` accepts joint names and SI values.
        clock: Time base of the servos' motion and of scheduled faults (default
            :func:`~armctl.clock.default_clock`). With a :class:`~armctl.clock.SimulatedClock`
            the servos move only as simulated time passes; replies go out as soon as a request
            arrives either way, so a client's read timeout never sees simulated time.
    """

    def __init__(self, servos: Iterable[SimServoSpec], protocol: Protocol | None = None,
                 baudrate: int = 1_000_000, *, wire_timing: bool = False,
                 mapping: JointLookup | None = None, clock: Clock | None = None):
        servos = list(servos)
        if protocol is None:
            if not servos:
                raise InputError("a simulated bus without servos needs its protocol named")
            protocol = factory_protocol(table_for(servos[0].model).family)
        self.protocol = protocol
        self.clock = clock if clock is not None else default_clock()
        self.baudrate = baudrate
        self.wire_timing = wire_timing
        self.mapping = mapping
        self.servos: list[SimServo] = []
        family = protocol.family
        rules = RULES[protocol]
        for s in servos:
            table = table_for(s.model)
            if table.family is not family:
                raise InputError(f"servo {s.servo_id}: a {s.model} does not speak "
                                 f"{protocol.value}")
            if any(o.id == s.servo_id for o in self.servos):
                raise InputError(f"servo id {s.servo_id} is used twice on the simulated bus")
            servo = SimServo(table, s.servo_id, baudrate, s.position, clock=self.clock,
                             rules=rules())
            mode = table.vendor.multi_turn_mode
            if s.multi_turn and mode is not None:
                servo.set(Register.OPERATING_MODE, mode)
            if s.homing_offset:
                servo.set(Register.HOMING_OFFSET, s.homing_offset)
            servo.set_present_position(s.position)
            self.servos.append(servo)
        self._wire = rules.wire()
        self._dispatch = Dispatcher(self._wire)
        self._faults: list[F.Fault] = []
        self._skips: dict[int, int] = {}  # id(reply fault) -> replies to let through first
        self._scheduled: list[tuple[float, F.Fault]] = []
        self._lock = threading.RLock()
        self._thread: threading.Thread | None = None
        self._stop = threading.Event()
        self._master = self._slave = -1
        self._wake_r = self._wake_w = -1
        self._wire_free = 0.0
        self._outbox: deque[tuple[float, bytes, bool]] = deque()  # (due, packet, last of group)
        self._started_at = 0.0
        self.port = ""
        self.requests = 0
        self.trace: list[tuple[str, bytes]] | None = None

    # ---- life cycle -------------------------------------------------------------------------
    def start(self) -> str:
        """Create the pty and start answering; returns the port path."""
        if self._thread is not None:
            return self.port
        self._master, self._slave = os.openpty()
        tty.setraw(self._slave)  # no echo, no CR/NL translation before pyserial opens it
        tty.setraw(self._master)
        self.port = os.ttyname(self._slave)
        self._wake_r, self._wake_w = os.pipe()
        self._outbox.clear()
        self._stop.clear()
        self._started_at = self.clock.now()
        self._thread = threading.Thread(target=self._run, name="armctl-simbus", daemon=True)
        self._thread.start()
        return self.port

    def stop(self) -> None:
        """Stop answering and close the pty."""
        if self._thread is None:
            return
        self._stop.set()
        os.write(self._wake_w, b"x")
        self._thread.join(timeout=2.0)
        self._thread = None
        for fd in (self._master, self._slave, self._wake_r, self._wake_w):
            with contextlib.suppress(OSError):
                os.close(fd)
        self._master = self._slave = self._wake_r = self._wake_w = -1

    def unplug(self) -> None:
        """Pull the adapter out: stop answering and remove the pty while clients have it open.

        Their next read or write of the port fails and its device path is gone, as when a USB
        adapter is unplugged.
        """
        self.stop()

    def __enter__(self) -> SimulatedBus:
        self.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self.stop()

    # ---- state for tests and teaching ---------------------------------------------------------
    def servo(self, servo_id: int) -> SimServo:
        """The servo whose id register is ``servo_id``.

        Raises:
            InputError: If no servo has that id.
        """
        for s in self.servos:
            if s.id == servo_id:
                return s
        raise InputError(f"no simulated servo with id {servo_id}; ids: "
                         f"{', '.join(str(s.id) for s in self.servos)}")

    @property
    def positions(self) -> dict[int, int]:
        """Present position of every servo [tick], by id."""
        with self._lock:
            out = {}
            for s in self.servos:
                s.read(0, 1)  # advance the dynamics
                out[s.id] = s.present_position()
            return out

    def joint_positions(self) -> dict[str, float]:
        """Joint values [rad] or [m] through the mapping, by joint name.

        Raises:
            InputError: If the bus was built without a joint mapping.
        """
        mapping = self._need_mapping()
        ticks = self.positions
        return {j.name: j.to_joint(ticks[j.servo_id]) for j in mapping.joints}

    def set_joint(self, joint_or_id: str | int, value: float) -> None:
        """Hand-guide a servo whose torque is off.

        Args:
            joint_or_id: A joint name (then ``value`` is in joint units, [rad] or [m], converted
                through the joint mapping) or a servo id (then ``value`` is the present position
                in [tick]).
            value: The new position.

        Raises:
            InputError: For an unknown joint or id, or a servo with torque on (a real servo would
                resist; turn its torque off first).
        """
        if isinstance(joint_or_id, str):
            joint = self._need_mapping().joint(joint_or_id)
            sid, ticks = joint.servo_id, round(joint.to_ticks(value))
        else:
            sid, ticks = int(joint_or_id), round(value)
        with self._lock:
            servo = self.servo(sid)
            if servo.torque:
                raise InputError(f"servo {sid} has torque on; it cannot be moved by hand. Turn "
                                 "its torque off first (set_torque(False) or 'armctl torque').")
            servo.set_present_position(ticks)

    def _need_mapping(self) -> JointLookup:
        if self.mapping is None:
            raise InputError("this simulated bus has no joint mapping; build it with "
                             "armctl.servo.simulated_bus(spec) or address servos by id")
        return self.mapping

    def power_cycle(self, servo_id: int | None = None) -> None:
        """Power-cycle one servo (or all): like a reboot, and clears its state faults."""
        with self._lock:
            for s in self.servos if servo_id is None else [self.servo(servo_id)]:
                s.reboot()
                s.model_override = None
                s.set(Register.MODEL_NUMBER, s.table.model_number)
                self._faults = [f for f in self._faults if getattr(f, "servo_id", None) != s.id]

    # ---- faults -------------------------------------------------------------------------------
    def inject(self, fault: F.Fault, at: float | None = None) -> None:
        """Inject a fault now, or ``at`` seconds after the bus started.

        Args:
            fault: One of the fault dataclasses of :mod:`armctl.servo.sim.faults`.
            at: Time after :meth:`start` [s]; ``None`` means now.
        """
        if at is not None:
            with self._lock:
                self._scheduled.append((at, fault))
            return
        with self._lock:
            sid = getattr(fault, "servo_id", None)
            if sid is not None:
                self.servo(sid)
            if isinstance(fault, F.HardwareAlarm):
                servo = self.servo(fault.servo_id)
                servo.raise_alarm(servo.vendor.alarm_bit(fault.alarm))
            elif isinstance(fault, F.LockupAfterOverload):
                servo = self.servo(fault.servo_id)
                servo.raise_alarm(0x20)
                servo.locked_up = True
            elif isinstance(fault, F.WrongModel):
                servo = self.servo(fault.servo_id)
                servo.model_override = fault.model_number
                servo.set(Register.MODEL_NUMBER, fault.model_number)
            elif isinstance(fault, F.Obstacle):
                self.servo(fault.servo_id).block_at(fault.ticks)
            self._skips.pop(id(fault), None)  # a new fault acts on the next reply
            self._faults.append(fault)

    def clear_faults(self, servo_id: int | None = None) -> None:
        """Remove injected faults (of one servo, or all) and clear their alarms and lock-ups."""
        with self._lock:
            keep = []
            for f in self._faults:
                sid = getattr(f, "servo_id", None)
                if servo_id is None or sid == servo_id:
                    if sid is not None:
                        s = self.servo(sid)
                        s.alarm_bits, s.locked_up, s.model_override = 0, False, None
                        s.obstacle = None
                        s.set(Register.HARDWARE_ERROR, 0)
                        s.set(Register.MODEL_NUMBER, s.table.model_number)
                    continue
                keep.append(f)
            self._faults = keep
            if servo_id is None:
                self._scheduled.clear()

    @property
    def faults(self) -> tuple[F.Fault, ...]:
        """The active faults."""
        with self._lock:
            return tuple(self._faults)

    def load_scenario(self, path: str | Path) -> int:
        """Schedule the faults of a YAML scenario file (see ``docs/bus.md``).

        Returns:
            The number of faults scheduled.
        """
        from armctl.servo.sim.scenario import load_scenario

        items = load_scenario(path)
        for at, fault in items:
            self.inject(fault, at if at > 0 else None)
        return len(items)

    def start_trace(self) -> list[tuple[str, bytes]]:
        """Record every instruction received (``"rx"``) and reply sent (``"tx"``) from now on.

        Returns:
            The list the records are appended to.
        """
        self.trace = []
        return self.trace

    def _missing(self, servo: SimServo) -> bool:
        return servo.locked_up or any(
            isinstance(f, F.MissingServo) and f.servo_id == servo.id for f in self._faults)

    def _take_reply_faults(self, sid: int) -> list[F.Fault]:
        """The reply faults that hit this reply (using up one of their count).

        A fault with ``every`` = N lets N - 1 replies through after each one it hits.
        """
        hit: list[F.Fault] = []
        keep: list[F.Fault] = []
        skips: dict[int, int] = {}
        for f in self._faults:
            if isinstance(f, _REPLY_FAULTS) and getattr(f, "servo_id", sid) == sid:
                wait = self._skips.get(id(f), 0)
                if wait > 0:  # this reply passes
                    keep.append(f)
                    skips[id(f)] = wait - 1
                    continue
                hit.append(f)
                every = f.every
                if f.count is not None and f.count > 1:
                    f = _with_count(f, f.count - 1)
                elif f.count is not None:
                    continue  # used up
                keep.append(f)
                skips[id(f)] = every - 1
            else:
                keep.append(f)
                if id(f) in self._skips:
                    skips[id(f)] = self._skips[id(f)]
        self._faults = keep
        self._skips = skips
        return hit

    # ---- the bus thread ---------------------------------------------------------------------
    def _run(self) -> None:
        buf = bytearray()
        last_rx = time.monotonic()
        while not self._stop.is_set():
            self._fire_scheduled()
            next_due = self._flush_outbox()
            timeout = 0.02 if next_due is None else min(0.02, max(0.0, next_due -
                                                                  time.monotonic()))
            try:
                ready, _, _ = select.select([self._master, self._wake_r], [], [], timeout)
            except (OSError, ValueError):
                return
            now = time.monotonic()
            if self._master not in ready:
                if buf and now - last_rx > 0.05:
                    buf.clear()  # a torn packet: the servos drop it after the byte gap
                continue
            try:
                data = os.read(self._master, 4096)
            except OSError:
                time.sleep(0.001)
                continue
            last_rx = now
            buf += data
            self._fire_scheduled()  # due by the clock, which may be simulated: before answering
            for ins in self._wire.frame(buf):
                self.requests += 1
                if self.trace is not None:
                    self.trace.append(("rx", ins.raw))
                with self._lock:
                    try:
                        replies = self._handle(ins)
                    except (IndexError, ValueError, OverflowError):
                        replies = []  # parameters too short or malformed: ignored
                self._send(ins, replies, now)

    def _fire_scheduled(self) -> None:
        if not self._scheduled:
            return
        elapsed = self.clock.now() - self._started_at
        with self._lock:
            due = [f for at, f in self._scheduled if at <= elapsed]
            self._scheduled = [(at, f) for at, f in self._scheduled if at > elapsed]
        for f in due:
            self.inject(f)

    def _send(self, ins: Instruction, replies: list[Reply],
              received: float) -> None:
        """Queue the replies to an instruction at the times they are due, in wire order.

        A late reply (:class:`~.faults.LateReply`, :class:`~.faults.LatencySpike`) is held
        back like bytes in a slow USB adapter: the replies after it wait behind it, but the bus
        goes on hearing instructions meanwhile.
        """
        t = received
        tick = 10.0 / self.baudrate
        if self.wire_timing:
            t = max(received, self._wire_free) + ins.size * tick
        items: list[tuple[float, bytes]] = []  # (when it is due, packet)
        for servo, pkt in replies:
            extra = 0.0
            if servo is not None:
                for f in self._take_reply_faults(servo.id):
                    if isinstance(f, F.DroppedReply):
                        pkt = b""
                    elif isinstance(f, F.CorruptedReply) and pkt:
                        pkt = pkt[:-1] + bytes([pkt[-1] ^ 0x5A])
                    elif isinstance(f, F.TruncatedReply):
                        pkt = pkt[:f.keep]
                    elif isinstance(f, (F.LateReply, F.LatencySpike)):
                        extra += f.delay
            if self.wire_timing:
                t += (servo.return_delay if servo is not None else 0.0) + len(pkt) * tick
            if pkt:
                items.append((t + extra, pkt))
        self._wire_free = t
        for i, (due, pkt) in enumerate(items):
            if self._outbox:  # the line is in order: nothing overtakes a held-back reply
                due = max(due, self._outbox[-1][0])
            self._outbox.append((due, pkt, i == len(items) - 1))
        self._flush_outbox()

    def _flush_outbox(self) -> float | None:
        """Write the queued replies that are due (sleeping for ones due within 5 ms).

        Sleeping for less than the OS timer allows would make every reply late; so a reply
        that is not the last of its group may go out up to ``_EARLY`` early. The last one
        (which completes the host's transaction) is never early.

        Returns:
            When the next queued reply is due, or ``None`` when none is queued.
        """
        pending = bytearray()
        while self._outbox:
            due, pkt, last = self._outbox[0]
            wait = due - time.monotonic()
            if wait > _INLINE:
                break
            if wait > (0.0 if last else _EARLY):
                self._write(pending)
                pending.clear()
                if last:
                    _sleep_until(due)
                else:
                    time.sleep(wait)
            if self.trace is not None:
                self.trace.append(("tx", pkt))
            pending += pkt
            self._outbox.popleft()
        self._write(pending)
        return self._outbox[0][0] if self._outbox else None

    def _write(self, data: bytes | bytearray) -> None:
        if data:
            with contextlib.suppress(OSError):
                os.write(self._master, data)

    # ---- instruction semantics -------------------------------------------------------------
    def _handle(self, ins: Instruction) -> list[Reply]:
        if ins.inst == REBOOT and ins.valid:
            for s in self.servos:  # a locked-up servo still obeys a reboot, without a reply
                if s.locked_up and ins.servo_id in (s.id, BROADCAST):
                    s.reboot()
                    self._faults = [f for f in self._faults if not (
                        isinstance(f, F.LockupAfterOverload) and f.servo_id == s.id)]
                    return []
        baud = client_baudrate(self._slave)
        live = {s.id: s for s in self.servos
                if not self._missing(s) and (baud is None or baud == s.baudrate)}
        return self._dispatch.handle(ins, live)


def _sleep_until(due: float) -> None:
    """Wait until the monotonic clock reaches ``due`` [s], on time to a few microseconds.

    The OS wakes a sleeping thread tens of microseconds late (timer slack, scheduling), which
    would add to every transaction; so the last :data:`_SPIN` is spent polling the clock.
    """
    rest = due - time.monotonic() - _SPIN
    if rest > 0:
        time.sleep(rest)
    while time.monotonic() < due:
        pass


def _with_count(fault: F.Fault, count: int) -> F.Fault:
    from dataclasses import replace

    out: F.Fault = replace(fault, count=count)  # type: ignore[arg-type]
    return out
