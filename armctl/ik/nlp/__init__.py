"""IK as non-linear programming (CasADi): weighted goals, general constraints, keep-out zones.

Use it through the registry (``arm.ik(goal, solver="nlp", constraints=[...])``) with the
constraint objects exported here and, optionally, :class:`NLPOptions`. CasADi is imported only
when a problem is first built.
"""

from armctl.ik.nlp.constraints import (
    AxisInCone,
    Constraint,
    InBox,
    InHalfSpace,
    InSphere,
    OnLine,
    OnPlane,
)
from armctl.ik.nlp.keep_out import KeepOutBox, KeepOutSphere
from armctl.ik.nlp.options import Method, NLPOptions
from armctl.ik.nlp.problem import build_count, clear_cache
from armctl.ik.nlp.scene import KeepAboveTable, KeepOutCapsule, KeepOutOrientedBox, scene_keep_out

__all__ = [
    "AxisInCone",
    "Constraint",
    "InBox",
    "InHalfSpace",
    "InSphere",
    "KeepAboveTable",
    "KeepOutBox",
    "KeepOutCapsule",
    "KeepOutOrientedBox",
    "KeepOutSphere",
    "Method",
    "NLPOptions",
    "OnLine",
    "OnPlane",
    "build_count",
    "clear_cache",
    "scene_keep_out",
]
