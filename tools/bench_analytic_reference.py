"""Analytic ``ik_all`` per call on the reference robots, side by side with EAIK, in one run.

Usage: python tools/bench_analytic_reference.py [--goals N] [--passes P] [--before GITREF]
                                                [--no-write]

The reference robots: the UR5 of the example-robot-data package (``ur5_robot.urdf``) and the
KUKA KR6 R900 sixx of the rtb-data package (its xacro, expanded with xacrodoc). For each, N
random configurations inside the joint limits (fixed seed) give N pose goals. Each pass times,
one after the other in one process, armctl's ``ik_all`` (Python call included, default options:
one row per solution) and EAIK's ``HPRobot.IK`` on the same goals (EAIK is given armctl's
idealised axes; its goals are converted to its tool frame beforehand, outside the timing). A
time per call comes from blocks of 50 goals, each timed solver after solver in 5 rounds (the
best round per block, see ``per_call``); the table gives the median over the passes, the
ratio of the medians, and the median, lowest and highest of the per-pass ratios. With
``--before GITREF`` each pass also runs the armctl of that git revision (``git archive``, in a
subprocess, so both trees are measured in alternation), with EAIK timed beside it there too.

Also reported: completeness (the share of goals whose generating configuration is among the
answers, up to 2 pi wraps, within 1e-6 rad) and the mean number of answers whose FK (by armctl)
is within 1e-9 m / rad of the goal. EAIK, example-robot-data, rtb-data and xacrodoc are
bench-only: a missing one skips its part with a message. Writes the section
``analytic-ik-reference`` of docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
UR5_URDF = "cmeel.prefix/share/example-robot-data/robots/ur_description/urdf/ur5_robot.urdf"


def reference_urdfs(out: Path) -> tuple[dict[str, Path], list[str]]:
    """The reference robots' URDF files (KR6 expanded into ``out``) and what is missing."""
    found: dict[str, Path] = {}
    missing = []
    for p in sys.path:
        cand = Path(p) / UR5_URDF
        if cand.is_file():
            found["UR5 (example-robot-data)"] = cand
            break
    else:
        missing.append("UR5: `pip install example-robot-data` (bench only)")
    try:
        import rtbdata
        from xacrodoc import XacroDoc, packages

        kuka = Path(rtbdata.__file__).parent / "xacro" / "kuka_description"
        packages.update_package_cache({"kuka_kr6_support": str(kuka / "kuka_kr6"),
                                       "kuka_resources": str(kuka / "kuka_resources")})
        doc = XacroDoc.from_file(kuka / "kuka_kr6" / "urdf" / "kr6r900sixx.xacro")
        path = out / "kr6r900sixx.urdf"
        path.write_text(doc.to_urdf_string())
        found["KUKA KR6 R900 sixx (rtb-data)"] = path
    except ImportError:
        missing.append("KR6 R900: `pip install rtb-data xacrodoc` (bench only)")
    return found, missing


#: Goals per timed block, and rounds over the blocks (see :func:`per_call`).
BLOCK, ROUNDS = 50, 5


def per_call(runs: list[tuple[Callable[[Any], object], list[Any]]]) -> list[float]:
    """Time of one call [us] of each ``(fn, goals)``, the solvers interleaved block by block.

    The goals are cut into blocks of :data:`BLOCK`; each round times every solver on each block
    in turn (solver after solver on the same block, so a burst of load on a shared machine hits
    them alike), and a block's time is its best over :data:`ROUNDS` rounds (a short block is
    often timed without a preemption); the time per call is the sum of the blocks' bests over
    the number of goals.
    """
    for fn, goals in runs:
        for g in goals[:5]:
            fn(g)
    n = len(runs[0][1])
    starts = range(0, n, BLOCK)
    best = [[float("inf")] * len(starts) for _ in runs]
    for _ in range(ROUNDS):
        for b, a in enumerate(starts):
            for k, (fn, goals) in enumerate(runs):
                block = goals[a:a + BLOCK]
                t = time.perf_counter()
                for g in block:
                    fn(g)
                best[k][b] = min(best[k][b], time.perf_counter() - t)
    return [sum(bk) / n * 1e6 for bk in best]


def _wrapped(a: np.ndarray) -> np.ndarray:
    return np.abs((a + np.pi) % (2 * np.pi) - np.pi)


