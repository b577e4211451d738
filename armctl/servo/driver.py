"""One narrow bus contract for Dynamixel and Feetech servos, over the vendor SDKs.

:class:`ServoBus` opens a port (no I/O in the constructor; use it as a context manager), pings
and scans, reads and writes registers by name, sync-reads servo feedback for many ids in one
transaction and sync-writes goals, switches torque and reboots. It adds what the SDKs lack:
every status packet matched to its request (:mod:`armctl.servo.replies`: a late reply is never
taken for the answer to a later request), bounded retries with the line drained before each,
retries counted per servo, timeouts that fit the baud rate, the error byte that the SDKs' group
sync read drops, an exclusively opened port, I/O errors turned into bus errors, and exceptions
that name the port, the servo, the register and what the servo answered.
"""

from __future__ import annotations

import threading
import time
from collections.abc import Callable, Iterable, Mapping, Sequence
from dataclasses import dataclass
from typing import Any

from armctl.config.bus import Protocol
from armctl.errors import InputError
from armctl.servo import errors as E
from armctl.servo.codec import decode, encode, from_le, to_le
from armctl.servo.dynamixel.sdk import Dxl1Sdk, DxlSdk
from armctl.servo.feetech.sdk import FeetechSdk
from armctl.servo.replies import ReplyLedger, Window
from armctl.servo.sdk import IO_ERRORS, Sdk
from armctl.servo.status import Feedback, PingResult
from armctl.servo_tables import (
    VENDORS,
    Alarm,
    ControlTable,
    Register,
    RegisterSpec,
    table_for,
    table_for_model_number,
)

__all__ = ["ServoBus"]

#: The vendor adapter that speaks each protocol (the one place that picks a vendor).
_SDKS: dict[Protocol, type[Sdk]] = {
    Protocol.DYNAMIXEL: DxlSdk, Protocol.DYNAMIXEL1: Dxl1Sdk, Protocol.FEETECH: FeetechSdk}

#: Unanswered requests per servo after which the line is resynchronised (drained until quiet).
MAX_PENDING = 24
#: Silence [s] that ends a resynchronisation, and the longest one may take [s].
RESYNC_QUIET = 0.1
RESYNC_MAX = 1.0


@dataclass
class _Attempt:
    """The outcome of one attempt of a transaction.

    Attributes:
        result: SDK result code.
        value: What the transaction returns (on success).
        waited: The servo whose reply was missing or corrupt (on failure).
        received: Status packets received during the attempt (matched, late or stray).
    """

    result: int
    value: Any = None
    waited: int | None = None
    received: int = 0


