"""Benchmark of the analytic IK (all solutions) against EAIK and IK-Geo, in one run.

Usage: python tools/bench_analytic.py [--goals N] [--no-write]

For each arm, N random reachable goals (fixed seed) are solved by ``armctl.ik.analytic.ik_all``
and by the peers (bench-only dependencies ``eaik`` and ``ik-geo``, given the same idealised
kinematic parameters). Reported: time per call [us] (Python call included, median of repeats),
and the mean number of distinct solutions per goal whose FK residual (by armctl's model) is
<= 1e-9 m / rad. Writes the section ``analytic-ik`` of docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import math
import sys
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _benchdoc import write_section

from armctl.arm import Arm, load_arm
from armctl.config.schema import ArmSpec, FrameSpec, JointSpec, JointType, Limits, LinkSpec, Origin
from armctl.ik import DirectionGoal
from armctl.ik.analytic import GoalKind, classify, decomposition, ik_all
from armctl.ik.analytic._pipeline import GENERAL, PARALLEL, SPHERICAL, pose6
from armctl.ik.analytic.chain import chain_of
from armctl.ik.analytic.classify import _CACHE
from armctl.spatial import matrix_to_rpy

#: KUKA KR6-class spherical-wrist arm, standard DH (d, a, alpha) [m, m, rad]: base height 0.4,
#: shoulder offset 0.025, upper arm 0.455, elbow offset 0.035, forearm 0.42, flange 0.08.
KR6 = [(0.4, 0.025, -math.pi / 2), (0.0, 0.455, 0.0), (0.0, 0.035, -math.pi / 2),
       (0.42, 0.0, math.pi / 2), (0.0, 0.0, -math.pi / 2), (0.08, 0.0, 0.0)]


#: A general 6R arm (no special geometry), standard DH (d, a, alpha) [m, m, rad].
GENERAL_6R = [(0.3, 0.1, 1.2), (-0.1, 0.4, -0.7), (0.15, 0.35, 2.0), (0.2, -0.05, 0.9),
              (-0.12, 0.08, -1.4), (0.1, 0.05, 0.6)]

#: Manocha and Canny (1994), Table I: the arm of their 16-solution example (axes 5 and 6 meet).
MANOCHA_CANNY = [(0.0, 0.3, math.radians(90)), (0.0, 1.0, math.radians(1)),
                 (0.2, 0.0, math.radians(90)), (0.0, 1.5, math.radians(1)),
                 (0.0, 0.0, math.radians(90)), (0.0, 0.0, math.radians(1))]


def dh_arm(name: str, rows: list[tuple[float, float, float]]) -> Arm:
    """An arm from a standard DH table (joint limits +-pi)."""
    def origin(t: np.ndarray) -> Origin:
        return Origin(tuple(float(v) for v in t[:3, 3]),  # type: ignore[arg-type]
                      tuple(float(v) for v in matrix_to_rpy(t[:3, :3])))  # type: ignore[arg-type]

    links = [LinkSpec("base")] + [LinkSpec(f"l{i + 1}") for i in range(len(rows))]
    joints, pre = [], np.eye(4)
    for i, (d, a, al) in enumerate(rows):
        joints.append(JointSpec(f"j{i + 1}", JointType.REVOLUTE, "base" if i == 0 else f"l{i}",
                                f"l{i + 1}", origin(pre), (0.0, 0.0, 1.0),
                                Limits(-math.pi, math.pi)))
        ca, sa = math.cos(al), math.sin(al)
        pre = np.array([[1, 0, 0, a], [0, ca, -sa, 0], [0, sa, ca, d], [0, 0, 0, 1.0]])
    frames = (FrameSpec("tool", f"l{len(rows)}", origin(pre)),)
    return Arm(ArmSpec(name, "base", tuple(links), tuple(joints), frames, "tool", ("tool",)))


def per_call(fn: Callable[[], object], n: int) -> float:
    """Time of one call [us]: the best of 15 runs of ``n`` calls (the machine is shared)."""
    fn()
    runs = []
    for _ in range(15):
        t = time.perf_counter()
        for _ in range(n):
            fn()
        runs.append((time.perf_counter() - t) / n * 1e6)
    return min(runs)


def distinct(arm: Arm, qs: list[np.ndarray], goal: np.ndarray) -> int:
    """Distinct (mod 2 pi) configurations that reach ``goal`` within 1e-9 by armctl's FK."""
    keep = set()
    chain = list(arm.chain())
    for qc in qs:
        q = np.zeros(arm.dof)
        q[chain] = qc
        t = arm.fk(q)
        if np.linalg.norm(t[:3, 3] - goal[:3, 3]) <= 1e-9 and np.abs(
                t[:3, :3] - goal[:3, :3]).max() <= 1e-9:
            keep.add(tuple(np.round(np.mod(np.asarray(qc) + 1e-7, 2 * np.pi), 6)))
    return len(keep)


