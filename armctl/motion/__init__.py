"""Motion planning: joint moves, straight lines, keyframe playback, all checked before motion.

Pure planning: nothing here talks to servos (:mod:`armctl.robot` streams plans to the bus).
"""

from armctl.motion.detour import DetourOptions, Planner, plan_detour
from armctl.motion.errors import DetourError, LimitViolation, PathError
from armctl.motion.interpolate import Interpolation, plan_run
from armctl.motion.keyframe_file import load_keyframes, parse_keyframes, save_keyframes
from armctl.motion.keyframes import AngleUnit, Keyframe, KeyframeProgram, LengthUnit
from armctl.motion.limits import MotionLimits, check_speed, check_trajectory
from armctl.motion.plan import Event, MotionPlan, Waypoint, plan_joint_move
from armctl.motion.playback import PlaybackOptions, plan_program, resolve_keyframes
from armctl.motion.profiles import ruckig_move, stop_trajectory
from armctl.motion.trajectory import Chain, Hold, PiecewisePolynomial, Trajectory

__all__ = [
    "AngleUnit",
    "Chain",
    "DetourError",
    "DetourOptions",
    "Event",
    "Hold",
    "Interpolation",
    "Keyframe",
    "KeyframeProgram",
    "LengthUnit",
    "LimitViolation",
    "MotionLimits",
    "MotionPlan",
    "PathError",
    "PiecewisePolynomial",
    "Planner",
    "PlaybackOptions",
    "Trajectory",
    "Waypoint",
    "check_speed",
    "check_trajectory",
    "load_keyframes",
    "parse_keyframes",
    "plan_detour",
    "plan_joint_move",
    "plan_program",
    "plan_run",
    "resolve_keyframes",
    "ruckig_move",
    "save_keyframes",
    "stop_trajectory",
]
