"""``--port`` and ``--sim`` of the motion commands: which bus a command drives.

``--port PORT`` replaces the port of the config's ``bus:`` section (a serial device, or the pty
of a running ``armctl sim``); ``--sim`` runs the command on the built-in simulated bus, also for
a config without a ``bus:`` section (see :func:`armctl.robot.bus_choice.arm_on_bus`).
"""

from __future__ import annotations

import argparse
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from armctl.arm import Arm

__all__ = ["add_bus_choice", "arm_on_chosen_bus"]


def add_bus_choice(p: argparse.ArgumentParser) -> None:
    """Add the mutually exclusive ``--port PORT`` and ``--sim`` to a motion command."""
    group = p.add_mutually_exclusive_group()
    group.add_argument("--port", metavar="PORT", default=None,
                       help="drive the servos on this port instead of the config's (a serial "
                            "device, or the pty printed by a running 'armctl sim')")
    group.add_argument("--sim", action="store_true",
                       help="use the built-in simulated bus (also for a config without a "
                            "'bus:' section, e.g. a converted URDF: one simulated servo per "
                            "joint)")


def arm_on_chosen_bus(args: argparse.Namespace, arm: Arm) -> Arm:
    """The arm with the bus ``--port``/``--sim`` chose (the arm itself without either).

    Raises:
        InputError: As :func:`armctl.robot.bus_choice.arm_on_bus`.
    """
    from armctl.robot.bus_choice import arm_on_bus

    return arm_on_bus(arm, getattr(args, "port", None), bool(getattr(args, "sim", False)))