def peers(arm: Arm) -> dict[str, tuple[Callable[[np.ndarray], list[np.ndarray]], str]]:
    """The peer solvers for a 6R arm, on armctl's idealised parameters."""
    dec = decomposition(arm, None, GoalKind.POSE)
    chain = dec.chain
    h = np.array(chain.h)
    p = np.vstack([chain.o[0], np.diff(chain.o, axis=0), chain.m[:3, 3] - chain.o[-1]])
    rm = chain.m[:3, :3]
    sign = np.array(chain.sign)
    out: dict[str, tuple[Callable[[np.ndarray], list[np.ndarray]], str]] = {}
    try:
        from eaik.IK_HP import HPRobot

        bot = HPRobot(h, p)

        def eaik_solve(goal: np.ndarray) -> list[np.ndarray]:
            g = goal.copy()
            g[:3, :3] = goal[:3, :3] @ rm.T
            res = bot.IK(g)
            return [np.asarray(q) * sign for q, ls in zip(res.Q, res.is_LS, strict=True)
                    if not ls]

        out["eaik"] = (eaik_solve, bot.getKinematicFamily())
    except ImportError:
        pass
    return out


def bench_pose_arm(label: str, arm: Arm, goals: int, rng: np.random.Generator) -> list[str]:
    """Rows of the pose table for one arm."""
    dec = decomposition(arm, None, GoalKind.POSE)
    family = dec.label
    qs = arm.sample(rng, goals)
    poses = [arm.fk(q) for q in qs]
    rows = []
    state = {"i": 0}

    def cycle(fn: Callable[[np.ndarray], object]) -> Callable[[], object]:
        def call() -> object:
            state["i"] = (state["i"] + 1) % goals
            return fn(poses[state["i"]])
        return call

    ours_counts = [len({tuple(np.round(np.mod(r + 1e-7, 2 * np.pi), 6))
                        for r in ik_all(arm, g).q[:, list(arm.chain())]}) for g in poses]
    n_rows = np.mean([len(ik_all(arm, g, variants=True)) for g in poses])
    t_ours = per_call(cycle(lambda g: ik_all(arm, g)), goals)
    rows.append(f"| {label} | armctl `ik_all` ({family}) | {t_ours:.1f} | "
                f"{np.mean(ours_counts):.2f} | {n_rows:.1f} |")
    c = dec.chain
    code = SPHERICAL if "SPHERICAL" in dec.family.name else PARALLEL
    ref = arm.middle()
    f = arm.frame_index(None)
    jd, fd, paths = arm.tree.joints, arm.tree.frames, arm.tree.paths

    def kernel(g: np.ndarray) -> object:
        return pose6(code, dec.inverted, c.h, c.o, c.m, c.index, c.sign, dec.columns, dec.mask,
                     ref, g, jd, fd, paths, f, 1e-9, arm.lower, arm.upper, True)

    rows.append(f"| {label} | armctl compiled core (`pose6`, no Python wrapper) | "
                f"{per_call(cycle(kernel), goals):.1f} | same | same |")
    for name, (solve, fam) in peers(arm).items():
        counts = [distinct(arm, solve(g), g) for g in poses]
        t = per_call(cycle(solve), goals)
        rows.append(f"| {label} | {name} ({fam}) | {t:.1f} | {np.mean(counts):.2f} | - |")
    return rows


