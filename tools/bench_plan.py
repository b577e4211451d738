"""Detour planning: success rate and planning time on random problems, side by side with OMPL.

For each arm (SO-101, UR5e, Panda) it builds problems: a random free start and goal, and one to
three boxes placed where the arm passes half-way along the straight joint line between them,
so that the straight line collides; a problem is kept only if start and goal are free, the
straight line collides, and a long run of the builtin planner (5 s, another seed) finds a
free path, so every kept
problem has a solution. On the same problems, with the same collision model and the same fixed
seeds, it runs:

* ``armctl (OMPL)``: :func:`armctl.motion.detour.plan_detour` with OMPL's RRT-Connect, i.e. the
  search, shortcutting, time parameterisation under the velocity, acceleration and jerk limits,
  the continuous check of the timed trajectory and the limit check;
* ``armctl (builtin)``: the same with armctl's seeded RRT-Connect;
* ``OMPL direct``: OMPL's RRTConnect and its ``PathSimplifier.simplifyMax`` with the same state
  and motion checks, no timing and no trajectory check.

The time budget is 1 s per plan. Times are wall times and CPU times per problem (median and
90th percentile over the problems each method solved); the trajectory duration and path length
show what the shortcutting and timing give. A second table compares, on the same raw
RRTConnect paths, OMPL's ``simplifyMax`` with armctl's shortcutting.

Usage: ``python tools/bench_plan.py [--problems N] [--arms so101,ur5e,panda] [--write]``.
"""

from __future__ import annotations

import argparse
import logging
import os
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from armctl import load_arm
from armctl.collision.model import CollisionModel
from armctl.config.scene import Obstacle, SceneSpec, TableSpec
from armctl.config.schema import Box, Origin
from armctl.errors import ArmctlError
from armctl.motion.detour import DetourOptions, Planner, plan_detour
from armctl.motion.errors import DetourError
from armctl.motion.limits import MotionLimits
from armctl.motion.rrt_connect import finite_box, path_length, shortcut

ARMS = ("so101", "ur5e", "panda")
BUDGET = 1.0
VERIFY_BUDGET = 5.0
#: Seed of the verification runs (the measured runs use the problem's index).
VERIFY_SEED = 1_000_003


def _scale(model: object) -> float:
    """A length for the arm's boxes [m]: a fraction of its reach."""
    return float(model.reach())  # type: ignore[attr-defined]


