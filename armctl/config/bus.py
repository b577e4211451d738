"""The ``bus:`` section of an arm config: port, protocol, baud rate and one servo per joint."""

from __future__ import annotations

from dataclasses import dataclass, field
from enum import Enum

from armctl.config.source import Section
from armctl.errors import KeyPath
from armctl.servo_tables import TABLES, Family

__all__ = ["BusSpec", "Protocol", "ServoSpec", "parse_bus"]

SIM_PORT = "sim"


class Protocol(Enum):
    """Wire protocols armctl speaks."""

    DYNAMIXEL = "dynamixel"  # Dynamixel Protocol 2.0
    DYNAMIXEL1 = "dynamixel1"  # Dynamixel Protocol 1.0
    FEETECH = "feetech"  # Feetech SCS/STS

    @property
    def family(self) -> Family:
        """The servo family that speaks this protocol."""
        return Family.FEETECH if self is Protocol.FEETECH else Family.DYNAMIXEL


@dataclass(frozen=True)
class ServoSpec:
    """The servo that drives one joint.

    Attributes:
        joint: Joint name.
        id: Servo id on the bus (0-252).
        model: Servo model name, e.g. ``"sts3215"`` or ``"xm430-w350"``.
        offset: Joint angle [rad] (or position [m]) at the servo's centre tick.
        direction: +1, or -1 when the servo turns opposite to the joint axis.
        gear_ratio: Servo turns per joint turn (or servo [rad] per joint [m] for a prismatic joint).
        where: Where it was defined, for error messages.
    """

    joint: str
    id: int
    model: str
    offset: float = 0.0
    direction: int = 1
    gear_ratio: float = 1.0
    where: KeyPath = field(default_factory=KeyPath, compare=False)


@dataclass(frozen=True)
class BusSpec:
    """A serial servo bus.

    Attributes:
        port: Device path (``/dev/ttyACM0``, ``COM3``) or ``"sim"`` for the built-in simulated bus.
        protocol: Wire protocol.
        baudrate: Baud rate in [bit/s].
        servos: One servo per driven joint.
        calibration: Calibration file, relative to the config file, if any.
    """

    port: str
    protocol: Protocol
    baudrate: int
    servos: tuple[ServoSpec, ...]
    calibration: str | None = None

    @property
    def simulated(self) -> bool:
        """Whether the port is the built-in simulated bus."""
        return self.port == SIM_PORT


def _model(s: Section, protocol: Protocol) -> str:
    """The servo model name of one servo entry, checked against the known control tables.

    Raises:
        ConfigError: For an unknown model, or one that does not speak the bus's protocol.
    """
    import difflib

    raw = s.string("model")
    model = raw.lower()
    table = TABLES.get(model)
    if table is None:
        known = sorted(TABLES)
        close = difflib.get_close_matches(model, known, n=1)
        fix = ((f"did you mean {close[0]!r}? " if close else "")
               + f"known models: {', '.join(known)}")
        raise s.error(f"unknown servo model {raw!r}", "model", fix=fix)
    if table.family is not protocol.family:
        raise s.error(f"{raw!r} is a {table.family.value} servo but the bus protocol is "
                      f"{protocol.value!r}", "model",
                      fix="fix the model, or the bus's 'protocol'")
    return model


def parse_bus(sec: Section) -> BusSpec:
    """Validate a ``bus:`` section.

    Args:
        sec: The section.

    Returns:
        The bus description (joint names are checked against the arm by the caller).
    """
    sec.check_keys(["port", "protocol", "servos"], ["baudrate", "calibration"])
    protocol = sec.choice("protocol", Protocol, [p.value for p in Protocol])
    servos = []
    seen: dict[int, str] = {}
    for joint, s in sec.child("servos").mapping().items():
        s = s.mapping()
        s.check_keys(["id", "model"], ["offset", "direction", "gear_ratio"])
        sid = s.integer("id", lo=0, hi=252)
        if sid in seen:
            raise s.error(f"servo id {sid} is already used by joint {seen[sid]!r}", "id",
                          fix="give every servo its own id")
        seen[sid] = joint
        direction = s.integer("direction", 1)
        if direction not in (1, -1):
            raise s.error(f"direction must be 1 or -1, found {direction}", "direction")
        servos.append(ServoSpec(
            joint=joint, id=sid, model=_model(s, protocol),
            offset=s.number("offset", 0.0, angle=True), direction=direction,
            gear_ratio=s.number("gear_ratio", 1.0, positive=True), where=s.where(),
        ))
    calibration = sec.string("calibration", required=False) or None
    return BusSpec(
        port=sec.string("port"), protocol=protocol,
        baudrate=sec.integer("baudrate", 1_000_000, lo=1200, hi=10_500_000),
        servos=tuple(servos), calibration=calibration,
    )