def bench_ikgeo(goals: int, rng: np.random.Generator) -> list[str]:
    """ik-geo on its own built-in arms (its PyPI binding returned only least-squares results
    for armctl's parameters), checked by its own forward kinematics."""
    try:
        import ik_geo
    except ImportError:
        return []
    rows = []
    for label, robot in (("UR5 (ik-geo built-in)", ik_geo.Robot.ur5()),
                         ("spherical-wrist arm (ik-geo built-in)", ik_geo.Robot.spherical_bot())):
        poses = [robot.forward_kinematics(list(q)) for q in rng.uniform(-np.pi, np.pi, (goals, 6))]
        counts = []
        for r, t in poses:
            keep = set()
            for q, ls in robot.get_ik(r, t):
                r2, t2 = robot.forward_kinematics(q)
                if not ls and np.abs(np.subtract(r2, r)).max() <= 1e-9 and np.abs(
                        np.subtract(t2, t)).max() <= 1e-9:
                    keep.add(tuple(np.round(np.mod(np.asarray(q) + 1e-7, 2 * np.pi), 6)))
            counts.append(len(keep))
        def call(robot: Any = robot, poses: list[Any] = poses,
                 k: dict[str, int] = {"i": 0}) -> object:  # noqa: B006
            k["i"] = (k["i"] + 1) % goals
            r, t = poses[k["i"]]
            return robot.get_ik(r, t)

        rows.append(f"| {label} | ik-geo | {per_call(call, goals):.1f} | {np.mean(counts):.2f} "
                    "| - |")
    return rows


def general_kernel(a: Arm) -> Callable[[np.ndarray], Any]:
    """The compiled general 6R solve of arm ``a`` (polish and acceptance included)."""
    c = chain_of(a)
    cols, mask, ref = np.arange(6, dtype=np.int64), np.ones(6, dtype=np.bool_), a.middle()
    f = a.frame_index(None)
    jd, fd, paths = a.tree.joints, a.tree.frames, a.tree.paths

    def kernel(g: np.ndarray) -> Any:
        return pose6(GENERAL, False, c.h, c.o, c.m, c.index, c.sign, cols, mask, ref, g,
                     jd, fd, paths, f, 1e-9, a.lower, a.upper, True)

    return kernel


def bench_general(goals: int, rng: np.random.Generator) -> list[str]:
    """Rows for general 6R arms (Raghavan-Roth / Manocha-Canny elimination)."""
    rows = []
    arm = dh_arm("general-6r", GENERAL_6R)
    poses = [arm.fk(q) for q in arm.sample(rng, goals)]
    k = {"i": 0}

    def call() -> object:
        k["i"] = (k["i"] + 1) % goals
        return ik_all(arm, poses[k["i"]])

    counts = [len({tuple(np.round(np.mod(r + 1e-7, 2 * np.pi), 6)) for r in ik_all(arm, g).q})
              for g in poses]
    rows.append(f"| general 6R (DH, no special axes) | armctl `ik_all` "
                f"({decomposition(arm, None, GoalKind.POSE).label}) | "
                f"{per_call(call, goals):.1f} | {np.mean(counts):.2f} | - |")
    for label, a in (("general 6R (DH, no special axes)", arm),
                     ("Manocha-Canny 16-solution arm", dh_arm("mc", MANOCHA_CANNY))):
        ps = [a.fk(q) for q in a.sample(rng, goals)]
        kernel = general_kernel(a)
        n = np.mean([len({tuple(np.round(np.mod(r + 1e-7, 2 * np.pi), 6))
                          for r in kernel(g)[0]}) for g in ps])
        j = {"i": 0}

        def timed(kernel: Callable[[np.ndarray], Any] = kernel, ps: list[np.ndarray] = ps,
                  j: dict[str, int] = j) -> object:
            j["i"] = (j["i"] + 1) % goals
            return kernel(ps[j["i"]])

        rows.append(f"| {label} | armctl compiled general 6R core (`pose6`, no Python "
                    f"wrapper) | {per_call(timed, goals):.1f} | {n:.2f} | - |")
    return rows


def bench_setup(arm: Arm) -> float:
    """Classification time [ms] without the cache."""
    t = time.perf_counter()
    for _ in range(20):
        _CACHE.pop(arm, None)
        classify(arm, None, GoalKind.POSE)
    return (time.perf_counter() - t) / 20 * 1e3


