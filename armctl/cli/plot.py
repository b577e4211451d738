"""``armctl plot``: draw a motion log (``--log FILE.csv``) as commanded/measured tracking curves."""

from __future__ import annotations

import argparse
import math
from pathlib import Path
from typing import TYPE_CHECKING

from armctl.cli._common import add_json, emit, table
from armctl.errors import ConfigError, KeyPath

if TYPE_CHECKING:
    from armctl.robot.motion_log import MotionLog

ORDER = 61


def register(sub: argparse._SubParsersAction[argparse.ArgumentParser]) -> None:
    """Add ``plot``."""
    p = sub.add_parser("plot", help="plot a motion log: commanded, measured, tracking error",
                       description="Draw, per joint, the commanded and measured values of a "
                       "motion log written by a motion command's '--log FILE.csv', and the "
                       "tracking error (measured - commanded) in degrees (revolute joints) or "
                       "millimetres (prismatic joints; the joint types come from the log's "
                       "first line). Drawn headless.")
    p.add_argument("log", metavar="FILE.csv", help="a motion log written by '--log'")
    p.add_argument("-o", "--output", required=True,
                   help="image file (.png .svg .pdf .jpg)")
    p.add_argument("--force", action="store_true", help="overwrite an existing output file")
    add_json(p)
    p.set_defaults(func=cmd_plot)


def _draw(log: MotionLog, path: Path) -> None:
    from armctl.render.plots import color, new_figure, save_figure, style_axes

    n = len(log.joints)
    fig, axes = new_figure(n, 2, size=(10.0, 2.4 * n))
    for j, name in enumerate(log.joints):
        scale, unit = (1000.0, "mm") if log.prismatic[j] else (math.degrees(1.0), "deg")
        ax, ax_err = axes[2 * j], axes[2 * j + 1]
        ax.plot(log.t, log.cmd[:, j] * scale, color=color(0), label="commanded")
        ax.plot(log.t, log.meas[:, j] * scale, color=color(1), linestyle="--", label="measured")
        style_axes(ax, title=name, xlabel="time [s]", ylabel=f"[{unit}]", legend=True)
        ax_err.plot(log.t, log.error[:, j] * scale, color=color(2))
        style_axes(ax_err, title=f"{name}: tracking error (measured - commanded)",
                   xlabel="time [s]", ylabel=f"[{unit}]")
    fig.suptitle(f"arm {log.arm}: {log.t.size} cycles at {log.rate_hz:g} Hz")
    save_figure(fig, path)


def cmd_plot(args: argparse.Namespace) -> int:
    """Read the log, refuse an existing output without --force, draw, report the errors."""
    from armctl.render.plots import check_output
    from armctl.robot.motion_log import read_log, tracking_errors

    out = check_output(args.output)
    if out.exists() and not args.force:
        raise ConfigError("the output file already exists; nothing was drawn", KeyPath(out),
                          "choose another name or pass --force to overwrite it")
    log = read_log(args.log)
    _draw(log, out)
    errors = tracking_errors(log)
    rows = [[name, e["unit"], f"{e['max']:.3f}", f"{e['rms']:.3f}"] for name, e in errors.items()]
    text = (f"wrote {out}: {log.t.size} cycles of arm {log.arm} at {log.rate_hz:g} Hz\n"
            + table(["joint", "unit", "max error", "rms error"], rows, right=[2, 3]))
    emit(args, {"output": str(out), "log": str(args.log), "arm": log.arm,
                "rate_hz": log.rate_hz, "cycles": int(log.t.size), "tracking_error": errors},
         text)
    return 0
