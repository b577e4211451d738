"""The console loop of ``armctl sim``: stdin lines to the simulator's console, replies to stdout."""

from __future__ import annotations

import sys
from typing import TYPE_CHECKING

if TYPE_CHECKING:
    from armctl.servo import SimulatedBus


def serve_console(sim: SimulatedBus) -> int:
    """Run the simulator's console on stdin until 'quit', end of input or Ctrl-C.

    Every stdin line goes to :class:`~armctl.servo.sim.console.SimConsole`; a bad line prints
    an error line and the simulator (and its pty) carries on.

    Args:
        sim: The running simulated bus.

    Returns:
        The exit code (0).
    """
    from armctl.servo.sim.console import SimConsole

    console = SimConsole(sim)
    while True:
        try:
            line = sys.stdin.readline()
        except KeyboardInterrupt:  # the normal way to stop the simulator
            return 0
        if not line:
            return 0
        try:
            reply = console.execute(line)
        except Exception as exc:  # a bug must not take the pty away from its clients
            reply = None
            print(f"error: {type(exc).__name__}: {exc} (the simulator goes on)")
        if reply is not None and reply.text:
            print(reply.text)
        sys.stdout.flush()
        if reply is not None and reply.quit:
            return 0