def worker(spec: dict[str, Any]) -> dict[str, Any]:
    """One pass over every robot: armctl (the tree on ``sys.path``) and, if asked, EAIK."""
    import armctl
    from armctl.arm import load_arm
    from armctl.ik.analytic import GoalKind, decomposition, ik_all

    out: dict[str, Any] = {"_armctl": armctl.__file__}
    for label, info in spec["robots"].items():
        arm = load_arm(info["urdf"])
        qs = np.array(info["q"])
        poses = [arm.fk(q) for q in qs]

        def ours(g: np.ndarray, arm: Any = arm) -> object:
            return ik_all(arm, g)

        res: dict[str, Any] = {}
        runs: list[tuple[Callable[[Any], object], list[Any]]] = [(ours, poses)]
        if spec.get("quality"):
            found, exact = 0, []
            for q, g in zip(qs, poses, strict=True):
                sols = ik_all(arm, g)
                found += bool(len(sols)) and _wrapped(sols.q - q).max(axis=1).min() < 1e-6
                exact.append(sum(_ok(arm, r, g) for r in sols.q))
            res["armctl_found"] = found / len(qs)
            res["armctl_answers"] = float(np.mean(exact))
        if spec.get("eaik"):
            try:
                from eaik.IK_HP import HPRobot
            except ImportError:
                res["eaik"] = None
            else:
                c = decomposition(arm, None, GoalKind.POSE).chain
                bot = HPRobot(np.array(c.h), np.vstack(
                    [c.o[0], np.diff(c.o, axis=0), c.m[:3, 3] - c.o[-1]]))
                rm = c.m[:3, :3]
                theirs = []
                for g in poses:  # their tool frame (conversion outside the timing)
                    e = g.copy()
                    e[:3, :3] = g[:3, :3] @ rm.T
                    theirs.append(e)

                def eaik_call(g: np.ndarray, bot: Any = bot) -> Any:
                    r = bot.IK(g)
                    return r.Q[~r.is_LS]

                runs.append((eaik_call, theirs))
                res["eaik_family"] = bot.getKinematicFamily()
                if spec.get("quality"):
                    found, exact = 0, []
                    idx, sign = list(c.index), np.asarray(c.sign)
                    for q, g, e in zip(qs, poses, theirs, strict=True):
                        rows = []
                        for qe in eaik_call(e):
                            full = arm.middle().copy()
                            full[idx] = np.asarray(qe) * sign
                            rows.append(full)
                        rq = np.array(rows) if rows else np.zeros((0, arm.dof))
                        found += bool(len(rq)) and _wrapped(rq - q).max(axis=1).min() < 1e-6
                        exact.append(sum(_ok(arm, r, g) for r in rq))
                    res["eaik_found"] = found / len(qs)
                    res["eaik_answers"] = float(np.mean(exact))
        if not spec.get("quality"):  # the quality pass is not timed
            times = per_call(runs)
            res["armctl"] = times[0]
            if len(runs) > 1:
                res["eaik"] = times[1]
        out[label] = res
    return out


def _ok(arm: Any, q: np.ndarray, goal: np.ndarray) -> bool:
    t = arm.fk(q)
    return bool(np.linalg.norm(t[:3, 3] - goal[:3, 3]) <= 1e-9
                and np.abs(t[:3, :3] - goal[:3, :3]).max() <= 1e-9)


def run_tree(tree: Path, spec: dict[str, Any], tmp: Path) -> dict[str, Any]:
    """:func:`worker` in a subprocess on the armctl of ``tree``."""
    path = tmp / "spec.json"
    path.write_text(json.dumps(spec))
    env = dict(os.environ, PYTHONPATH=str(tree))
    proc = subprocess.run([sys.executable, str(Path(__file__).resolve()), "--worker", str(path)],
                          env=env, capture_output=True, text=True, check=False, cwd=tree)
    if proc.returncode:
        raise SystemExit(f"the run on {tree} failed:\n{proc.stderr[-2000:]}")
    return json.loads(proc.stdout.strip().splitlines()[-1])


