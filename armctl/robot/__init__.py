"""The top layer: the arm model, IK, motion planning and the servo bus joined together.

:class:`Robot` is the Python API (a context manager that applies the exit policy when its
block ends normally, and holds the arm when it ends with an exception); the
:class:`Executor` streams checked plans at a fixed rate and stops safely; :class:`TeachSession`
records keyframes by hand-guiding or jogging; :class:`Teleop` makes a follower arm copy a leader
arm moved by hand.
"""

from armctl.robot.errors import MotionStopped, SignalInterrupt, StopReason
from armctl.robot.executor import CycleInfo, Executor, StreamResult, StreamStats
from armctl.robot.motion_control import ControlState, MotionControl
from armctl.robot.session import MoveReport, Robot
from armctl.robot.stop import STOP_SIGNALS, SignalGuard, StopRequest, signals_stop
from armctl.robot.teleop import Teleop, TeleopOptions

__all__ = [
    "STOP_SIGNALS",
    "ControlState",
    "CycleInfo",
    "Executor",
    "MotionControl",
    "MotionStopped",
    "MoveReport",
    "Robot",
    "SignalGuard",
    "SignalInterrupt",
    "StopReason",
    "StopRequest",
    "StreamResult",
    "StreamStats",
    "Teleop",
    "TeleopOptions",
    "signals_stop",
]
