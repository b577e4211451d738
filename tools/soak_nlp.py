"""Soak test of the NLP IK solver: many solves of every method on several arms in one process.

Each solve goes from a random start inside the limits to the pose (or position) of another random
configuration inside the limits; every fourth one adds a hard plane through the target. Every
answer reported as a success is checked again here, by forward kinematics and the joint limits.
A memory error inside the solvers shows as an abnormal end of this process (run it under
glibc's malloc checks to catch one at the first bad write, as the test suite does).

    python tools/soak_nlp.py [--solves 2000] [--arms panda ur5e so101 URDF:TIP ...]
                             [--methods auto ipopt:500 sqpmethod] [--seed 0] [--json]

``--methods`` takes ``METHOD`` or ``METHOD:SOLVES`` (that method's own count per arm).

Exit code 0 when every reported success really reaches its goal, 1 otherwise.
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import numpy as np

from armctl.arm import Arm, load_arm
from armctl.ik import PoseGoal, PositionGoal
from armctl.ik.goals import Goal
from armctl.ik.nlp import Method, NLPOptions, OnPlane

ROOT = Path(__file__).resolve().parent.parent
#: Default arms: bundled ones and a URDF whose 7 joints all have narrow limits.
DEFAULT_ARMS = ("panda", "ur5e", "so101", "tests/data/urdf/panda.urdf:panda_link8")


def _load(spec: str) -> Arm:
    """An arm from a bundled name, a YAML/URDF path, or ``URDF:TIP``."""
    path, _, tip = spec.partition(":")
    if path.endswith((".urdf", ".yaml", ".yml")) and not Path(path).is_absolute():
        path = str(ROOT / path)
    return load_arm(path, tip or None)


def _rotation_error(r: np.ndarray, target: np.ndarray) -> float:
    """Angle between two rotation matrices [rad]."""
    c = (float(np.trace(target.T @ r)) - 1.0) / 2.0
    return float(np.arccos(np.clip(c, -1.0, 1.0)))


def _problem(arm: Arm, rng: np.random.Generator, k: int) -> tuple[Goal, tuple[OnPlane, ...]]:
    """Goal and constraints of solve ``k``: pose, pose, position, position on a hard plane."""
    target = arm.fk(arm.sample(rng))
    kind = k % 4
    if kind < 2:
        return PoseGoal(target), ()
    goal = PositionGoal(target[:3, 3])
    if kind == 2:
        return goal, ()
    normal = rng.normal(size=3)
    return goal, (OnPlane(target[:3, 3], normal / np.linalg.norm(normal)),)


def _wrong(arm: Arm, goal: Goal, constraints: tuple[OnPlane, ...], q: np.ndarray) -> str:
    """Why a reported success is not one ("" when it is)."""
    if not arm.within_limits(q):
        return f"outside the limits: {q.tolist()}"
    pose = arm.fk(q)
    tol = goal.tolerance
    if isinstance(goal, PoseGoal):
        pos_err = float(np.linalg.norm(pose[:3, 3] - goal.position))
        rot_err = _rotation_error(pose[:3, :3], goal.rotation)
    else:
        assert isinstance(goal, PositionGoal)
        pos_err = float(np.linalg.norm(pose[:3, 3] - goal.position))
        rot_err = 0.0
    if pos_err > tol.position or rot_err > tol.rotation:
        return f"goal missed by {pos_err:.3g} m, {rot_err:.3g} rad"
    for c in constraints:
        off = abs(float(c.normal @ (pose[:3, 3] - c.point)))
        if off > c.tolerance:
            return f"{off:.3g} m off the plane"
    return ""


def _method(text: str, solves: int) -> tuple[Method, int]:
    """``METHOD`` or ``METHOD:SOLVES`` from the command line."""
    name, _, count = text.partition(":")
    try:
        return Method(name), int(count) if count else solves
    except ValueError:
        raise argparse.ArgumentTypeError(
            f"{text!r}: expected METHOD or METHOD:SOLVES with METHOD one of "
            f"{', '.join(m.value for m in Method)}") from None


def soak(arm_specs: list[str], methods: list[tuple[Method, int]],
         seed: int) -> Iterator[dict[str, Any]]:
    """Run the given number of solves per arm and method; yields one summary per pair."""
    for spec in arm_specs:
        arm = _load(spec)
        for method, solves in methods:
            rng = np.random.default_rng(seed)
            ok = 0
            wrong: list[str] = []
            started = time.perf_counter()
            for k in range(solves):
                goal, constraints = _problem(arm, rng, k)
                q0 = arm.sample(rng)
                res = arm.ik(goal, q0, solver="nlp", constraints=constraints,
                             options=NLPOptions(method=method, seed=seed + k))
                if res.success:
                    ok += 1
                    why = _wrong(arm, goal, constraints, np.asarray(res.q))
                    if why:
                        wrong.append(f"solve {k}: {why}")
            yield {"arm": spec, "method": method.value, "solves": solves, "success": ok,
                   "wrong": wrong, "seconds": round(time.perf_counter() - started, 2)}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--solves", type=int, default=2000, help="solves per arm and method")
    ap.add_argument("--arms", nargs="+", default=list(DEFAULT_ARMS),
                    help="bundled names, YAML/URDF paths, or URDF:TIP")
    ap.add_argument("--methods", nargs="+", default=[m.value for m in Method],
                    help="METHOD or METHOD:SOLVES, METHOD one of "
                         f"{', '.join(m.value for m in Method)}")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--json", action="store_true",
                    help="print each summary as a line of JSON")
    args = ap.parse_args(argv)
    try:
        methods = [_method(m, args.solves) for m in args.methods]
    except argparse.ArgumentTypeError as exc:
        ap.error(str(exc))
    failed = False
    for r in soak(args.arms, methods, args.seed):  # each row as soon as it is done
        failed = failed or bool(r["wrong"])
        if args.json:
            print(json.dumps(r), flush=True)
            continue
        print(f"{r['arm']:40s} {r['method']:9s} {r['success']}/{r['solves']} reached, "
              f"{len(r['wrong'])} wrong, {r['seconds']} s", flush=True)
        for line in r["wrong"]:
            print(f"    {line}", flush=True)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