def main() -> int:
    """Run the benchmark and write its section."""
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=500, help="random goals per robot (500)")
    ap.add_argument("--passes", type=int, default=7, help="interleaved passes (7)")
    ap.add_argument("--before", metavar="GITREF", help="also time the armctl of this revision")
    ap.add_argument("--no-write", action="store_true", help="print only")
    ap.add_argument("--worker", help=argparse.SUPPRESS)
    args = ap.parse_args()
    if args.worker:
        print(json.dumps(worker(json.loads(Path(args.worker).read_text()))))
        return 0
    sys.path.insert(0, str(HERE))
    from _benchdoc import write_section

    from armctl.arm import load_arm

    with tempfile.TemporaryDirectory() as tmpdir:
        tmp = Path(tmpdir)
        urdfs, missing = reference_urdfs(tmp)
        for m in missing:
            print(f"skipped: {m}", file=sys.stderr)
        if not urdfs:
            print("no reference robot available", file=sys.stderr)
            return 1
        try:
            import eaik  # noqa: F401
            have_eaik = True
        except ImportError:
            have_eaik = False
            print("skipped: EAIK (`pip install eaik`, bench only)", file=sys.stderr)
        rng = np.random.default_rng(2026)
        robots = {label: {"urdf": str(p), "q": load_arm(str(p)).sample(rng, args.goals).tolist()}
                  for label, p in urdfs.items()}
        before_tree = None
        if args.before:
            before_tree = tmp / "before"
            before_tree.mkdir()
            archive = subprocess.run(["git", "-C", str(ROOT), "archive", args.before, "armctl"],
                                     capture_output=True, check=True).stdout
            subprocess.run(["tar", "-x", "-C", str(before_tree)], input=archive, check=True)
            first = run_tree(before_tree, {"robots": robots}, tmp)  # compiles its kernels
            if not first["_armctl"].startswith(str(before_tree)):
                raise SystemExit(f"the before run imported {first['_armctl']}")
        load = [os.getloadavg()[0]]
        passes: list[dict[str, Any]] = []
        befores: list[dict[str, Any]] = []
        quality = worker({"robots": robots, "eaik": have_eaik, "quality": True})
        for _ in range(args.passes):
            if before_tree is not None:
                befores.append(run_tree(before_tree, {"robots": robots, "eaik": have_eaik}, tmp))
            passes.append(worker({"robots": robots, "eaik": have_eaik}))
            load.append(os.getloadavg()[0])
    lines = ["## Analytic IK on the reference robots, against EAIK", "",
             f"{args.goals} random pose goals per robot (configurations inside the joint limits, "
             f"seed 2026), {args.passes} interleaved passes; time per call in microseconds "
             "(median over the passes; in each pass the goals are timed in blocks of "
             f"{BLOCK}, armctl and EAIK in turn on each block, {ROUNDS} rounds, the best round "
             "per block; Python call included; armctl "
             "with default options: one row per solution, each the variant inside the limits "
             "nearest the reference). EAIK `HPRobot.IK` plus dropping its least-squares "
             "answers, on armctl's idealised axes, goals given in its tool frame. Found: share "
             "of goals whose generating configuration is among the answers (up to 2 pi); "
             "answers: mean number whose FK is within 1e-9 m / rad of the goal. Per pass: "
             "the ratio of that pass's two times (its median over the passes and, in "
             "brackets, the lowest and highest). 1-minute load "
             f"average during the run: {min(load):.1f}-{max(load):.1f} on "
             f"{os.cpu_count()} CPUs.", "",
             "| robot | armctl `ik_all` [us] | EAIK [us] | armctl / EAIK | per pass |"
             + (" armctl before [us] | EAIK, before's passes [us] | before / EAIK, per pass |"
                if befores and have_eaik else " armctl before [us] |" if befores else "")
             + " found armctl / EAIK | answers armctl / EAIK |",
             "|---|---:|---:|---:|---:|" + ("---:|---:|---:|" if befores and have_eaik
                                             else "---:|" if befores else "") + "---:|---:|"]

    def per_pass(runs: list[dict[str, Any]], label: str) -> str:
        r = sorted(p[label]["armctl"] / p[label]["eaik"] for p in runs)
        return f"{statistics.median(r):.2f} [{r[0]:.2f}-{r[-1]:.2f}]"

    for label in robots:
        ours = statistics.median(p[label]["armctl"] for p in passes)
        q = quality[label]
        row = f"| {label} | {ours:.1f} |"
        if have_eaik:
            theirs = statistics.median(p[label]["eaik"] for p in passes)
            row += f" {theirs:.1f} | {ours / theirs:.2f} | {per_pass(passes, label)} |"
        else:
            row += " - | - | - |"
        if befores:
            row += f" {statistics.median(b[label]['armctl'] for b in befores):.1f} |"
            if have_eaik:
                row += (f" {statistics.median(b[label]['eaik'] for b in befores):.1f} |"
                        f" {per_pass(befores, label)} |")
        if have_eaik:
            row += (f" {q['armctl_found']:.3f} / {q['eaik_found']:.3f} |"
                    f" {q['armctl_answers']:.2f} / {q['eaik_answers']:.2f} |")
        else:
            row += f" {q['armctl_found']:.3f} / - | {q['armctl_answers']:.2f} / - |"
        lines.append(row)
    if befores:
        rev = subprocess.run(["git", "-C", str(ROOT), "rev-parse", "--short", args.before],
                             capture_output=True, text=True, check=True).stdout.strip()
        lines += ["", f"Before: the armctl of git revision {rev} (`{args.before}` at the time), "
                  "timed the same way in a subprocess, in alternation with the current tree"
                  + (", side by side with EAIK in each of its passes." if have_eaik else ".")]
    if have_eaik:
        fams = {label: quality[label].get("eaik_family", "") for label in robots}
        lines += ["", "EAIK's families: " + "; ".join(f"{k}: {v}" for k, v in fams.items())
                  + "."]
    md = "\n".join(lines)
    print(md)
    if not args.no_write:
        cmd = ("python tools/bench_analytic_reference.py"
               + (f" --goals {args.goals}" if args.goals != 500 else "")
               + (f" --passes {args.passes}" if args.passes != 7 else "")
               + (f" --before {args.before}" if args.before else ""))
        print(write_section("analytic-ik-reference", md, cmd))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
