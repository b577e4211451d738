"""IK cost per call from random starts, and the fixed cost of a call; writes the ``ik-call``
section of docs/benchmarks.md.

Robots: by default the reference robots (:data:`REFERENCE`): the Franka Panda and the UR5 of
the example-robot-data package, the KUKA KR6 R900 sixx of the rtb-data package (its xacro,
expanded with xacrodoc) and the SO-ARM100 of example-robot-data (``so100.urdf``, 5 arm joints,
tool: its ``gripper`` link); bench-only packages. Bundled arms by name (``--arms panda ur5e
wx250s so101``) work too.

Protocol: per arm, random reachable goals (FK of uniform random configurations inside the
limits, fixed seed) and random starts (uniform inside the limits, another seed). Every call is
timed from the caller's side, building the goal included: ``arm.ik(PoseGoal(T, tolerance=tol),
q0)`` (the bundled 5-joint SO-101: a ``DirectionGoal``, position + tool z axis; the SO-ARM100
gets full poses, which FK of its own configurations makes reachable). Success = armctl's FK of
the answer within 1e-6 m and 1e-6 rad and inside the limits; an answer reported as solved that
fails this check is a false success. The peer, roboticstoolbox-python ``ETS.ik_LM`` (C++, tol
1e-13, joint limits on; its chain built from armctl's model as in tools/bench_ik.py), solves the
same goals from the same starts, the two interleaved goal by goal (the order alternating per
pass). The fixed cost is the time of a call that needs no iteration: the start is the
configuration that generated the goal.

``--against DIR`` measures armctl only, in fresh processes alternating between this checkout
and the armctl package in DIR (e.g. a git worktree of an earlier commit), and writes the
``ik-call-versions`` section instead.

Usage: python tools/bench_ik_call.py [--goals 300] [--passes 5] [--arms ROBOT ...]
       python tools/bench_ik_call.py --against /path/to/other/checkout [--passes 6]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import time
import timeit
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

if TYPE_CHECKING:
    from armctl.arm import Arm

sys.path.insert(0, str(Path(__file__).resolve().parent))

ROOT = Path(__file__).resolve().parent.parent
TOL = 1e-6


#: The reference robots: name -> (label, where the description comes from, the tool link).
REFERENCE = {
    "panda-erd": ("Franka Panda (example-robot-data)", "erd:panda_description/urdf/panda.urdf",
                  "panda_hand_tcp"),
    "ur5-erd": ("UR5 (example-robot-data)", "erd:ur_description/urdf/ur5_robot.urdf", None),
    "kr6-rtb": ("KUKA KR6 R900 sixx (rtb-data)", "kr6", None),
    "so100-erd": ("SO-ARM100 (example-robot-data)", "erd:so_arm_description/urdf/so100.urdf",
                  "gripper"),
}
ERD = "cmeel.prefix/share/example-robot-data/robots"
_TMP: list[Any] = []


def load_robot(name: str) -> Arm:
    """A bundled arm by name, or a reference robot (:data:`REFERENCE`) from its package."""
    from armctl.arm import load_arm

    if name not in REFERENCE:
        return load_arm(name)
    _, where, tip = REFERENCE[name]
    if where == "kr6":
        import tempfile

        from bench_analytic_reference import reference_urdfs

        if not _TMP:
            _TMP.append(tempfile.TemporaryDirectory())
        found, missing = reference_urdfs(Path(_TMP[0].name))
        path = found.get("KUKA KR6 R900 sixx (rtb-data)")
        if path is None:
            raise SystemExit(f"{name}: {'; '.join(missing)}")
        return load_arm(path)
    rel = where.split(":", 1)[1]
    for d in sys.path:
        cand = Path(d) / ERD / rel
        if cand.is_file():
            return load_arm(cand, tip=tip)
    raise SystemExit(f"{name}: `pip install example-robot-data` (bench only)")


def robot_label(name: str) -> str:
    """How the tables name a robot."""
    return REFERENCE[name][0] if name in REFERENCE else name


def _setup(name: str, n: int, seed: int) -> tuple[Any, ...]:
    from armctl.ik import DirectionGoal, PoseGoal, Tolerance

    arm = load_robot(name)
    q_goal = arm.sample(np.random.default_rng(seed), n)
    poses = arm.fk_batch(q_goal)
    starts = arm.sample(np.random.default_rng(seed + 1), n)
    tol = Tolerance(TOL, TOL)
    if len(arm.chain()) < 6 and name not in REFERENCE:
        def make(p: np.ndarray) -> object:
            return DirectionGoal(p[:3, 3], p[:3, 2], tolerance=tol)
    else:
        def make(p: np.ndarray) -> object:
            return PoseGoal(p, tolerance=tol)
    return arm, q_goal, poses, starts, make


def _armctl_only(names: list[str], n: int, passes: int, seed: int) -> dict[str, dict[str, float]]:
    """Median armctl call [us] from random starts and from the goal's own configuration."""
    out = {}
    for name in names:
        arm, q_goal, poses, starts, make = _setup(name, n, seed)
        for i in range(min(n, 30)):  # load the compiled kernels outside the timing
            arm.ik(make(poses[i]), starts[i])
        rand, zero, ok = [], [], 0
        for _ in range(passes):
            for i in range(n):
                t0 = time.perf_counter()
                res = arm.ik(make(poses[i]), starts[i])
                rand.append(time.perf_counter() - t0)
                ok += res.success
                t0 = time.perf_counter()
                arm.ik(make(poses[i]), q_goal[i])
                zero.append(time.perf_counter() - t0)
        out[name] = {"random": float(np.median(rand)) * 1e6, "fixed": float(np.median(zero)) * 1e6,
                     "success": ok / (n * passes)}
    return out


