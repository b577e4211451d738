"""The simulator knows ids, registers and ticks only: every family difference is in the rules.

The code of ``armctl/servo/sim/`` (docstrings and comments aside) names no servo family, no
vendor package and no vendor flag, and does not tell framings or rules apart by type; what a
family does differently is asked of its :class:`~armctl.servo.sim.rules.ServoRules` (in the
vendor packages) or read from table data. The Operating Mode numbers in the rules are checked
against the makers' own lists.
"""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

import armctl.servo.sim
from armctl.config.bus import Protocol
from armctl.servo.sim.bus import SimServoSpec, SimulatedBus
from armctl.servo.sim.motor import ControlMode
from armctl.servo.sim.rules import ServoRules
from armctl.servo.sim.wire import Protocol1Wire, Protocol2Wire
from armctl.servo.vendor_rules import RULES, rules_for_family
from armctl.servo_tables import Family

SIM = Path(armctl.servo.sim.__file__).resolve().parent
FAMILY_WORDS = ("feetech", "dynamixel", "dxl", "scservo")
#: Vendor attributes that are switches between families rather than data.
VENDOR_FLAGS = frozenset({"feetech", "reports_errors", "eeprom_lock", "zero_limits_off",
                          "sets_mode", "Family", "FEETECH", "DYNAMIXEL", "DYNAMIXEL1"})


def _docstrings(tree: ast.AST) -> set[int]:
    """``id`` of every docstring node."""
    out = set()
    for node in ast.walk(tree):
        if isinstance(node, (ast.Module, ast.ClassDef, ast.FunctionDef, ast.AsyncFunctionDef)):
            body = node.body
            if body and isinstance(body[0], ast.Expr) and isinstance(body[0].value, ast.Constant) \
                    and isinstance(body[0].value.value, str):
                out.add(id(body[0].value))
    return out


def family_knowledge(source: str, name: str = "<source>") -> list[str]:
    """Every place in ``source`` that names a family, a vendor flag or tells types apart."""
    tree = ast.parse(source, name)
    docs = _docstrings(tree)
    found = []

    def words(node: ast.AST) -> list[str]:
        if isinstance(node, ast.Name):
            return [node.id]
        if isinstance(node, ast.Attribute):
            return [node.attr]
        if isinstance(node, (ast.FunctionDef, ast.AsyncFunctionDef, ast.ClassDef)):
            return [node.name]
        if isinstance(node, ast.arg):
            return [node.arg]
        if isinstance(node, ast.alias):
            return [node.name, node.asname or ""]
        if isinstance(node, ast.ImportFrom):
            return [node.module or ""]
        if isinstance(node, ast.Constant) and isinstance(node.value, str) and id(node) not in docs:
            return [node.value]
        return []

    for node in ast.walk(tree):
        line = getattr(node, "lineno", 0)
        for w in words(node):
            low = w.lower()
            if any(f in low for f in FAMILY_WORDS):
                found.append(f"{name}:{line}: names a family: {w!r}")
            elif w in VENDOR_FLAGS and not isinstance(node, ast.Constant):
                found.append(f"{name}:{line}: a vendor flag: {w!r}")
        if isinstance(node, ast.Call) and isinstance(node.func, ast.Name) \
                and node.func.id == "isinstance" and len(node.args) == 2:
            kinds = ast.unparse(node.args[1])
            if "Wire" in kinds or "Rules" in kinds:
                found.append(f"{name}:{line}: tells framings or rules apart by type: {kinds}")
    return found


def test_the_checker_finds_what_it_looks_for() -> None:
    source = '''
"""Feetech and Dynamixel may be named in a docstring."""
from armctl.servo.feetech.rules import FeetechRules
def f(table, wire, protocol):
    # a comment may say Feetech too
    if table.vendor.feetech:
        return 1
    if isinstance(wire, DxlWire):
        return 2
    if protocol is Protocol.DYNAMIXEL or table.family is Family.FEETECH:
        return 3
    return table.vendor.reports_errors
'''
    found = family_knowledge(source)
    lines = sorted({int(f.split(":")[1]) for f in found})
    assert lines == [3, 6, 8, 10, 12], found


@pytest.mark.parametrize("path", sorted(SIM.glob("*.py")), ids=lambda p: p.name)
def test_simulator_code_names_no_family(path: Path) -> None:
    assert family_knowledge(path.read_text(encoding="utf-8"), path.name) == []


# Operating Mode numbers as the makers list them: ROBOTIS e-Manual, X series "Operating
# Mode(11)" (0 Current, 1 Velocity, 3 Position, 4 Extended Position (Multi-turn), 5
# Current-based Position, 16 PWM); Feetech STS memory table, Operating mode (33) (0 position
# servo, 1 constant-speed (wheel), 2 PWM open loop, 3 step servo).
MAKERS_MODES = {
    Protocol.DYNAMIXEL: {0: "current", 1: "velocity", 3: "position", 4: "extended_position",
                         5: "current_based_position", 16: "pwm"},
    Protocol.FEETECH: {0: "position", 1: "velocity", 2: "pwm", 3: "step"},
}
MAKERS_MODES[Protocol.DYNAMIXEL1] = MAKERS_MODES[Protocol.DYNAMIXEL]


@pytest.mark.parametrize("protocol", list(Protocol), ids=lambda p: p.value)
def test_mode_numbers_are_the_makers(protocol: Protocol) -> None:
    rules = RULES[protocol]()
    assert {k: v.value for k, v in rules.modes.items()} == MAKERS_MODES[protocol]
    assert all(rules.control_mode(k) is ControlMode(v) for k, v in MAKERS_MODES[protocol].items())


def test_every_protocol_has_rules_and_its_framing() -> None:
    framing = {Protocol.DYNAMIXEL: Protocol2Wire, Protocol.DYNAMIXEL1: Protocol1Wire,
               Protocol.FEETECH: Protocol1Wire}  # e-Manual Protocol 1.0 / 2.0; SCS/STS = 1.0
    for protocol in Protocol:
        rules = RULES[protocol]()
        assert isinstance(rules, ServoRules)
        assert rules.wire is framing[protocol]
    assert rules_for_family(Family.DYNAMIXEL).wire is Protocol2Wire  # out of the box: 2.0


@pytest.mark.parametrize(("model", "protocol"), [("xm430-w350", Protocol.DYNAMIXEL),
                                                 ("sts3215", Protocol.FEETECH)])
def test_simulated_bus_speaks_the_servos_factory_protocol(model: str, protocol: Protocol) -> None:
    bus = SimulatedBus([SimServoSpec(1, model)])
    assert bus.protocol is protocol
    assert isinstance(bus.servos[0].rules, RULES[protocol])


def test_a_bus_without_servos_needs_a_protocol() -> None:
    from armctl.errors import InputError

    with pytest.raises(InputError, match="protocol"):
        SimulatedBus([])
    assert SimulatedBus([], Protocol.FEETECH).protocol is Protocol.FEETECH