def main() -> int:
    """Run the benchmark and write the section."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=300, help="random goals per arm (default 300)")
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args()
    rng = np.random.default_rng(2026)
    arms = [("UR5e (bundled)", load_arm("ur5e")), ("WX250s (bundled)", load_arm("wx250s")),
            ("KR6-class (DH)", dh_arm("kr6", KR6))]
    lines = ["## Analytic IK: all solutions", "",
             f"{args.goals} random reachable pose goals per arm (seed 2026). Time per call in "
             "microseconds, Python call included (best of 15 runs over all goals); solutions: mean "
             "distinct "
             "configurations per goal that reach the goal within 1e-9 m and 1e-9 rad by "
             "armctl's FK (ik-geo rows: its own FK); rows: what `ik_all(..., variants=True)` "
             "lists (every in-limit 2 pi variant; by default it lists one row per solution). "
             "The reference robots against EAIK: section \"Analytic IK on the reference robots, "
             "against EAIK\".", "",
             "| arm | solver | us / call | solutions | rows |", "|---|---|---:|---:|---:|"]
    for label, arm in arms:
        lines += bench_pose_arm(label, arm, args.goals, rng)
    lines += bench_ikgeo(args.goals, rng)
    torso = load_arm("torso")
    tq = torso.sample(rng, args.goals)
    tposes = [torso.fk(q, "right_tcp") for q in tq]
    tk = {"i": 0}

    def torso_call() -> object:
        tk["i"] = (tk["i"] + 1) % args.goals
        return ik_all(torso, tposes[tk["i"]], frame="right_tcp")

    n_torso = np.mean([len(ik_all(torso, g, frame="right_tcp")) for g in tposes])
    lines.append(f"| torso right arm (axes 5, 6 meet: 1-D search) | armctl `ik_all` | "
                 f"{per_call(torso_call, min(args.goals, 40)):.1f} | {n_torso:.2f} | - |")
    panda = load_arm("panda")
    pq = panda.sample(rng, args.goals)
    pposes = [panda.fk(q) for q in pq]
    k = {"i": 0}

    def panda_call() -> object:
        k["i"] = (k["i"] + 1) % args.goals
        return ik_all(panda, pposes[k["i"]], q_ref=pq[k["i"]])

    t_panda = per_call(panda_call, args.goals)
    n_panda = np.mean([len(ik_all(panda, g, q_ref=q)) for g, q in zip(pposes, pq, strict=True)])
    lines.append(f"| Panda (7 DOF, joint 7 held at q_ref) | armctl `ik_all` | {t_panda:.1f} | "
                 f"{n_panda:.2f} | - |")
    so = load_arm("so101")
    a = np.array([1.0, 0.0, 0.0])
    sgoals = []
    for q in so.sample(rng, args.goals):
        t = so.fk(q)
        sgoals.append(DirectionGoal(t[:3, 3], t[:3, :3] @ a, axis=a))
    j = {"i": 0}

    def so_call() -> object:
        j["i"] = (j["i"] + 1) % args.goals
        return ik_all(so, sgoals[j["i"]])

    lines.append(f"| SO-101 (5 DOF, position + tool x direction) | armctl `ik_all` | "
                 f"{per_call(so_call, args.goals):.1f} | "
                 f"{np.mean([len(ik_all(so, g)) for g in sgoals]):.2f} | - |")
    lines += bench_general(min(args.goals, 100), rng)
    general = dh_arm("general-6r", GENERAL_6R)
    lines += ["", "Setup (classification, uncached) per arm [ms]: " + ", ".join(
        f"{label} {bench_setup(arm):.2f}" for label, arm in [*arms, ("general 6R", general)])
        + ".", "",
        "General 6R rows: every solution from the 24 x 24 eigenvalue problem of the "
        "Raghavan-Roth / Manocha-Canny elimination (its setup includes a self-check on four "
        "configurations); the Manocha-Canny arm has axes 5 and 6 meeting, and `ik_all` uses the "
        "general method on such arms whenever its elimination is well posed (the 1-D search "
        "is the fallback, e.g. for the torso's arms); peers have no general 6R closed form."]
    md = "\n".join(lines)
    print(md)
    if not args.no_write:
        cmd = "python tools/bench_analytic.py" + (f" --goals {args.goals}"
                                                  if args.goals != 300 else "")
        print(write_section("analytic-ik", md, cmd))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
