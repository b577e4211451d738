"""Analytic (closed-form) inverse kinematics: every solution of a goal.

A chain is classified from its geometry (:mod:`.classify`): three axes meeting in a point
(spherical wrist or shoulder), three consecutive parallel axes (UR type), the 5- and 4-joint
arms with parallel pitch axes, any three joints for a position goal, and, solved by a 1-D
search rather than in closed form (:mod:`._search`), 6R chains whose axes 5 and 6 (or 1 and 2)
meet. The family's solver (:mod:`._families`, built from the canonical subproblems in
:mod:`._subproblems`) yields every candidate; each is polished on the exact forward kinematics
and kept only if it reaches the goal (:mod:`._polish`). :func:`ik_all` lists all solutions;
:func:`solve` is the ``"analytic"`` entry of the solver registry. See docs/analytic-ik.md.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

from armctl.ik.analytic.classify import (
    Decomposition,
    Family,
    GoalKind,
    Tolerances,
    classify,
    decomposition,
    describe,
)
from armctl.ik.analytic.errors import NoDecompositionError

if TYPE_CHECKING:
    from armctl.ik.analytic.solve_all import ACCEPT, IKSolutions, acceptance, ik_all
    from armctl.ik.analytic.solver import solve

#: The names imported on first use (the solvers import numba): classifying an arm stays light.
_LAZY = {"ACCEPT": "solve_all", "IKSolutions": "solve_all", "acceptance": "solve_all",
         "ik_all": "solve_all", "solve": "solver"}


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is None:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = getattr(importlib.import_module(f"{__name__}.{module}"), name)
    globals()[name] = value
    return value


__all__ = [
    "ACCEPT",
    "Decomposition",
    "Family",
    "GoalKind",
    "IKSolutions",
    "NoDecompositionError",
    "Tolerances",
    "acceptance",
    "classify",
    "decomposition",
    "describe",
    "ik_all",
    "solve",
]