def make_problem(arm: object, rng: np.random.Generator, allowed: object,
                 stats: dict[str, int], tries: int = 200
                 ) -> tuple[np.ndarray, np.ndarray, SceneSpec] | None:
    """One problem: start, goal and a scene of boxes across the straight line, or ``None``."""
    model = arm
    reach = _scale(model)
    for _ in range(tries):
        q0 = model.sample(rng)  # type: ignore[attr-defined]
        q1 = model.sample(rng)  # type: ignore[attr-defined]
        boxes = []
        for b in range(int(rng.integers(1, 4))):
            s = 0.5 if b == 0 else float(rng.uniform(0.3, 0.7))
            qm = q0 + s * (q1 - q0)
            frames = model.fk_frames(qm)  # type: ignore[attr-defined]
            # a point on the outer half of the arm (where the detours are)
            k = int(rng.integers(len(frames) // 2, len(frames)))
            centre = frames[k][:3, 3] + rng.normal(0.0, 0.02 * reach, 3)
            size = tuple(float(x) for x in rng.uniform(0.06, 0.18, 3) * reach)
            boxes.append(Obstacle(f"box{b}", Box(size, Origin(tuple(float(c) for c in centre)))))
        scene = SceneSpec(TableSpec(), tuple(boxes))
        cm = CollisionModel.of(model, scene, allowed)  # type: ignore[arg-type]
        if not (cm.free(q0) and cm.free(q1)):
            stats["ends collide"] += 1
            continue
        if cm.segment_free(q0, q1):
            stats["straight line free"] += 1
            continue
        limits = MotionLimits.from_model(model)  # type: ignore[arg-type]
        try:
            plan_detour(cm, q0, q1, limits, options=DetourOptions(
                VERIFY_BUDGET, seed=VERIFY_SEED, planner=Planner.BUILTIN))
        except DetourError:
            stats["unsolved in verification"] += 1
            continue
        stats["kept"] += 1
        return q0, q1, scene
    return None


def ompl_direct(cm: CollisionModel, q0: np.ndarray, q1: np.ndarray, lo: np.ndarray,
                hi: np.ndarray, budget: float
                ) -> tuple[np.ndarray, np.ndarray, float] | None:
    """OMPL used directly: RRTConnect and simplifyMax, the same state and motion checks.

    Returns the raw path, the simplified path and the time simplifyMax took [s], or ``None``.
    """
    from ompl import base as ob
    from ompl import geometric as og
    from ompl import util as ou

    ou.setLogLevel(ou.LOG_NONE)
    dof = q0.size
    space = ob.RealVectorStateSpace(dof)
    bounds = ob.RealVectorBounds(dof)
    for k in range(dof):
        bounds.setLow(k, float(lo[k]))
        bounds.setHigh(k, float(hi[k]))
    space.setBounds(bounds)
    si = ob.SpaceInformation(space)
    si.setStateValidityChecker(lambda s: cm.free(np.array(s[0:dof])))

    class Segments(ob.MotionValidator):
        def checkMotion(self, a, b):
            return cm.segment_free(np.array(a[0:dof]), np.array(b[0:dof]))

    mv = Segments(si)
    si.setMotionValidator(mv)
    si.setup()
    pdef = ob.ProblemDefinition(si)
    s, g = si.allocState(), si.allocState()
    s[0:dof] = [float(v) for v in q0]
    g[0:dof] = [float(v) for v in q1]
    pdef.setStartAndGoalStates(s, g)
    planner = og.RRTConnect(si)
    planner.setProblemDefinition(pdef)
    planner.setup()
    planner.solve(budget)
    out = None
    if pdef.hasExactSolution():
        path = pdef.getSolutionPath()
        raw = np.array([st[0:dof] for st in path.getStates()])
        t = time.perf_counter()
        og.PathSimplifier(si).simplifyMax(path)
        took = time.perf_counter() - t
        out = raw, np.array([st[0:dof] for st in path.getStates()]), took
    return out


def run_arm(name: str, n: int, seed: int) -> dict[str, object]:
    arm = load_arm(name)
    rng = np.random.default_rng(seed)
    allowed = _allowed(arm)
    limits = MotionLimits.from_model(arm)
    problems = []
    t_gen = time.perf_counter()
    stats = dict.fromkeys(("ends collide", "straight line free", "unsolved in verification",
                           "kept"), 0)
    while len(problems) < n:
        p = make_problem(arm, rng, allowed, stats)
        if p is not None:
            problems.append(p)
    t_gen = time.perf_counter() - t_gen
    methods = {"armctl (OMPL)": [], "armctl (builtin)": [], "OMPL direct": []}
    extra = {k: {"duration": [], "length": [], "fail": 0} for k in methods}
    cpu: dict[str, list[float]] = {k: [] for k in methods}
    shortcuts: dict[str, list[tuple[float, float]]] = {
        "raw": [], "OMPL simplifyMax": [], "armctl shortcut": []}
    load = os.getloadavg()[0]
    for i, (q0, q1, scene) in enumerate(problems):
        if i % 10 == 0:
            print(f"  {name}: problem {i}", file=sys.stderr, flush=True)
        cm = CollisionModel.of(arm, scene, allowed)
        for key, planner in (("armctl (OMPL)", Planner.OMPL),
                             ("armctl (builtin)", Planner.BUILTIN)):
            t, c = time.perf_counter(), time.process_time()
            try:
                plan = plan_detour(cm, q0, q1, limits,
                                   options=DetourOptions(BUDGET, seed=i, planner=planner))
            except ArmctlError as exc:
                logging.getLogger("bench").info("%s %s problem %d: %s", name, key, i, exc)
                extra[key]["fail"] += 1
                continue
            methods[key].append(time.perf_counter() - t)
            cpu[key].append(time.process_time() - c)
            extra[key]["duration"].append(plan.duration)
            extra[key]["length"].append(plan.extra["path_length"])
        lo, hi = finite_box(limits.lower, limits.upper, q0, q1)
        t, c = time.perf_counter(), time.process_time()
        found = ompl_direct(cm, q0, q1, lo, hi, BUDGET)
        if found is None:
            extra["OMPL direct"]["fail"] += 1
            continue
        methods["OMPL direct"].append(time.perf_counter() - t)
        cpu["OMPL direct"].append(time.process_time() - c)
        raw, simplified, took = found
        extra["OMPL direct"]["length"].append(path_length(simplified))
        # the same raw path shortened by armctl's shortcutting, with the same checks
        t = time.perf_counter()
        short = shortcut(raw, cm.segment_free, np.random.default_rng(i), t + BUDGET)
        shortcuts["armctl shortcut"].append((time.perf_counter() - t, path_length(short)))
        shortcuts["OMPL simplifyMax"].append((took, path_length(simplified)))
        shortcuts["raw"].append((0.0, path_length(raw)))
    return {"name": name, "n": n, "gen": t_gen, "times": methods, "extra": extra,
            "stats": stats, "cpu": cpu, "load": (load, os.getloadavg()[0]),
            "shortcuts": shortcuts}


def _allowed(arm: object) -> object:
    """The arm's allowed-collision matrix (its ``collision:`` section, or sampled)."""
    from armctl.collision.allowed import allowed_pairs

    return allowed_pairs(arm, SceneSpec())  # type: ignore[arg-type]


def _pct(xs: list[float], q: float) -> str:
    return f"{np.percentile(xs, q) * 1000:.1f}" if xs else "-"


def report(results: list[dict[str, object]]) -> str:
    lines = ["## Detour planning (`tools/bench_plan.py`)", "",
             "Random problems per arm: a free start and goal, one to three boxes (edges 6-18 % "
             "of the arm's reach) across the straight joint line (which collides), placed "
             "where the arm's outer links pass on it, the table at the base, the arm's "
             "allowed-collision matrix; each problem verified solvable by a 5 s run of the "
             "builtin planner with another seed. Time budget 1 s per plan, seeds fixed. "
             "`armctl` times are whole `plan_detour` calls: search, shortcutting, time "
             "parameterisation under the velocity, acceleration and jerk limits, the continuous "
             "collision check of the timed trajectory and the limit check. `OMPL direct` is "
             "OMPL's RRTConnect and `PathSimplifier.simplifyMax` with the collision model's "
             "`free` and `segment_free` as state and motion checks (no timing, no trajectory "
             "check). Times are medians and 90th percentiles over the problems each method "
             "solved.", "",
             "| arm | method | problems | success | median [ms] | p90 [ms] | "
             "CPU median [ms] | CPU p90 [ms] | joint path length (median) | "
             "trajectory [s] (median) |",
             "|---|---|---|---|---|---|---|---|---|---|"]
    for r in results:
        for key, ts in r["times"].items():  # type: ignore[union-attr]
            ex = r["extra"][key]  # type: ignore[index]
            n = r["n"]
            ok = len(ts)
            dur = f"{np.median(ex['duration']):.2f}" if ex["duration"] else "-"
            length = f"{np.median(ex['length']):.2f}" if ex["length"] else "-"
            cp = r["cpu"][key]  # type: ignore[index]
            lines.append(f"| {r['name']} | {key} | {n} | {ok / n:.1%} | {_pct(ts, 50)} | "
                         f"{_pct(ts, 90)} | {_pct(cp, 50)} | {_pct(cp, 90)} | {length} | "
                         f"{dur} |")
    lines.append("")
    lines.append("Wall times ([ms]) are what a caller waits; CPU times are the process's CPU "
                 "time for the same calls (the machine is shared: load average "
                 + ", ".join(f"{r['name']} {r['load'][0]:.1f}-{r['load'][1]:.1f}"  # type: ignore[index]
                             for r in results)
                 + " on its cores during the runs).")
    lines += ["", "Shortcutting the same raw RRTConnect paths (those of `OMPL direct`), with the "
              "same segment check:", "",
              "| arm | method | paths | median [ms] | p90 [ms] | joint path length (median) |",
              "|---|---|---|---|---|---|"]
    for r in results:
        for key, rows in r["shortcuts"].items():  # type: ignore[union-attr]
            ts = [a for a, _ in rows]
            ln = f"{np.median([b for _, b in rows]):.2f}" if rows else "-"
            shown = ("-", "-") if key == "raw" else (_pct(ts, 50), _pct(ts, 90))
            lines.append(f"| {r['name']} | {key} | {len(rows)} | {shown[0]} | {shown[1]} | "
                         f"{ln} |")
    lines.append("")
    for r in results:
        lines.append(f"{r['name']}: candidates rejected while generating {r['n']} problems: "
                     + ", ".join(f"{k} {v}" for k, v in r["stats"].items()  # type: ignore[union-attr]
                                 if k != "kept"))
    return "\n".join(lines)


def main() -> None:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--problems", type=int, default=100, help="problems per arm")
    ap.add_argument("--arms", default=",".join(ARMS))
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--write", action="store_true", help="write docs/benchmarks.md")
    args = ap.parse_args()
    results = []
    for name in args.arms.split(","):
        r = run_arm(name, args.problems, args.seed)
        print(f"{name}: {args.problems} problems generated in {r['gen']:.1f} s "
              f"(candidates: {r['stats']})", flush=True)
        results.append(r)
    text = report(results)
    print(text)
    if args.write:
        from _benchdoc import write_section

        cmd = "python tools/bench_plan.py" + (
            f" --problems {args.problems}" if args.problems != 100 else "")
        print(write_section("plan", text, cmd))


if __name__ == "__main__":
    main()
