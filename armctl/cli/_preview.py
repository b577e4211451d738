"""The --preview plot of ``armctl play``: joint positions and velocities over time."""

from __future__ import annotations

import math
from typing import TYPE_CHECKING

import numpy as np

from armctl.config.schema import JointType
from armctl.errors import InputError

if TYPE_CHECKING:
    from armctl.motion import MotionPlan
    from armctl.robot import Robot


def write_preview(robot: Robot, plan: MotionPlan, path: str) -> None:
    """Joint positions and velocities over time, with keyframes marked (matplotlib, headless)."""
    try:  # a bare Figure with the Agg canvas: no pyplot, no display, no global state
        from matplotlib.backends.backend_agg import FigureCanvasAgg
        from matplotlib.figure import Figure
    except ImportError as exc:  # pragma: no cover - optional dependency
        raise InputError("--preview needs matplotlib (pip install 'armctl[render]')") from exc
    ts = np.linspace(0.0, plan.duration, max(2, int(plan.duration * 200)))
    q, qd, _ = plan.trajectory.sample_many(ts)
    fig = Figure(figsize=(9, 6))
    FigureCanvasAgg(fig)
    ax1, ax2 = fig.subplots(2, 1, sharex=True)
    for i, name in enumerate(robot.arm.joint_names):
        prismatic = robot.arm.joint_types[i] is JointType.PRISMATIC
        scale = 1000.0 if prismatic else math.degrees(1.0)
        ax1.plot(ts, scale * q[:, i], label=f"{name} [mm]" if prismatic else name)
        ax2.plot(ts, scale * qd[:, i])
    for w in plan.waypoints:
        ax1.axvline(w.time, color="0.8", lw=0.8, zorder=0)
    ax1.set_ylabel("position [deg; mm]")
    ax2.set_ylabel("velocity [deg/s; mm/s]")
    ax2.set_xlabel("time [s]")
    ax1.legend(fontsize=7, ncol=3)
    ax1.set_title(plan.description)
    fig.tight_layout()
    from armctl.render.plots import save_figure

    save_figure(fig, path, dpi=100)
