"""Which vendor package's rules a simulated servo follows, per wire protocol and servo family.

The simulator (:mod:`armctl.servo.sim`) knows ids, registers and ticks; it asks a
:class:`~armctl.servo.sim.rules.ServoRules` for everything a family does differently. This
module is the one place that names the families' rules: Protocol 2.0 and 1.0 from
:mod:`armctl.servo.dynamixel.rules`, SCS/STS from :mod:`armctl.servo.feetech.rules`.
"""

from __future__ import annotations

from collections.abc import Mapping
from types import MappingProxyType

from armctl.config.bus import Protocol
from armctl.servo.dynamixel.rules import DynamixelProtocol1Rules, DynamixelRules
from armctl.servo.feetech.rules import FeetechRules
from armctl.servo.sim.rules import ServoRules
from armctl.servo_tables import Family

__all__ = ["RULES", "factory_protocol", "rules_for_family", "rules_for_protocol"]

#: The rules of the servos that speak each protocol.
RULES: Mapping[Protocol, type[ServoRules]] = MappingProxyType({
    Protocol.DYNAMIXEL: DynamixelRules,
    Protocol.DYNAMIXEL1: DynamixelProtocol1Rules,
    Protocol.FEETECH: FeetechRules,
})

#: The protocol a family's servo speaks out of the box.
_FACTORY_PROTOCOL: Mapping[Family, Protocol] = MappingProxyType({
    Family.DYNAMIXEL: Protocol.DYNAMIXEL,
    Family.FEETECH: Protocol.FEETECH,
})


def rules_for_protocol(protocol: Protocol) -> ServoRules:
    """The rules of a servo speaking ``protocol``."""
    return RULES[protocol]()


def factory_protocol(family: Family) -> Protocol:
    """The protocol a ``family`` servo speaks out of the box (Protocol 2.0 for Dynamixel)."""
    return _FACTORY_PROTOCOL[family]


def rules_for_family(family: Family) -> ServoRules:
    """The rules of a ``family`` servo in its factory protocol."""
    return rules_for_protocol(factory_protocol(family))
