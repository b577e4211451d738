"""Fault scenarios for the simulated bus, from YAML (read with :mod:`armctl.config.source`).

Format::

    armctl_scenario: 1
    faults:
      - {kind: dropped_reply, servo: 3, count: 2}          # now
      - {kind: hardware_alarm, servo: 2, alarm: overload, at: 1.5}   # 1.5 s after start
      - {kind: latency_spike, delay: 0.02, count: 5, at: 0.5}

Keys per fault: ``kind`` (see :data:`~armctl.servo.sim.faults.FAULT_KINDS`), ``at`` [s] after
the bus started (default 0 = now), ``servo`` (every kind but ``latency_spike``), ``count``
(replies affected; ``null`` = until cleared), ``every`` (act on one reply in N: an intermittent
fault), ``delay`` [s], ``keep`` [bytes],
``alarm`` (``input_voltage``, ``overheating``, ``encoder``, ``overload``), ``model_number``,
``ticks`` (where an ``obstacle`` blocks the shaft; default: where it is).
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

from armctl.config.source import load_yaml
from armctl.servo.sim import faults as F

__all__ = ["load_scenario"]

_FIELDS: dict[type, tuple[str, ...]] = {
    F.DroppedReply: ("count", "every"),
    F.CorruptedReply: ("count", "every"),
    F.TruncatedReply: ("count", "keep", "every"),
    F.LateReply: ("count", "delay", "every"),
    F.LatencySpike: ("count", "delay", "every"),
    F.MissingServo: (),
    F.HardwareAlarm: ("alarm",),
    F.WrongModel: ("model_number",),
    F.LockupAfterOverload: (),
    F.Obstacle: ("ticks",),
}


def load_scenario(path: str | Path) -> list[tuple[float, F.Fault]]:
    """The faults of a scenario file with their times.

    Returns:
        ``(at [s], fault)`` pairs in file order.

    Raises:
        ConfigError: For anything invalid, naming file, key path and line.
    """
    doc = load_yaml(path)
    root = doc.root()
    root.check_keys(["faults"], ["armctl_scenario", "description"])
    if root.has("armctl_scenario"):
        root.integer("armctl_scenario", lo=1, hi=1)
    out: list[tuple[float, F.Fault]] = []
    for item in root.list_of("faults", label_key="kind"):
        item.mapping()
        cls = item.choice("kind", F.FAULT_KINDS.__getitem__, list(F.FAULT_KINDS))
        fields = _FIELDS[cls]
        needs_servo = cls is not F.LatencySpike
        item.check_keys(["kind", *(["servo"] if needs_servo else [])], ["at", *fields])
        kw: dict[str, Any] = {}
        if needs_servo:
            kw["servo_id"] = item.integer("servo", lo=0, hi=252)
        if "count" in fields and "count" in item.value:
            kw["count"] = None if item.value["count"] is None else item.integer("count", lo=1)
        if "delay" in fields and item.has("delay"):
            kw["delay"] = item.number("delay", nonnegative=True)
        if "every" in fields and item.has("every"):
            kw["every"] = item.integer("every", lo=1)
        if "keep" in fields and item.has("keep"):
            kw["keep"] = item.integer("keep", lo=0)
        if "alarm" in fields and item.has("alarm"):
            kw["alarm"] = item.choice("alarm", F.Alarm, [a.value for a in F.Alarm])
        if "model_number" in fields and item.has("model_number"):
            kw["model_number"] = item.integer("model_number", lo=0, hi=65535)
        if "ticks" in fields and item.has("ticks"):
            kw["ticks"] = item.integer("ticks", lo=-(2**31), hi=2**31 - 1)
        out.append((item.number("at", 0.0, nonnegative=True), cls(**kw)))
    return out
