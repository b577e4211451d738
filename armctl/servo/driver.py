"""One narrow bus contract for Dynamixel and Feetech servos, over the vendor SDKs.

:class:`ServoBus` opens a port (no I/O in the constructor; use it as a context manager), pings
and scans, reads and writes registers by name, sync-reads servo feedback for many ids in one
transaction and sync-writes goals, switches torque and reboots. It adds what the SDKs lack:
bounded retries of failed transactions with input flushed before each, timeouts that fit the
baud rate, the error byte that the SDKs' group sync read drops (armctl reads the group replies
itself, one status packet per id in request order), and exceptions that name the port, the
servo, the register and what the servo answered.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from typing import Any, TypeVar

from armctl.config.bus import Protocol
from armctl.errors import InputError
from armctl.servo import errors as E
from armctl.servo.codec import decode, encode, from_le, to_le
from armctl.servo.sdk import Dxl1Sdk, DxlSdk, FeetechSdk, Sdk
from armctl.servo.status import Feedback, PingResult, StatusStyle, alarms_in, refusal
from armctl.servo.tables import (
    Alarm,
    ControlTable,
    Family,
    Register,
    alarms_from_bits,
    table_for,
    table_for_model_number,
)

__all__ = ["ServoBus"]

T = TypeVar("T", bound=tuple[Any, ...])

FEEDBACK = (Register.PRESENT_POSITION, Register.PRESENT_VELOCITY, Register.PRESENT_LOAD,
            Register.PRESENT_VOLTAGE, Register.PRESENT_TEMPERATURE)


class ServoBus:
    """A serial servo bus driven through the vendor SDK.

    Args:
        port: Serial device path (the pty path for the simulated bus).
        protocol: Wire protocol.
        baudrate: Baud rate [bit/s].
        models: Expected model per servo id; reads and writes use that model's control table.
        retries: Extra attempts after a timeout or corrupt reply (bounded).
        latency_ms: USB adapter latency [ms] used in reply timeouts (FTDI default 16; the
            simulated bus needs little).
    """

    def __init__(self, port: str, protocol: Protocol, baudrate: int = 1_000_000, *,
                 models: Mapping[int, str] | None = None, retries: int = 2,
                 latency_ms: float = 16.0):
        self.port = port
        self.protocol = protocol
        self.baudrate = baudrate
        self.retries = max(0, int(retries))
        self.latency_ms = latency_ms
        self.tables: dict[int, ControlTable] = {
            sid: table_for(m) for sid, m in (models or {}).items()}
        self.family = Family.FEETECH if protocol is Protocol.FEETECH else Family.DYNAMIXEL
        self.p1 = protocol is Protocol.DYNAMIXEL1  # error bit field, no sync read, no reboot
        self.style = StatusStyle.of(protocol)
        for sid, t in self.tables.items():
            if t.family is not self.family:
                raise InputError(f"servo {sid} is a {t.model} ({t.family.value}) on a "
                                 f"{protocol.value} bus; fix the bus protocol or the model")
        self._sdk: Sdk | None = None
        self._lock = threading.RLock()

    # ---- life cycle -------------------------------------------------------------------------
    def open(self) -> ServoBus:
        """Open the port.

        Raises:
            PortError: The port is missing, busy, not permitted, or the baud rate is refused.
        """
        if self._sdk is not None:
            return self
        cls: type[Sdk] = FeetechSdk if self.family is Family.FEETECH else (
            Dxl1Sdk if self.p1 else DxlSdk)
        sdk = cls(self.port, self.latency_ms)
        try:
            ok = sdk.open(self.baudrate)
        except Exception as exc:  # pyserial raises SerialException (an OSError subclass)
            raise E.port_error(self.port, exc) from exc
        if not ok:
            raise E.PortError(f"the {self.protocol.value} SDK refuses {self.baudrate} baud",
                              self.port, fix="use a baud rate the servos and the SDK support")
        fd = sdk.fileno()
        if fd is not None:
            try:
                import fcntl

                fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
            except ImportError:
                pass
            except OSError as exc:
                sdk.close()
                raise E.PortError("the port is busy: another armctl program is using it",
                                  self.port, fix="close the other program (armctl status, "
                                  "sim or a script) and try again") from exc
        self._sdk = sdk
        return self

    def close(self) -> None:
        """Close the port (safe to call twice)."""
        with self._lock:
            if self._sdk is not None:
                self._sdk.close()
                self._sdk = None

    def __enter__(self) -> ServoBus:
        return self.open()

    def __exit__(self, *exc: object) -> None:
        self.close()

    @property
    def is_open(self) -> bool:
        """Whether the port is open."""
        return self._sdk is not None

    def _need(self) -> Sdk:
        if self._sdk is None:
            raise E.PortError("the bus is not open", self.port,
                              fix="call open() or use 'with bus:' first")
        return self._sdk

    def table(self, sid: int) -> ControlTable:
        """The control table used for servo ``sid``.

        Raises:
            InputError: If the servo's model is unknown (give it in ``models``).
        """
        try:
            return self.tables[sid]
        except KeyError:
            raise InputError(f"servo {sid} on {self.port} has no known model; pass it in "
                             "'models' or run 'armctl scan' to find it") from None

    # ---- transactions with retries ------------------------------------------------------------
    def _retry(self, what: str, sid: int | None, reg: str | None, call: Callable[[Sdk], T],
               retries: int | None = None) -> T:
        """Run ``call`` (which returns the SDK result code first) with bounded retries.

        Input is flushed before every attempt; timeouts and corrupt replies are retried.
        """
        sdk = self._need()
        result = sdk.SUCCESS
        attempts = 1 + (self.retries if retries is None else retries)
        for _attempt in range(attempts):
            with self._lock:
                sdk.flush_input()
                out = call(sdk)
            result = out[0]
            if result == sdk.SUCCESS:
                return out
            if result not in (sdk.TIMEOUT, sdk.CORRUPT):
                break
        text = sdk.result_text(result)
        tries = f"after {attempts} attempt" + ("s" if attempts > 1 else "")
        if result == sdk.TIMEOUT:
            raise E.NoReplyError(f"no reply to {what} {tries} ({text})", self.port, sid, reg,
                                 fix="check the cable, power, id and baud rate "
                                     "('armctl scan --port ... --baud all')")
        if result == sdk.CORRUPT:
            raise E.CorruptReplyError(f"corrupt reply to {what} {tries} ({text})", self.port,
                                      sid, reg, fix="check wiring, power supply voltage and "
                                      "that no two servos share an id")
        raise E.CommError(f"{what} failed: {text}", self.port, sid, reg)

    def ping(self, sid: int, retries: int | None = None) -> PingResult:
        """Ping one servo.

        Args:
            sid: Servo id.
            retries: Extra attempts (default: the bus's).

        Raises:
            NoReplyError: If it does not answer.
        """
        def call(sdk: Sdk) -> tuple[int, int, int | None, int]:
            model, fw, result, error = sdk.ping(sid)
            return result, model, fw, error
        _, model, fw, _ = self._retry("ping", sid, None, call, retries)
        known = table_for_model_number(self.family, model)
        return PingResult(sid, model, known.model if known else None, fw)

    def scan(self, ids: Iterable[int] | None = None) -> list[PingResult]:
        """The servos that answer: a broadcast ping, or unicast pings of ``ids``."""
        sdk = self._need()
        out = []
        if ids is None and self.p1:
            ids = range(253)  # Protocol 1.0 has no broadcast ping
        if ids is None:
            with self._lock:
                sdk.flush_input()
                found, _ = sdk.broadcast_ping(20.0 + 2 * self.latency_ms)
            for sid, (model, fw) in sorted(found.items()):
                known = table_for_model_number(self.family, model)
                out.append(PingResult(sid, model, known.model if known else None, fw))
            return out
        for sid in ids:
            try:
                out.append(self.ping(sid, retries=0))
            except E.CommError:
                continue
        return out

    def verify(self, expected: Mapping[int, str] | None = None) -> list[PingResult]:
        """Check that every expected servo answers and reports the expected model.

        Raises:
            ServoMissingError: For the first servo that does not answer.
            WrongModelError: For the first servo with another model number.
        """
        found = []
        for sid, model in (expected or {t: m.model for t, m in self.tables.items()}).items():
            table = table_for(model)
            try:
                res = self.ping(sid)
            except E.NoReplyError as exc:
                raise E.ServoMissingError(
                    f"servo {sid} ({model}) does not answer", self.port, sid,
                    fix="check its cable and power; check its id and baud rate with "
                        f"'armctl scan --port {self.port} --baud all'") from exc
            if res.model_number != table.model_number:
                name = res.model or "unknown to armctl"
                raise E.WrongModelError(
                    f"expected a {model} (model number {table.model_number})", self.port, sid,
                    "model_number", f"model number {res.model_number} ({name})",
                    fix="fix the servo's model in the config's bus section, or the wiring")
            found.append(res)
        return found

    # ---- registers ------------------------------------------------------------------------------
    def read(self, sid: int, register: Register | str) -> int:
        """Read one register (decoded: signed where the register is signed).

        Raises:
            CommError: Timeout or corrupt reply after the retries.
            ServoRejectedError: The servo answered with an error number.
        """
        reg = Register.parse(register) if isinstance(register, str) else register
        spec = self.table(sid).spec(reg)
        data, error = self._read_block(sid, spec.address, spec.size, f"read {reg.value}",
                                       reg.value)
        self._check(sid, reg, error, reading=True)
        return decode(spec, from_le(data))

    def _read_block(self, sid: int, addr: int, n: int, what: str, reg: str | None = None
                    ) -> tuple[list[int], int]:
        """``(data, error byte)`` of a READ of ``n`` bytes, retried like every transaction."""
        def call(sdk: Sdk) -> tuple[int, list[int], int]:
            try:
                data, result, error = sdk.read(sid, addr, n)
            except IndexError:  # SDK-DXL read helpers on an error reply without params
                return sdk.CORRUPT, [], 0
            if result == sdk.SUCCESS and not error and len(data) != n:
                return sdk.CORRUPT, data, error
            return result, data, error
        _, data, error = self._retry(what, sid, reg, call)
        return data, error

    def write(self, sid: int, register: Register | str, value: int) -> None:
        """Write one register, checking the value against the register's range first.

        Raises:
            InputError: For a read-only register or a value outside its range (nothing sent).
            EepromLockedError: EEPROM write refused (torque on, or locked).
            ServoRejectedError: The servo answered with another error number.
            ServoAlarmError: The servo reports a hardware alarm.
        """
        reg = Register.parse(register) if isinstance(register, str) else register
        table = self.table(sid)
        spec = table.spec(reg)
        if not spec.writable:
            raise E.AccessError("the register is read-only; nothing was sent", self.port, sid,
                                reg.value)
        if not spec.lo <= value <= spec.hi:
            raise InputError(f"servo {sid} {reg.value}: {value} is outside its range "
                             f"[{spec.lo}, {spec.hi}]; nothing was sent")
        data = to_le(encode(spec, value), spec.size)

        def call(sdk: Sdk) -> tuple[int, int]:
            return sdk.write(sid, spec.address, data)
        _, error = self._retry(f"write {reg.value}={value}", sid, reg.value, call)
        self._check(sid, reg, error, reading=False)
        target = sid
        if reg is Register.ID and value != sid:
            target = value
            self.tables[value] = self.tables.pop(sid)
        if self.family is Family.FEETECH and table.is_eeprom(reg):
            try:  # Feetech ignores locked EEPROM writes silently: read back
                back = self.read(target, reg)
            except E.NoReplyError:
                if target == sid:
                    raise
                self.tables[sid] = self.tables.pop(target)  # the id did not change
                back = self.read(sid, reg)
            if back != value:
                raise E.EepromLockedError(
                    f"EEPROM write of {value} was ignored (reads back {back})", self.port, sid,
                    reg.value, fix="turn torque off and write lock=0 first")

    def _check(self, sid: int, reg: Register | None, error: int, reading: bool) -> None:
        """Raise for a refusal; a hardware alarm only fails writes and commands."""
        name = reg.value if reg is not None else None
        ref = refusal(self.style, error)
        if ref is not None:
            text, access = ref
            table = self.tables.get(sid)
            if access and not reading and reg is not None and table is not None and \
                    table.is_eeprom(reg):
                raise E.EepromLockedError(
                    "EEPROM write refused", self.port, sid, name, text,
                    fix="turn torque off first (EEPROM is writable only with torque off): "
                        "'armctl torque CONFIG off'")
            if access and self.style is StatusStyle.DYNAMIXEL2:
                raise E.AccessError("access refused", self.port, sid, name, text)
            raise E.ServoRejectedError("the servo rejected the instruction", self.port, sid,
                                       name, text)
        found = alarms_in(self.style, error)
        if (found is None or found) and not reading and reg is not Register.TORQUE_ENABLE:
            self._raise_alarm(sid, name, found)

    def alarms(self, sid: int) -> tuple[Alarm, ...]:
        """The hardware alarms servo ``sid`` reports (Hardware Error Status / Status)."""
        bits = self.read(sid, Register.HARDWARE_ERROR)
        return alarms_from_bits(bits, self.family is Family.FEETECH)

    def _raise_alarm(self, sid: int, reg: str | None,
                     found: tuple[Alarm, ...] | None = None) -> None:
        if found is None:
            try:
                found = self.alarms(sid)
            except E.CommError:
                found = ()
        names = ", ".join(a.value for a in found) or "unknown"
        raise E.ServoAlarmError("hardware alarm", self.port, sid, reg, names,
                                fix="remove the cause (load, heat, supply voltage), then "
                                    "reboot the servo (ArmBus.reboot / power cycle)")

    # ---- group transactions -------------------------------------------------------------------
    def sync_read(self, ids: Sequence[int], registers: Sequence[Register]
                  ) -> dict[int, tuple[dict[Register, int], int]]:
        """Read several registers of many servos in one SYNC READ.

        Args:
            ids: Servo ids; replies are requested (and come) in this order.
            registers: Registers to read; one block covering all of them is requested.

        Returns:
            ``{id: ({register: value}, error byte)}``.

        Raises:
            NoReplyError: A servo did not answer (named; after the retries).
            InputError: The servos' tables disagree on the registers' addresses.
        """
        ids = list(ids)
        specs = [self.table(ids[0]).spec(r) for r in registers]
        for sid in ids[1:]:
            for s in specs:
                o = self.table(sid).spec(s.register)
                if (o.address, o.size) != (s.address, s.size):
                    raise InputError(f"servos {ids[0]} and {sid} keep {s.register.value} at "
                                     "different addresses; they cannot share a sync read")
        start = min(s.address for s in specs)
        n = max(s.address + s.size for s in specs) - start
        failed: list[int] = []

        def call(sdk: Sdk) -> tuple[int, dict[int, tuple[list[int], int]]]:
            got: dict[int, tuple[list[int], int]] = {}
            result = sdk.sync_read_tx(start, n, ids)
            if result != sdk.SUCCESS:
                return result, got
            for sid in ids:
                data, result, error = sdk.read_rx(sid, n)
                if result == sdk.SUCCESS and len(data) != n:
                    result = sdk.CORRUPT
                if result != sdk.SUCCESS:
                    failed[:] = [sid]
                    return result, got
                got[sid] = (data, error)
            return result, got
        try:
            if self._need().has_sync_read:
                _, got = self._retry(f"sync read of {n} bytes at {start}", None, None, call)
            else:  # Protocol 1.0: one read per servo
                got = {}
                for sid in ids:
                    failed[:] = [sid]
                    got[sid] = self._read_block(sid, start, n, "read of feedback")
        except E.CommError as exc:
            who = failed[0] if failed else None
            raise type(exc)(exc.problem, self.port, who, ", ".join(r.value for r in registers),
                            fix=exc.fix) from exc
        out = {}
        for sid, (data, error) in got.items():
            vals = {s.register: decode(s, from_le(data[s.address - start:
                                                       s.address - start + s.size]))
                    for s in specs}
            out[sid] = (vals, error)
        return out

    def read_feedback(self, ids: Sequence[int]) -> dict[int, Feedback]:
        """Position, velocity, load, voltage, temperature and alarms of many servos.

        One SYNC READ; a servo whose error byte flags an alarm is asked which (Dynamixel) or
        its error byte is the alarm itself (Feetech).
        """
        raw = self.sync_read(ids, FEEDBACK)
        out = {}
        for sid, (v, error) in raw.items():
            alarms = self._alarms_from_error(sid, error)
            vel = float(v[Register.PRESENT_VELOCITY])
            if self.family is Family.DYNAMIXEL:
                vel *= 0.229 / 60.0 * 4096
            out[sid] = Feedback(sid, v[Register.PRESENT_POSITION], vel, v[Register.PRESENT_LOAD],
                                v[Register.PRESENT_VOLTAGE] / 10.0,
                                v[Register.PRESENT_TEMPERATURE], error, alarms)
        return out

    def read_positions(self, ids: Sequence[int]) -> dict[int, tuple[int, tuple[Alarm, ...]]]:
        """Present positions [tick] and hardware alarms of many servos in one SYNC READ.

        The alarms come from each status packet's error byte (asked for by name from a
        Dynamixel servo whose alert bit is set).
        """
        raw = self.sync_read(ids, (Register.PRESENT_POSITION,))
        out = {}
        for sid, (v, error) in raw.items():
            out[sid] = (v[Register.PRESENT_POSITION], self._alarms_from_error(sid, error))
        return out

    def _alarms_from_error(self, sid: int, error: int) -> tuple[Alarm, ...]:
        found = alarms_in(self.style, error)
        if found is None:  # Dynamixel Alert bit: ask the servo which alarm
            return self.alarms(sid) or (Alarm.OVERLOAD,)
        return found

    def sync_write(self, register: Register, values: Mapping[int, int]) -> None:
        """Write one register of many servos in one SYNC WRITE (no reply).

        Raises:
            InputError: A value outside the register's range (nothing sent).
        """
        items = {}
        spec = None
        for sid, value in values.items():
            spec = self.table(sid).spec(register)
            if not spec.writable or not spec.lo <= value <= spec.hi:
                raise InputError(f"servo {sid} {register.value}: {value} is not writable or "
                                 f"outside [{spec.lo}, {spec.hi}]; nothing was sent")
            items[sid] = to_le(encode(spec, int(value)), spec.size)
        if spec is None:
            return

        def call(sdk: Sdk) -> tuple[int]:
            assert spec is not None  # mypy.
            return (sdk.sync_write(spec.address, spec.size, items),)
        self._retry(f"sync write of {register.value}", None, register.value, call)

    def set_torque(self, ids: Iterable[int], on: bool) -> None:
        """Switch torque on or off, servo by servo (each write is acknowledged)."""
        for sid in ids:
            self.write(sid, Register.TORQUE_ENABLE, 1 if on else 0)

    def reboot(self, sid: int, wait: float = 0.05) -> None:
        """Reboot a servo (clears latched alarms) and check it answers again.

        A reboot's status packet may be lost (DynamixelSDK#283), so a timeout is followed by
        pings instead of an error.

        Raises:
            ServoMissingError: If the servo does not answer after the reboot.
        """
        sdk = self._need()
        if not sdk.has_reboot:
            raise E.CommError("Dynamixel Protocol 1.0 has no reboot instruction", self.port, sid,
                              fix="power-cycle the servo")
        with self._lock:
            sdk.flush_input()
            sdk.reboot(sid)
        deadline = time.monotonic() + 0.5
        while True:
            time.sleep(wait)
            try:
                self.ping(sid)
                return
            except E.NoReplyError as exc:
                if time.monotonic() > deadline:
                    raise E.ServoMissingError("the servo does not answer after a reboot",
                                              self.port, sid,
                                              fix="power-cycle the servo") from exc