@dataclass(frozen=True)
class _SyncPlan:
    """What a sync read of some registers from some servos asks for.

    Attributes:
        tables: The servos' tables it was planned with.
        start: First address of the block.
        size: Bytes of the block.
        what: The registers' names, for errors.
        request: The request, for errors.
        fields: ``(register, spec, first, end)`` of each register within the block.
    """

    tables: tuple[ControlTable, ...]
    start: int
    size: int
    what: str
    request: str
    fields: tuple[tuple[Register, RegisterSpec, int, int], ...]


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
        self.family = protocol.family
        self.vendor = VENDORS[self.family]  # ticks, units and conventions of the family
        #: The vendor adapter's class: the protocol's abilities and what its error byte means.
        self.adapter: type[Sdk] = _SDKS[protocol]
        for sid, t in self.tables.items():
            if t.family is not self.family:
                raise InputError(f"servo {sid} is a {t.model} ({t.family.value}) on a "
                                 f"{protocol.value} bus; fix the bus protocol or the model")
        self._sdk: Sdk | None = None
        self._lock = threading.RLock()
        self.ledger = ReplyLedger()
        self._late_now: list[int] = []
        self._plans: dict[tuple[tuple[int, ...], tuple[Register, ...]], _SyncPlan] = {}
        generic = table_for(self.vendor.generic_model)
        self._generic = generic  # for servos of unknown model (scan): model number, id, memory

    # ---- life cycle -------------------------------------------------------------------------
    def open(self) -> ServoBus:
        """Open the port, exclusively (no other program can use it while armctl does).

        Raises:
            PortError: The port is missing, not a serial port, busy (in use by another
                program), not permitted, or the baud rate is refused.
        """
        if self._sdk is not None:
            return self
        sdk = self.adapter(self.port, self.latency_ms)
        try:
            ok = sdk.open(self.baudrate)
        except Exception as exc:  # pyserial raises SerialException (an OSError subclass)
            raise E.port_error(self.port, exc) from exc
        if not ok:
            raise E.PortError(f"the {self.protocol.value} SDK refuses {self.baudrate} baud",
                              self.port, fix="use a baud rate the servos and the SDK support")
        self._sdk = sdk
        self.ledger = ReplyLedger()
        return self

    def close(self) -> None:
        """Close the port (safe to call twice, and after the port vanished)."""
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

    def retry_counts(self) -> dict[int, int]:
        """Failed attempts per servo id since the bus was opened.

        An attempt fails when its reply is missing, corrupt or late; each one is retried
        while the transaction has attempts left. The servo counted is the one whose reply
        failed (or, for late replies, the servo whose late replies held up the line).
        """
        with self._lock:
            return dict(self.ledger.retries)

    # ---- transactions: matching, retries, I/O errors --------------------------------------------
    def _transact(self, what: str, sid: int | None, reg: str | None,
                  call: Callable[[Sdk], _Attempt], retries: int | None = None,
                  replies: bool = True) -> Any:
        """Run ``call`` (one attempt: send a request, match its replies) with bounded retries.

        The line is drained before every attempt of a request with ``replies`` (late replies
        waiting in the input are read and recorded against their servos; every transmit then
        flushes the input); timeouts and corrupt replies are retried; an I/O error on the port
        is never retried.

        Raises:
            LateReplyError: Late replies were seen and no reply could be matched.
            NoReplyError, CorruptReplyError, CommError: After the retries.
            PortIOError, PortVanishedError: Reading or writing the port failed.
        """
        sdk = self._need()
        attempts = 1 + (self.retries if retries is None else max(0, retries))
        with self._lock:
            self._late_now = []
            blame: int | None = None
            outcome = _Attempt(sdk.SUCCESS)
            for _attempt in range(attempts):
                mark = len(self._late_now)
                try:
                    if replies:
                        self._drain(sdk)
                    outcome = call(sdk)
                except IO_ERRORS as exc:
                    raise E.port_io_error(self.port, exc) from exc
                if outcome.result == sdk.SUCCESS:
                    return outcome.value
                late = self._late_now[mark:]
                if outcome.result == sdk.TIMEOUT and late:
                    blame = late[0]  # its late reply held up the line
                elif not (outcome.result == sdk.TIMEOUT and outcome.received == 0
                          and blame is not None):
                    blame = outcome.waited  # (a silent retry keeps the earlier blame)
                self.ledger.count_retry(blame)
                if outcome.result not in (sdk.TIMEOUT, sdk.CORRUPT):
                    break
            late_seen = blame is not None and blame in self._late_now
        who = blame if blame is not None else sid
        result = outcome.result
        text = sdk.result_text(result)
        tries = f"after {attempts} attempt" + ("s" if attempts > 1 else "")
        if result == sdk.TIMEOUT and late_seen:
            raise E.LateReplyError(
                f"its replies arrive late, after their timeout, so none could be matched to "
                f"{what} {tries}", self.port, who, reg,
                fix="a slow USB adapter or a busy computer: lower the adapter's latency timer "
                    "(docs/bus.md) or raise latency_ms; check the servo's Return Delay Time")
        if result == sdk.TIMEOUT:
            raise E.NoReplyError(f"no reply to {what} {tries} ({text})", self.port, who, reg,
                                 fix="check the cable, power, id and baud rate "
                                     "('armctl scan --port ... --baud all')")
        if result == sdk.CORRUPT:
            raise E.CorruptReplyError(f"corrupt reply to {what} {tries} ({text})", self.port,
                                      who, reg, fix="check wiring, power supply voltage and "
                                      "that no two servos share an id")
        raise E.CommError(f"{what} failed: {text}", self.port, who, reg)

    def _drain(self, sdk: Sdk) -> int:
        """Read the packets waiting in the input (late replies are recorded)."""
        waiting = sdk.drain()
        for rsid, _err, data in waiting:
            if self.ledger.take_late(rsid, len(data)):
                self._late_now.append(rsid)
        return len(waiting)

    def _resync(self, sdk: Sdk, ids: Iterable[int]) -> None:
        """Drain the line until it stays quiet, then expect nothing more from ``ids``.

        Used when so many requests went unanswered that no read length is left free.

        Raises:
            LateReplyError: The line did not go quiet within :data:`RESYNC_MAX`.
        """
        ids = list(ids)
        start = quiet = time.monotonic()
        while True:
            now = time.monotonic()
            if sdk.waiting():
                self._drain(sdk)
                sdk.flush_input()  # a torn packet too
                quiet = now
            elif now - quiet >= RESYNC_QUIET:
                break
            if now - start > RESYNC_MAX:
                raise E.LateReplyError(
                    f"replies keep arriving for requests that timed out; the line did not go "
                    f"quiet within {RESYNC_MAX:g} s", self.port, ids[0] if ids else None,
                    fix="check the USB adapter (latency timer) and that no other program "
                        "uses the port")
            time.sleep(0.002)
        for sid in ids:
            self.ledger.matched(sid)

    def _window(self, sdk: Sdk, ids: Sequence[int], addr: int, size: int) -> Window:
        """A read window for ``ids`` whose reply length no pending reply has."""
        if not self.ledger.any_pending(ids):
            return Window(addr, size)
        memory = min(self.tables.get(i, self._generic).memory_size for i in ids)
        if all(self.ledger.count_pending(i) < MAX_PENDING for i in ids):
            win = self.ledger.window(ids, addr, size, memory)
            if win is not None:
                return win
        self._resync(sdk, ids)
        return Window(addr, size)

    def _collect(self, sdk: Sdk, ids: Sequence[int], n: int, refusal_ok: bool = False
                 ) -> _Attempt:
        """Receive the replies to the request just sent: one per id, in order, ``n`` bytes each.

        A packet is accepted for servo ``s`` only when its id is ``s`` and it carries ``n``
        data bytes (or, with ``refusal_ok``, no data and an error number: a refused read).
        Packets matching a pending entry are late replies (recorded, skipped); others are
        skipped. A servo further down the list answering means the ones before it are
        missing: their replies cannot follow.

        Returns:
            The attempt's outcome; ``value`` is ``{id: (error, data)}``.
        """
        got: dict[int, tuple[int, list[int]]] = {}
        order = {sid: i for i, sid in enumerate(ids)}
        received = 0
        result = sdk.SUCCESS
        while len(got) < len(ids):
            rx, result = sdk.receive()
            if result != sdk.SUCCESS:
                break
            received += 1
            rsid, err, data = sdk.status(rx)
            if rsid in order and rsid not in got and (len(data) == n or (
                    refusal_ok and not data and self.adapter.refusal(err) is not None
                    and 0 not in self.ledger.pending(rsid) - {n})):
                self.ledger.matched(rsid)
                got[rsid] = (err, data)
                if order[rsid] == len(ids) - 1:
                    break  # the last one: nothing more of this request can come
                continue
            if self.ledger.take_late(rsid, len(data)):
                self._late_now.append(rsid)
        missing = [sid for sid in ids if sid not in got]
        if not missing:
            return _Attempt(sdk.SUCCESS, got, received=received)
        if result == sdk.SUCCESS:
            result = sdk.TIMEOUT  # a later servo answered: the missing one will not
        return _Attempt(result, got, missing[0], received)

    def _send(self, sdk: Sdk, ids: Sequence[int], n: int, send: Callable[[], int]) -> int:
        """Send a request and record the replies it asks for as pending."""
        result = send()
        if result == sdk.SUCCESS:
            for sid in ids:
                self.ledger.sent(sid, n)
        return result

    def _barrier(self, sdk: Sdk, sid: int) -> _Attempt | None:
        """Make sure no reply of servo ``sid`` can be confused with an acknowledgement.

        Sent before a request whose reply length cannot vary (a write's acknowledgement, a
        ping) when a reply of that length is pending: a read of the id register with a
        distinguishable length; its matched reply settles every earlier request.

        Returns:
            ``None`` when the line is in step, else the failed attempt.
        """
        spec = self.tables.get(sid, self._generic).spec(Register.ID)
        win = self._window(sdk, [sid], spec.address, spec.size)
        res = self._send(sdk, [sid], win.length,
                         lambda: sdk.send_read(sid, win.start, win.length))
        if res != sdk.SUCCESS:
            return _Attempt(res, waited=sid)
        out = self._collect(sdk, [sid], win.length)
        return None if out.result == sdk.SUCCESS else out

    def _exchange(self, sdk: Sdk, sid: int, n: int, send: Callable[[], int],
                  settle_corrupt: bool = False) -> _Attempt:
        """One request with a fixed reply length ``n`` (barrier first when needed).

        Args:
            sdk: The open SDK.
            sid: The servo.
            n: The reply's data length [bytes].
            send: Sends the request; returns the SDK's result code.
            settle_corrupt: Take a corrupt reply as this request's own reply (its entry is
                settled, so a retry needs no barrier). Only for requests whose reply carries
                nothing a stale one could hide (a ping's status, a reboot's); a write's
                acknowledgement carries the servo's error byte, so :meth:`write` reads back
                instead.
        """
        if n in self.ledger.pending(sid):
            failed = self._barrier(sdk, sid)
            if failed is not None:
                return failed
        res = self._send(sdk, [sid], n, send)
        if res != sdk.SUCCESS:
            return _Attempt(res, waited=sid)
        out = self._collect(sdk, [sid], n)
        if out.result == sdk.CORRUPT and settle_corrupt:
            self.ledger.unreadable(sid, n)  # reads keep avoiding the length
        return out

    def _read_back(self, sdk: Sdk, sid: int, addr: int, data: Sequence[int]) -> _Attempt:
        """Read back what a write whose acknowledgement came corrupt should have written.

        The corrupt packet settles nothing: it may have been another packet, with the real
        acknowledgement still to come. The read's length differs from every pending reply
        length, so that acknowledgement, if it comes, is taken as late; the read's matched
        reply brings the servo in step and carries its present error byte.

        Returns:
            The attempt; on success ``value`` is ``(error byte, whether the register holds
            data)``.
        """
        n = len(data)
        win = self._window(sdk, [sid], addr, n)
        res = self._send(sdk, [sid], win.length, lambda: sdk.send_read(sid, win.start, win.length))
        if res != sdk.SUCCESS:
            return _Attempt(res, waited=sid)
        out = self._collect(sdk, [sid], win.length)
        if out.result == sdk.SUCCESS:
            error, got = out.value[sid]
            out.value = (error, win.slice(got, addr, n) == list(data))
        return out

    def ping(self, sid: int, retries: int | None = None) -> PingResult:
        """Ping one servo (Feetech and Protocol 1.0: then read its model number).

        Args:
            sid: Servo id.
            retries: Extra attempts (default: the bus's).

        Raises:
            NoReplyError: If it does not answer.
        """
        def call(sdk: Sdk) -> _Attempt:
            out = self._exchange(sdk, sid, sdk.ping_size, lambda: sdk.send_ping(sid), True)
            if out.result == sdk.SUCCESS:
                out.value = out.value[sid][1]
            return out
        data = self._transact("ping", sid, None, call, retries)
        if len(data) >= 3:  # Dynamixel 2.0: model number and firmware in the ping status
            model, fw = data[0] | data[1] << 8, data[2]
        else:
            spec = self.tables.get(sid, self._generic).spec(Register.MODEL_NUMBER)
            raw, _ = self._read_block(sid, spec.address, spec.size, "read model_number",
                                      "model_number", retries)
            model, fw = raw[0] | raw[1] << 8, None
        known = table_for_model_number(self.family, model)
        return PingResult(sid, model, known.model if known else None, fw)

    def scan(self, ids: Iterable[int] | None = None) -> list[PingResult]:
        """The servos that answer: a broadcast ping, or unicast pings of ``ids``."""
        sdk = self._need()
        out = []
        if ids is None and not self.adapter.has_broadcast_ping:
            ids = range(253)  # Protocol 1.0: ping ids one by one
        if ids is None:
            with self._lock:
                try:
                    self._drain(sdk)
                    found, _ = sdk.broadcast_ping(20.0 + 2 * self.latency_ms)
                except IO_ERRORS as exc:
                    raise E.port_io_error(self.port, exc) from exc
            spec = self._generic.spec(Register.MODEL_NUMBER)
            for sid, (model, fw) in sorted(found.items()):
                if not model:  # Feetech: the ping status has no model number; read it
                    try:
                        raw, _ = self._read_block(sid, spec.address, spec.size,
                                                  "read model_number", "model_number")
                        model = raw[0] | raw[1] << 8
                    except E.CommError:
                        pass
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
            except E.LateReplyError:
                raise  # it answers, too late: say so
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

    def _read_block(self, sid: int, addr: int, n: int, what: str, reg: str | None = None,
                    retries: int | None = None) -> tuple[list[int], int]:
        """``(data, error byte)`` of a READ of ``n`` bytes, matched and retried.

        ``data`` is empty when the servo refused the read (an error number without data).
        """
        def call(sdk: Sdk) -> _Attempt:
            win = self._window(sdk, [sid], addr, n)
            res = self._send(sdk, [sid], win.length,
                             lambda: sdk.send_read(sid, win.start, win.length))
            if res != sdk.SUCCESS:
                return _Attempt(res, waited=sid)
            out = self._collect(sdk, [sid], win.length, refusal_ok=True)
            if out.result == sdk.SUCCESS:
                error, data = out.value[sid]
                out.value = (win.slice(data, addr, n) if data else [], error)
            return out
        data, error = self._transact(what, sid, reg, call, retries)
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
        unsure = [False]  # the last acknowledgement came corrupt: was the value written?

        def call(sdk: Sdk) -> _Attempt:
            if unsure[0]:  # never a resend that a late acknowledgement could answer
                back = self._read_back(sdk, sid, spec.address, data)
                if back.result != sdk.SUCCESS:
                    return back
                error, written = back.value
                if written:  # done: the read's error byte is the servo's state after it
                    back.value = error
                    return back
                unsure[0] = False  # not written; the line is in step: write again
            out = self._exchange(sdk, sid, 0, lambda: sdk.send_write(sid, spec.address, data))
            if out.result == sdk.SUCCESS:
                out.value = out.value[sid][0]
            unsure[0] = out.result == sdk.CORRUPT
            return out
        error = self._transact(f"write {reg.value}={value}", sid, reg.value, call)
        self._check(sid, reg, error, reading=False)
        target = sid
        if reg is Register.ID and value != sid:
            target = value
            self.tables[value] = self.tables.pop(sid)
        # a new baud rate is checked by the caller at that rate (the servo no longer hears this)
        if self.vendor.eeprom_lock and table.is_eeprom(reg) and reg is not Register.BAUD_RATE:
            try:  # a locked EEPROM ignores writes silently (Feetech): read back
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
        ref = self.adapter.refusal(error)
        if ref is not None:
            text, access = ref
            table = self.tables.get(sid)
            if access and not reading and reg is not None and table is not None and \
                    table.is_eeprom(reg):
                raise E.EepromLockedError(
                    "EEPROM write refused", self.port, sid, name, text,
                    fix="turn torque off first (EEPROM is writable only with torque off): "
                        "'armctl torque CONFIG off'")
            if access and self.adapter.access_errors:
                raise E.AccessError("access refused", self.port, sid, name, text)
            raise E.ServoRejectedError("the servo rejected the instruction", self.port, sid,
                                       name, text)
        found = self.adapter.alarms_in(error)
        if (found is None or found) and not reading and reg is not Register.TORQUE_ENABLE:
            self._raise_alarm(sid, name, found)

    def alarms(self, sid: int) -> tuple[Alarm, ...]:
        """The hardware alarms servo ``sid`` reports (Hardware Error Status / Status)."""
        bits = self.read(sid, Register.HARDWARE_ERROR)
        return tuple(a for a in Alarm if bits & self.vendor.alarm_bit(a))

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
        plan, got = self._sync_read_block(list(ids), tuple(registers))
        fields = plan.fields
        return {sid: ({reg: decode(spec, from_le(data[lo:hi])) for reg, spec, lo, hi in fields},
                      error) for sid, (data, error) in got.items()}

    def _sync_read_block(self, ids: list[int], registers: tuple[Register, ...]
                         ) -> tuple[_SyncPlan, dict[int, tuple[list[int], int]]]:
        """The plan and ``{id: (block data, error byte)}`` of a sync read (see :meth:`sync_read`).

        Raises:
            NoReplyError, CorruptReplyError: A servo did not answer, or refused (named).
        """
        plan = self._sync_plan(tuple(ids), registers)
        start, n, what = plan.start, plan.size, plan.what

        def call(sdk: Sdk) -> _Attempt:
            win = self._window(sdk, ids, start, n)
            res = self._send(sdk, ids, win.length,
                             lambda: sdk.sync_read_tx(win.start, win.length, ids))
            if res != sdk.SUCCESS:
                return _Attempt(res, waited=ids[0])
            out = self._collect(sdk, ids, win.length, refusal_ok=True)
            if out.result == sdk.SUCCESS:
                exact = win.start == start and win.length == n  # the block itself
                out.value = {sid: (data if exact or not data else win.slice(data, start, n),
                                   error) for sid, (error, data) in out.value.items()}
            return out
        if self._need().has_sync_read:
            got = self._transact(plan.request, ids[0], what, call)
        else:  # Protocol 1.0: one read per servo
            got = {sid: self._read_block(sid, start, n, "read of feedback", what)
                   for sid in ids}
        for sid, (data, error) in got.items():
            if not data:  # refused: an error number and no data
                self._check(sid, None, error, reading=True)
                raise E.CorruptReplyError("a reply without data", self.port, sid, what)
        return plan, got

    def _sync_plan(self, ids: tuple[int, ...], registers: tuple[Register, ...]) -> _SyncPlan:
        """The block a sync read of ``registers`` asks ``ids`` for (kept while their tables stay).

        Raises:
            InputError: The servos' tables disagree on the registers' addresses.
        """
        tables = tuple(self.table(sid) for sid in ids)
        plan = self._plans.get((ids, registers))
        if plan is not None and plan.tables == tables:
            return plan
        specs = [tables[0].spec(r) for r in registers]
        for sid, table in zip(ids[1:], tables[1:], strict=True):
            for s in specs:
                o = table.spec(s.register)
                if (o.address, o.size) != (s.address, s.size):
                    raise InputError(f"servos {ids[0]} and {sid} keep {s.register.value} at "
                                     "different addresses; they cannot share a sync read")
        start = min(s.address for s in specs)
        size = max(s.address + s.size for s in specs) - start
        fields = tuple((s.register, s, s.address - start, s.address - start + s.size)
                       for s in specs)
        plan = _SyncPlan(tables, start, size, ", ".join(r.value for r in registers),
                         f"sync read of {size} bytes at {start}", fields)
        if len(self._plans) >= 32:
            self._plans.clear()
        self._plans[(ids, registers)] = plan
        return plan

    def read_feedback(self, ids: Sequence[int]) -> dict[int, Feedback]:
        """Position, velocity, load, voltage, temperature and alarms of many servos.

        One SYNC READ; a servo whose error byte flags an alarm is asked which (Dynamixel) or
        its error byte is the alarm itself (Feetech).
        """
        raw = self.sync_read(ids, FEEDBACK)
        out = {}
        for sid, (v, error) in raw.items():
            alarms = self._alarms_from_error(sid, error)
            vel = float(v[Register.PRESENT_VELOCITY]) * self.vendor.velocity_unit  # [tick/s]
            out[sid] = Feedback(sid, v[Register.PRESENT_POSITION], vel, v[Register.PRESENT_LOAD],
                                v[Register.PRESENT_VOLTAGE] / 10.0,
                                v[Register.PRESENT_TEMPERATURE], error, alarms)
        return out

    def read_positions(self, ids: Sequence[int]) -> dict[int, tuple[int, tuple[Alarm, ...]]]:
        """Present positions [tick] and hardware alarms of many servos in one SYNC READ.

        The alarms come from each status packet's error byte (asked for by name from a
        Dynamixel servo whose alert bit is set).
        """
        plan, got = self._sync_read_block(list(ids), (Register.PRESENT_POSITION,))
        ((_, spec, lo, hi),) = plan.fields
        alarms_in = self.adapter.alarms_in
        out = {}
        for sid, (data, error) in got.items():
            found = alarms_in(error)
            out[sid] = (decode(spec, from_le(data[lo:hi])),
                        self._alarms_from_error(sid, error) if found is None else found)
        return out

    def _alarms_from_error(self, sid: int, error: int) -> tuple[Alarm, ...]:
        found = self.adapter.alarms_in(error)
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
        tables = self.tables
        for sid, value in values.items():
            table = tables.get(sid)
            spec = (table or self.table(sid)).spec(register)
            if not spec.writable or not spec.lo <= value <= spec.hi:
                raise InputError(f"servo {sid} {register.value}: {value} is not writable or "
                                 f"outside [{spec.lo}, {spec.hi}]; nothing was sent")
            items[sid] = to_le(encode(spec, int(value)), spec.size)
        if spec is None:
            return

        address, size = spec.address, spec.size

        def call(sdk: Sdk) -> _Attempt:
            return _Attempt(sdk.sync_write(address, size, items))
        self._transact(f"sync write of {register.value}", None, register.value, call,
                       replies=False)

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

        def call(sdk: Sdk) -> _Attempt:
            out = self._exchange(sdk, sid, 0, lambda: sdk.send_reboot(sid), True)
            return _Attempt(sdk.SUCCESS) if out.result in (sdk.TIMEOUT, sdk.CORRUPT) else out
        self._transact("reboot", sid, None, call, retries=0)
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
