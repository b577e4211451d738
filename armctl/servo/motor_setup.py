"""Give a new servo its id and baud rate: find the single servo on a bus, then write both.

Servos leave the factory with the same id (1) and baud rate, so an arm is set up one servo at a
time: with only that servo connected, :func:`find_single_servo` pings the bus at every baud rate
of the family's Baud Rate table and :func:`assign_id_and_baud` writes the id and the rate the arm
config wants (both are EEPROM items: torque off first; on Feetech the EEPROM is unlocked for the
writes and locked again), then pings the servo at its new id and rate.
"""

from __future__ import annotations

import logging
from collections.abc import Sequence
from dataclasses import dataclass

from armctl.config.bus import Protocol
from armctl.errors import InputError
from armctl.servo import errors as E
from armctl.servo.driver import ServoBus
from armctl.servo.status import PingResult
from armctl.servo_tables import Register, table_for

__all__ = ["FoundServo", "assign_id_and_baud", "bus_rates", "check_port", "find_single_servo"]

log = logging.getLogger(__name__)


@dataclass(frozen=True)
class FoundServo:
    """The one servo that answered.

    Attributes:
        ping: Its ping (id, model number, model name).
        baudrate: The baud rate it answered at [bit/s].
    """

    ping: PingResult
    baudrate: int


def bus_rates(model: str, first: int | None = None) -> tuple[int, ...]:
    """The baud rates of a model's Baud Rate table [bit/s] in the order to try them.

    ``first`` (if listed) first, then the factory rate (the Baud Rate item's default), then the
    others from the fastest.
    """
    table = table_for(model)
    codes = table.baud_codes
    factory = codes.get(table.spec(Register.BAUD_RATE).default)
    rates = sorted(set(codes.values()), reverse=True)
    for rate in (factory, first):
        if rate in rates:
            rates.remove(rate)
            rates.insert(0, rate)
    return tuple(rates)


def _open(port: str, protocol: Protocol, baudrate: int, models: dict[int, str] | None = None,
          latency_ms: float = 16.0) -> ServoBus:
    return ServoBus(port, protocol, baudrate, models=models, retries=1,
                    latency_ms=latency_ms).open()


def check_port(port: str, protocol: Protocol, baudrate: int) -> None:
    """Open and close the port (before asking the user to connect servos).

    Raises:
        PortError: The port cannot be opened.
    """
    _open(port, protocol, baudrate).close()


def find_single_servo(port: str, protocol: Protocol, rates: Sequence[int], *,
                      latency_ms: float = 16.0) -> FoundServo:
    """Ping the bus at each baud rate until servos answer; exactly one must.

    Args:
        port: Serial port.
        protocol: Wire protocol.
        rates: Baud rates to try, in order [bit/s].
        latency_ms: USB adapter latency [ms] (see :class:`~armctl.servo.driver.ServoBus`).

    Raises:
        InputError: More than one servo answers (nothing is written), or none at any rate.
        PortError: The port cannot be opened.
    """
    for rate in rates:
        try:
            bus = _open(port, protocol, rate, latency_ms=latency_ms)
        except E.PortError as exc:
            if rate == rates[0]:
                raise
            log.info("skipping %d baud on %s: %s", rate, port, exc)
            continue
        try:
            found = bus.scan()
        finally:
            bus.close()
        if len(found) > 1:
            ids = ", ".join(str(p.servo_id) for p in found)
            raise InputError(f"{len(found)} servos answer on {port} at {rate} baud (ids {ids}); "
                             "disconnect all but the one to set up and try again (nothing was "
                             "written)")
        if found:
            return FoundServo(found[0], rate)
    raise InputError(f"no servo answers on {port} at any of {', '.join(map(str, rates))} baud; "
                     "check that the servo is connected and powered")


def assign_id_and_baud(port: str, protocol: Protocol, found: FoundServo, model: str,
                       servo_id: int, baudrate: int, *, latency_ms: float = 16.0) -> PingResult:
    """Write a servo's id and baud rate and ping it at the new ones.

    Args:
        port: Serial port.
        protocol: Wire protocol.
        found: The servo as :func:`find_single_servo` found it.
        model: The model the arm config expects.
        servo_id: Id to give it.
        baudrate: Baud rate to give it [bit/s].
        latency_ms: USB adapter latency [ms].

    Returns:
        Its ping at the new id and baud rate.

    Raises:
        WrongModelError: It is not the expected model (nothing is written).
        InputError: The model has no code for ``baudrate``.
        ServoMissingError: It does not answer at the new id and rate.
    """
    table = table_for(model)
    codes = {rate: code for code, rate in table.baud_codes.items()}
    if baudrate not in codes:
        raise InputError(f"{model} has no baud rate {baudrate}; use one of "
                         f"{', '.join(map(str, sorted(codes)))} (bus: baudrate)")
    old = found.ping.servo_id
    if found.ping.model != model:
        seen = found.ping.model or f"model number {found.ping.model_number}"
        raise E.WrongModelError(
            f"the connected servo is a {seen}, the config expects a {model}", port, old,
            fix="connect the servo the config names, or fix its model in the config")
    bus = _open(port, protocol, found.baudrate, {old: model, servo_id: model}, latency_ms)
    try:
        lock = bus.vendor.eeprom_lock
        bus.write(old, Register.TORQUE_ENABLE, 0)
        if lock:
            bus.write(old, Register.LOCK, 0)
        if old != servo_id:
            bus.write(old, Register.ID, servo_id)  # answered from the old id
        if found.baudrate != baudrate:
            bus.write(servo_id, Register.BAUD_RATE, codes[baudrate])  # answered at the old rate
    finally:
        bus.close()
    bus = _open(port, protocol, baudrate, {servo_id: model}, latency_ms)
    try:
        if lock:
            bus.write(servo_id, Register.LOCK, 1)
        ping = bus.ping(servo_id)
    except E.NoReplyError as exc:
        raise E.ServoMissingError(f"the servo does not answer at id {servo_id}, {baudrate} baud "
                                  "after the change", port, servo_id,
                                  fix="power-cycle it and run the setup again") from exc
    finally:
        bus.close()
    log.info("servo %d at %d baud is now id %d at %d baud", old, found.baudrate, servo_id,
             baudrate)
    return ping
