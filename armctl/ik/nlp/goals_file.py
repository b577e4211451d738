"""Goals files: IK goals and NLP constraints in YAML.

Example::

    goals:
      - {type: pose, frame: flange, position: [0.4, 0.1, 0.3], rpy: [180 deg, 0, 0]}
      - {type: position, frame: left_tip, position: [0.2, 0.3, 0.4], weight: 2}
      - {type: direction, position: [0.4, 0, 0.2], direction: [0, 0, -1], axis: [0, 0, 1]}
      - {type: orientation, rpy: [0, 90 deg, 0], tolerance: {rotation: 1e-3}}
      - {type: look_at, frame: camera, point: [0.5, 0, 0], axis: [0, 0, 1]}
    constraints:
      - {type: plane, point: [0, 0, 0.2], normal: [0, 0, 1]}          # hard (no weight)
      - {type: halfspace, point: [0, 0, 0.05], normal: [0, 0, 1], weight: 10}
      - {type: line, point: [0.3, 0, 0.2], direction: [1, 0, 0]}
      - {type: box, lower: [0, -0.5, 0], upper: [0.6, 0.5, 0.8]}
      - {type: sphere, center: [0, 0, 0.3], radius: 0.7}
      - {type: cone, direction: [0, 0, -1], half_angle: 20 deg}
      - {type: keep_out_sphere, center: [0.3, 0.2, 0.3], radius: 0.1}
      - {type: keep_out_box, lower: [0.2, -0.1, 0], upper: [0.4, 0.1, 0.15], link_radius: 0.04}

Positions in [m]; angles in [rad] or as strings such as ``"20 deg"``. A constraint without a
``weight`` is hard. Errors name the file, the key path and the line. Each goal type reads and
writes its own keys (:meth:`armctl.ik.goals.Goal.from_file`, ``file_fields``); its ``type`` is
the class's ``file_type``. :func:`format_goals` writes goals back as YAML.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import TypeVar

import numpy as np
import yaml

from armctl.config.source import Document, Section, load_yaml, parse_yaml
from armctl.errors import ConfigError, InputError
from armctl.ik.goals import Goal, Tolerance, goal_classes
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

__all__ = ["GoalsFile", "format_goals", "load_goals", "parse_goals", "parse_goals_text"]

T = TypeVar("T")

_COMMON_GOAL = ["type", "frame", "weight", "tolerance"]
_CONSTRAINT_KEYS: dict[str, tuple[list[str], list[str]]] = {
    "plane": (["point", "normal"], []),
    "halfspace": (["point", "normal"], []),
    "line": (["point", "direction"], []),
    "box": (["lower", "upper"], []),
    "sphere": (["center", "radius"], []),
    "cone": (["direction", "half_angle"], ["axis"]),
    "keep_out_sphere": (["center", "radius"], ["link_radius"]),
    "keep_out_box": (["lower", "upper"], ["link_radius"]),
}
_COMMON_CONSTRAINT = ["type", "frame", "weight", "tolerance"]


@dataclass(frozen=True)
class GoalsFile:
    """What a goals file holds.

    Attributes:
        goals: The goals, one per frame.
        constraints: The constraints, hard or weighted.
    """

    goals: tuple[Goal, ...]
    constraints: tuple[Constraint, ...]


def load_goals(path: str | Path) -> GoalsFile:
    """Read a goals file.

    Raises:
        ConfigError: Naming the file, key path and line of the first problem.
    """
    return parse_goals(load_yaml(path))


def parse_goals_text(text: str) -> GoalsFile:
    """Parse goals-file YAML given as text (errors name ``<config>``)."""
    return parse_goals(parse_yaml(text))


def parse_goals(doc: Document) -> GoalsFile:
    """Validate a parsed goals document."""
    top = doc.root()
    top.check_keys(["goals"], ["constraints"])
    goals = tuple(_guard(sec, _goal) for sec in top.list_of("goals", "type"))
    if not goals:
        raise top.error("the goals list is empty", "goals", fix="list at least one goal")
    frames = [g.frame for g in goals]
    if len(set(frames)) != len(frames):
        raise top.error("two goals name the same frame", "goals",
                        fix="combine them into one goal (e.g. a pose goal)")
    cons = tuple(_guard(sec, _constraint) for sec in top.list_of("constraints", "type"))
    return GoalsFile(goals, cons)


def _guard(sec: Section, build: Callable[[Section], T]) -> T:
    """Run ``build``; an InputError raised by a goal's own checks gets the file location."""
    sec.mapping()
    try:
        return build(sec)
    except ConfigError:
        raise
    except InputError as exc:
        raise sec.error(str(exc)) from exc


