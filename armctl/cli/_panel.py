"""``armctl view`` as a control panel: the page commands the arm through a :class:`Robot`.

Used by :func:`armctl.cli.render.cmd_view` when the view has a bus to itself (``--sim``,
``--bus``, ``--port``) and is not asked to ``--watch`` only.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from typing import TYPE_CHECKING

from armctl.cli._common import emit
from armctl.errors import InputError

if TYPE_CHECKING:
    from armctl.arm import Arm

#: Addresses that serve this machine only.
LOCAL_HOSTS = ("127.0.0.1", "localhost", "::1")


def warn_exposed(host: str, token: str | None, control: bool) -> None:
    """Print a warning when the page is served beyond this machine."""
    if host in LOCAL_HOSTS:
        return
    who = ("anyone who can reach it and knows the token" if token
           else "anyone who can reach it")
    what = "command the arm" if control else "see the arm"
    print(f"warning: --host {host}: the view is served to other machines, and {who} can "
          f"{what}; serve it on 127.0.0.1 (the default) unless you mean it"
          + ("" if token or not control else ", or protect commanding with --token"),
          file=sys.stderr)


#: The web server's port when ``--http-port`` is not given (the next free one if it is taken).
DEFAULT_HTTP_PORT = 8080


def choose_http_port(args: argparse.Namespace) -> None:
    """Settle ``args.http_port``: a port given must be free; the default may move on.

    A port the user names (``--http-port N``, N > 0) is the one served or the command is
    refused: an address that changes silently breaks bookmarks and tunnels. Without
    ``--http-port`` the default is served, or the next free port, which :func:`say_http_port`
    announces.

    Raises:
        InputError: For a port outside 0-65535, or one given that another program listens on.
    """
    import socket

    args.http_port_given = args.http_port is not None
    if args.http_port is None:
        args.http_port = DEFAULT_HTTP_PORT
        return
    if not 0 <= args.http_port <= 65535:
        raise InputError(f"--http-port {args.http_port} is not a TCP port (0-65535)")
    if args.http_port == 0:
        return
    with socket.socket(socket.AF_INET6 if ":" in args.host else socket.AF_INET) as sock:
        try:
            sock.bind((args.host, args.http_port))
        except OSError:
            raise InputError(
                f"--http-port {args.http_port} is in use on {args.host} (another program, or "
                "another 'armctl view', listens on it); choose another port, or --http-port 0 "
                "for any free one") from None


def say_http_port(args: argparse.Namespace, served: int) -> None:
    """Say so on stderr when the default port was taken and another one is served."""
    if not args.http_port_given and served != DEFAULT_HTTP_PORT:
        print(f"note: port {DEFAULT_HTTP_PORT} is in use: the page is served on port {served} "
              "instead (--http-port N to choose)", file=sys.stderr)


def serve_panel(args: argparse.Namespace, arm: Arm) -> int | None:
    """Open the arm's bus as a :class:`Robot` and serve the control panel until stopped.

    Returns:
        The exit code, or ``None`` when another armctl command owns the port (the caller then
        shows that command's live state instead) or the arm has no bus (the caller says so).
    """
    from armctl.cli._watch import port_owner
    from armctl.config.motion import ExitPolicy
    from armctl.panel import ControlPanel
    from armctl.panel.page import PanelPage
    from armctl.robot import Robot
    from armctl.robot.bus_choice import arm_on_bus
    from armctl.servo.errors import PortError

    if arm.spec.bus is None and not args.sim:
        return None  # the caller says that there is no bus to command
    spec = arm_on_bus(arm, args.port, args.sim).spec
    assert spec.bus is not None  # arm_on_bus gave it one  # mypy.
    owner = port_owner(spec.bus, None)
    if owner is not None:
        owner.close()
        return None
    try:
        robot = Robot.open(arm, port=args.port, sim=args.sim, exit_policy=ExitPolicy.HOLD)
    except PortError:
        return None  # taken meanwhile: the caller attaches to its owner (or says why not)
    try:
        panel = ControlPanel(robot, token=args.token, solver=args.solver)
        connection = ("simulated bus" if robot.simulated
                      else f"bus on port {spec.bus.port}")
        page = PanelPage(panel, args.host, args.http_port, connection, min(args.rate, 20.0))
        try:
            url = page.start()
            say_http_port(args, page.port)
            emit(args, {"url": url, "http_port": page.port, "bus": True,
                        "bus_port": spec.bus.port, "attached": None, "control": True,
                        "token": args.token is not None},
                 f"control panel of {arm.name!r} on the {connection} at {url} (Ctrl-C stops; "
                 "the arm holds where it is)")
            sys.stdout.flush()
            end = math.inf if args.duration is None else time.monotonic() + args.duration
            while time.monotonic() < end:
                time.sleep(min(0.2, max(end - time.monotonic(), 0.0)))
        finally:
            page.stop()  # stops a running motion, which decelerates and holds
    except BaseException:
        robot.close_holding("the control panel stopped")
        raise
    robot.close(ExitPolicy.HOLD)
    return 0
