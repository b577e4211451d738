"""The top layer: the arm model, IK, motion planning and the servo bus joined together.

:class:`Robot` is the Python API (a context manager that applies the exit policy); the
:class:`Executor` streams checked plans at a fixed rate and stops safely; :class:`TeachSession`
records keyframes by hand-guiding or jogging.
"""

from armctl.robot.errors import MotionStopped, StopReason
from armctl.robot.executor import CycleInfo, Executor, StreamResult, StreamStats
from armctl.robot.session import MoveReport, Robot
from armctl.robot.stop import StopRequest, sigint_stops

__all__ = [
    "CycleInfo",
    "Executor",
    "MotionStopped",
    "MoveReport",
    "Robot",
    "StopReason",
    "StopRequest",
    "StreamResult",
    "StreamStats",
    "sigint_stops",
]