def _tolerance(sec: Section) -> Tolerance:
    if not sec.has("tolerance"):
        return Tolerance()
    t = sec.child("tolerance").mapping()
    t.check_keys([], ["position", "rotation"])
    d = Tolerance()
    return Tolerance(t.number("position", d.position, positive=True),
                     t.number("rotation", d.rotation, positive=True, angle=True))


def _goal(sec: Section) -> Goal:
    types = {cls.file_type: cls for cls in goal_classes()}
    kind = sec.choice("type", str, list(types))
    cls = types[kind]
    req, opt = cls.file_keys
    sec.check_keys(["type", *req], [k for k in _COMMON_GOAL if k != "type"] + list(opt))
    frame = sec.string("frame", required=False) or None
    weight = sec.number("weight", 1.0, positive=True)
    return cls.from_file(sec, frame=frame, weight=weight, tolerance=_tolerance(sec))


def format_goals(goals: Sequence[Goal]) -> str:
    """Goals as goals-file YAML (the ``goals:`` list; constraints are not written).

    Frames, weights and tolerances are written when they differ from the defaults; angles in
    [rad]. :func:`parse_goals_text` reads the text back to equal goals (up to round-off).
    """
    default = Tolerance()
    lines = ["goals:"]
    for goal in goals:
        entry: dict[str, object] = {"type": goal.file_type}
        if goal.frame is not None:
            entry["frame"] = goal.frame
        entry.update(goal.file_fields())
        if goal.weight != 1.0:
            entry["weight"] = float(goal.weight)
        if goal.tolerance != default:
            entry["tolerance"] = {"position": float(goal.tolerance.position),
                                  "rotation": float(goal.tolerance.rotation)}
        lines.append("  - " + yaml.safe_dump(entry, default_flow_style=True, sort_keys=False,
                                             width=10**6).strip())
    return "\n".join(lines) + "\n"


def _constraint(sec: Section) -> Constraint:
    kind = sec.choice("type", str, list(_CONSTRAINT_KEYS))
    req, opt = _CONSTRAINT_KEYS[kind]
    sec.check_keys(["type", *req], [k for k in _COMMON_CONSTRAINT if k != "type"] + opt)
    weight = sec.number("weight", positive=True) if sec.has("weight") else None
    tol = sec.number("tolerance", 1e-4 if kind == "cone" else 1e-5, positive=True)
    frame = sec.string("frame", required=False) or None
    if kind in ("keep_out_sphere", "keep_out_box") and sec.has("frame"):
        raise sec.error("keep-out constraints act on every moving link, not on a frame", "frame",
                        fix="remove 'frame'")

    def v(key: str) -> np.ndarray:
        return np.array(sec.vector(key, 3))

    if kind == "plane":
        return OnPlane(v("point"), v("normal"), frame=frame, weight=weight, tolerance=tol)
    if kind == "halfspace":
        return InHalfSpace(v("point"), v("normal"), frame=frame, weight=weight, tolerance=tol)
    if kind == "line":
        return OnLine(v("point"), v("direction"), frame=frame, weight=weight, tolerance=tol)
    if kind == "box":
        return InBox(v("lower"), v("upper"), frame=frame, weight=weight, tolerance=tol)
    if kind == "sphere":
        return InSphere(v("center"), sec.number("radius", positive=True), frame=frame,
                        weight=weight, tolerance=tol)
    if kind == "cone":
        axis = np.array(sec.vector("axis", 3, (0.0, 0.0, 1.0)))
        return AxisInCone(v("direction"), sec.number("half_angle", angle=True, positive=True),
                          axis, frame=frame, weight=weight, tolerance=tol)
    link_radius = sec.number("link_radius", positive=True) if sec.has("link_radius") else None
    if kind == "keep_out_sphere":
        return KeepOutSphere(v("center"), sec.number("radius", positive=True), weight=weight,
                             tolerance=tol, link_radius=link_radius)
    return KeepOutBox(v("lower"), v("upper"), weight=weight, tolerance=tol,
                      link_radius=link_radius)