def _version(tree: str) -> str:
    """The short commit of a git checkout, marked when its files differ from it."""
    def git(*cmd: str) -> str:
        return subprocess.run(["git", "-C", tree, *cmd], capture_output=True, text=True,
                              check=False).stdout.strip()

    head = git("rev-parse", "--short", "HEAD") or Path(tree).name
    return head + (" + changes" if git("status", "--porcelain", "--untracked-files=no") else "")


def against(args: argparse.Namespace) -> int:
    """Alternate fresh processes of this checkout and ``args.against``; report the ratios."""
    trees = {"this": str(ROOT), "other": str(Path(args.against).resolve())}
    runs: dict[str, list[dict]] = {k: [] for k in trees}
    load = [os.getloadavg()[0]]
    for r in range(args.passes):
        for k in (list(trees) if r % 2 == 0 else list(trees)[::-1]):
            env = dict(os.environ, PYTHONPATH=trees[k])
            cmd = [sys.executable, __file__, "--child", "--goals", str(args.goals), "--seed",
                   str(args.seed), "--arms", *args.arms]
            done = subprocess.run(cmd, env=env, capture_output=True, text=True, check=True,
                                  cwd=trees[k])
            runs[k].append(json.loads(done.stdout.strip().splitlines()[-1]))
    load.append(os.getloadavg()[0])
    this, other = _version(trees["this"]), args.label or _version(trees["other"])
    head = ["arm", "start", f"{other} [us]", f"{this} [us]", "ratio (per-run range)",
            "success"]
    md = ["## IK per call: two versions side by side (tools/bench_ik_call.py --against)", "",
          f"The armctl calls of the 'ik-call' section (goal built inside the timing, 1e-6 m / "
          f"1e-6 rad, {args.goals} goals x 2 passes per run), run by fresh processes that "
          f"alternate between two versions, {args.passes} runs each; medians over the runs' "
          "median call times, and the range of the per-run ratios (this run's noise).", "",
          "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for name in args.arms:
        for what, label in (("random", "random"), ("fixed", "goal's own configuration")):
            a = np.array([x[name][what] for x in runs["this"]])
            b = np.array([x[name][what] for x in runs["other"]])
            ratio = a / b
            ok_this, ok_other = runs["this"][0][name]["success"], runs["other"][0][name]["success"]
            md.append(f"| {robot_label(name)} | {label} | {np.median(b):.1f} | "
                      f"{np.median(a):.1f} | "
                      f"{np.median(ratio):.2f} ({ratio.min():.2f}-{ratio.max():.2f}) | "
                      f"{100 * ok_other:.1f} % / {100 * ok_this:.1f} % |")
    md += ["", f"Load average of the machine: {load[0]:.1f} at the start, {load[1]:.1f} at the "
           "end."]
    text = "\n".join(md)
    print(text)
    if not args.no_write:
        from _benchdoc import write_section

        cmd = "python tools/bench_ik_call.py " + " ".join(
            a if not a.startswith("/") else "DIR" for a in (
                args.argv if args.argv is not None else sys.argv[1:]))
        print(f"wrote {write_section('ik-call-versions', text, cmd.strip())}")
    return 0


def _fixed_parts(arm: Arm, q: np.ndarray, pose: np.ndarray, make: Callable[..., Any]
                 ) -> dict[str, float]:
    """Best-of-25 time [us] of the parts of a call that needs no iteration."""
    from armctl.ik import IKOptions, IKStatus, finish
    from armctl.ik import _engine as E
    from armctl.ik._pack import goal_kernel, model_arrays, seed_value
    from armctl.ik.numerical import method_params
    from armctl.ik.result import converged

    goal = make(pose)
    goals = (goal,)
    ma = model_arrays(arm)
    prm = method_params(arm, E.DLS, IKOptions())
    gk = goal_kernel(arm, goals)
    out, errs = np.empty(arm.dof), np.empty((1, 2))
    run = (E.DLS, prm, 100, 51, time.perf_counter() + 1e6)
    parts = {
        "whole call": lambda: arm.ik(make(pose), q),
        "goal construction (checks)": lambda: make(pose),
        "solve with a built goal": lambda: arm.ik(goal, q),
        "compiled core: solve + answer check": lambda: E.solve_checked(
            q, ma.kernel, gk, run, seed_value(0), out, errs),
        "result object": lambda: converged(arm.tool, goals, np.empty(arm.dof), ((0.0, 0.0),),
                                           0.0, 0.0, solver="auto", iterations=0, restarts=0,
                                           started=0.0),
        "a failed answer's check (finish)": lambda: finish(
            arm, goals, q, solver="auto", status=IKStatus.CONVERGED, iterations=0, restarts=0,
            started=0.0),
    }
    times = {}
    for label, fn in parts.items():
        for _ in range(200):
            fn()
        times[label] = min(timeit.repeat(fn, number=200, repeat=60)) / 200 * 1e6
    return times


def _measure_arm(name: str, args: argparse.Namespace) -> tuple[list[list[str]],
                                                                dict[str, float]]:
    """The table rows of one arm (armctl and rtb, interleaved) and its fixed-cost parts."""
    from bench_ik import rtb_solver

    from armctl.ik import PoseGoal, Tolerance, evaluate

    arm, q_goal, poses, starts, make = _setup(name, args.goals, args.seed)
    five = len(arm.chain()) < 6 and name not in REFERENCE  # a 5-DOF goal, which rtb cannot take
    rtb = None if five else rtb_solver(arm)
    check_tol = Tolerance(TOL, TOL)

    def ok(q: np.ndarray, pose: np.ndarray) -> bool:
        goal = make(pose) if five else PoseGoal(pose, tolerance=check_tol)
        return bool(arm.within_limits(q) and evaluate(arm, (goal,), q)[0].reached)

    for i in range(min(args.goals, 30)):  # compiled kernels loaded outside the timing
        arm.ik(make(poses[i]), starts[i])
        if rtb:
            rtb(poses[i], starts[i], 1e-13)
    stats: dict[str, dict] = {k: {"t": [], "ok": 0, "false": 0, "pass": []} for k in
                              ("armctl", "rtb", "armctl fixed", "rtb fixed")}

    def run_armctl(i: int, q0: np.ndarray, key: str) -> None:
        t0 = time.perf_counter()
        res = arm.ik(make(poses[i]), q0)
        stats[key]["t"].append(time.perf_counter() - t0)
        good = ok(res.q, poses[i])
        stats[key]["ok"] += good
        stats[key]["false"] += res.success and not good

    def run_rtb(i: int, q0: np.ndarray, key: str) -> None:
        assert rtb is not None
        t0 = time.perf_counter()
        q, claimed = rtb(poses[i], q0, 1e-13)
        stats[key]["t"].append(time.perf_counter() - t0)
        good = ok(np.asarray(q, dtype=float), poses[i])
        stats[key]["ok"] += good
        stats[key]["false"] += claimed and not good

    order = [("armctl", run_armctl)] + ([("rtb", run_rtb)] if rtb else [])
    for p in range(args.passes):
        first = {key: len(s["t"]) for key, s in stats.items()}
        for i in range(args.goals):
            for label, fn in (order if p % 2 == 0 else order[::-1]):
                fn(i, starts[i], label)
                fn(i, q_goal[i], label + " fixed")
        for key, s in stats.items():
            if len(s["t"]) > first[key]:
                s["pass"].append(float(np.median(s["t"][first[key]:])))
    n = args.goals * args.passes
    rows = []
    for key in ("armctl", "rtb", "armctl fixed", "rtb fixed"):
        s = stats[key]
        if not s["t"]:
            continue
        peer = stats[key.replace("armctl", "rtb")]
        ratio = "-"
        if key.startswith("armctl") and peer["t"]:
            per_pass = np.array(s["pass"]) / np.array(peer["pass"])
            ratio = (f"{np.median(s['t']) / np.median(peer['t']):.2f} "
                     f"({per_pass.min():.2f}-{per_pass.max():.2f})")
        who = ("armctl `arm.ik(...)`" if key.startswith("armctl") else
               "roboticstoolbox `ik_LM` (tol=1e-13)")
        start = "goal's own configuration (0 iterations)" if key.endswith("fixed") else "random"
        rows.append([robot_label(name) + (" (5-DOF goal)" if five else ""), who, start, str(n),
                     f"{100 * s['ok'] / n:.1f} %", f"{np.median(s['t']) * 1e6:.1f}",
                     f"{np.percentile(s['t'], 95) * 1e6:.1f}", str(s["false"]), ratio])
        print(" | ".join(rows[-1]), flush=True)
    return rows, _fixed_parts(arm, q_goal[0], poses[0], make)


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=300)
    ap.add_argument("--passes", type=int, default=5, help="passes over the goals (or runs "
                    "per checkout with --against)")
    ap.add_argument("--arms", nargs="+", default=list(REFERENCE),
                    help="reference robots (%(default)s) or bundled arms (panda, ur5e, ...)")
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--against", help="another armctl checkout to compare with (prints only)")
    ap.add_argument("--label", help="how the table names the --against checkout (default: "
                    "its git commit, or its directory's name)")
    ap.add_argument("--child", action="store_true", help=argparse.SUPPRESS)
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args(argv)
    args.argv = argv
    if args.child:
        print(json.dumps(_armctl_only(args.arms, args.goals, 2, args.seed)))
        return 0
    if args.against:
        return against(args)

    load = [os.getloadavg()[0]]
    rows, part_rows, part_labels = [], [], []
    for name in args.arms:
        arm_rows, parts = _measure_arm(name, args)
        rows += arm_rows
        part_rows.append([robot_label(name)] + [f"{v:.1f}" for v in parts.values()])
        part_labels = list(parts)
        print(name, {k: round(v, 1) for k, v in parts.items()}, flush=True)
    load.append(os.getloadavg()[0])
    head = ["arm", "solver", "start", "calls", "success", "median [us]", "p95 [us]",
            "false successes", "armctl / rtb median (per-pass range)"]
    md = ["## IK per call: random starts and the fixed cost (tools/bench_ik_call.py)", "",
          "Random reachable goals (FK of uniform random configurations inside the limits, seed "
          f"{args.seed}) from random starts inside the limits (seed {args.seed + 1}), "
          f"{args.passes} passes over {args.goals} goals per arm. Each call is timed from the "
          "caller's side with the goal built inside the timing: `arm.ik(PoseGoal(T, "
          "tolerance=Tolerance(1e-6, 1e-6)), q0)`. Robots: the Franka Panda and the UR5 of the "
          "example-robot-data package, the KUKA KR6 R900 sixx of rtb-data (its xacro expanded "
          "with xacrodoc), the SO-ARM100 of example-robot-data (`so100.urdf`, 5 arm joints up to "
          "its `gripper` link: full poses, reachable as FK of its own configurations); a "
          "bundled 5-joint arm gets a `DirectionGoal` (position + tool z axis), which "
          "roboticstoolbox cannot take. Success = armctl's FK of the answer "
          "within 1e-6 m and 1e-6 rad and inside the limits; a false success is an answer "
          "reported as solved that fails this check. roboticstoolbox `ETS.ik_LM` (C++, "
          "tol=1e-13, joint limits on, chain built from armctl's model) solves the same goals "
          "from the same starts, interleaved goal by goal, the order alternating per pass. The "
          "'goal's own configuration' rows start at the configuration that generated the goal: "
          "no iteration is needed, so they measure the fixed cost of a call. Targets: a median "
          "from random starts at most 1.0x roboticstoolbox's with 100 % success and no false "
          "success; a fixed cost of at most 10 us.", "",
          "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    md += ["| " + " | ".join(r) + " |" for r in rows]
    md += ["", "Parts of a call that needs no iteration (best of 60 x 200 calls) [us]: "
           "'goal construction' checks the input (shape, finite numbers, the last row, the "
           "rotation residual max |R R^T - I| and det R; in one compiled call once the solvers "
           "are loaded, the Python check for anything it does not accept as it is); the "
           "'compiled core' checks the start, solves and checks the answer (FK of the wrapped "
           "answer, each goal's error against its tolerance, the joint limits) in one call; "
           "the 'result object' is built from that check; an answer the core does not accept "
           "gets the full Python check, 'finish', as every answer did before.", "",
           "| arm | " + " | ".join(part_labels) + " |", "|" + "---|" * (len(part_labels) + 1)]
    md += ["| " + " | ".join(r) + " |" for r in part_rows]
    md += ["", f"Load average of the machine: {load[0]:.1f} at the start, {load[1]:.1f} at the "
           "end (a shared machine: compare the ratios of one run)."]
    text = "\n".join(md)
    if args.no_write:
        print(text)
    else:
        from _benchdoc import write_section

        cmd = "python tools/bench_ik_call.py " + " ".join(
            argv if argv is not None else sys.argv[1:])
        print(f"wrote {write_section('ik-call', text, cmd.strip())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
