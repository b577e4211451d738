"""Benchmark armctl's IK against peers in one run; writes the ``ik`` section of docs/benchmarks.md.

Protocol: for every arm, random reachable full-pose goals (FK of uniform random configurations
inside the limits, fixed seed), every solver started from the middle of the joint ranges. A
result counts as a success only if armctl's forward kinematics of the returned q meets the goal
(position and rotation error within the tolerance) and q is inside the limits; a peer that
reports success without meeting that is counted as a false success. Two tolerances: 1e-6 m /
1e-6 rad and 1 mm / 0.01 rad.

Peers (bench-only dependencies): roboticstoolbox-python ``ETS.ik_LM`` (C++; run with tol 1e-13
for the tight and its default 1e-6 for the loose tolerance), ikpy (scipy optimiser), and a
Levenberg-Marquardt loop with random restarts written here on top of pinocchio's compiled
kinematics. All peers get the same kinematic chain, built from armctl's model.

Usage: python tools/bench_ik.py [--goals 1000] [--ikpy-goals 100] [--arms panda ur5e wx250s so101]
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _benchdoc import write_section

from armctl.arm import Arm, load_arm
from armctl.ik import DirectionGoal, IKOptions, PoseGoal, Tolerance, evaluate, solve_batch
from armctl.spatial import matrix_to_rpy

TIGHT = Tolerance(1e-6, 1e-6)
LOOSE = Tolerance(1e-3, 0.01)


@dataclass
class Tally:
    """Outcomes of one solver on one arm at one tolerance."""

    times: list[float] = field(default_factory=list)
    ok: int = 0
    claimed: int = 0
    false: int = 0
    n: int = 0

    def add(self, t: float, ok: bool, claimed: bool) -> None:
        self.times.append(t)
        self.n += 1
        self.ok += ok
        self.claimed += claimed
        self.false += claimed and not ok

    def row(self, arm: str, solver: str, tol: str) -> list[str]:
        ts = np.array(self.times) * 1e3
        return [arm, solver, tol, str(self.n), f"{100 * self.ok / self.n:.1f} %",
                f"{np.median(ts):.3f}", f"{np.percentile(ts, 95):.3f}",
                str(self.false) if self.false else "0"]


def chain_of(arm: Arm) -> tuple[list[int], int]:
    """Joint indices from the base to the tool, and the tool's frame index."""
    return list(arm.chain()), arm.frame_index(None)


def _align(axis: np.ndarray) -> np.ndarray:
    """A rotation taking z onto ``axis``."""
    z = np.array([0.0, 0.0, 1.0])
    v = np.cross(z, axis)
    c = float(z @ axis)
    if np.linalg.norm(v) < 1e-12:
        return np.eye(3) if c > 0 else np.diag([1.0, -1.0, -1.0])
    k = np.array([[0, -v[2], v[1]], [v[2], 0, -v[0]], [-v[1], v[0], 0]])
    return np.eye(3) + k + k @ k / (1 + c)


# ---- peers ------------------------------------------------------------------------------------
def rtb_solver(arm: Arm) -> Callable[[np.ndarray, np.ndarray, float], tuple[np.ndarray, bool]]:
    """roboticstoolbox ETS.ik_LM on the arm's tool chain."""
    import roboticstoolbox as rtb

    joints, f = chain_of(arm)
    ets_list = []  # one ETS built at the end: every joint ET then gets its index
    for j in joints:
        axis = arm.tree.joint_axis(j)
        ets_list.append(rtb.ET.SE3(arm.tree.joint_origin(j)))
        qlim = [arm.lower[j], arm.upper[j]]
        canon = {(1, 0, 0): rtb.ET.Rx, (0, 1, 0): rtb.ET.Ry, (0, 0, 1): rtb.ET.Rz}
        key = tuple(round(a) for a in axis)
        if key in canon and np.allclose(axis, key):
            ets_list.append(canon[key](qlim=qlim))
        else:
            r = np.eye(4)
            r[:3, :3] = _align(axis)
            ets_list += [rtb.ET.SE3(r), rtb.ET.Rz(qlim=qlim), rtb.ET.SE3(np.linalg.inv(r))]
    ets_list.append(rtb.ET.SE3(arm.tree.frame_offset(f)))
    ets = rtb.ETS(ets_list)

    def solve(goal: np.ndarray, q0: np.ndarray, tol: float) -> tuple[np.ndarray, bool]:
        sol = ets.ik_LM(goal, q0=q0[joints], ilimit=30, slimit=100, tol=tol, joint_limits=True)
        q = q0.copy()
        q[joints] = sol.q
        return q, bool(sol.success)

    return solve


def ikpy_solver(arm: Arm) -> Callable[[np.ndarray, np.ndarray, float], tuple[np.ndarray, bool]]:
    """ikpy's scipy-based solver on the arm's tool chain."""
    from ikpy.chain import Chain
    from ikpy.link import OriginLink, URDFLink

    joints, f = chain_of(arm)
    links = [OriginLink()]
    for j in joints:
        t = arm.tree.joint_origin(j)
        links.append(URDFLink(arm.joint_names[j], t[:3, 3], matrix_to_rpy(t[:3, :3]),
                              rotation=arm.tree.joint_axis(j),
                              bounds=(arm.lower[j], arm.upper[j])))
    t = arm.tree.frame_offset(f)
    links.append(URDFLink("tool", t[:3, 3], matrix_to_rpy(t[:3, :3]), joint_type="fixed"))
    chain = Chain(links, active_links_mask=[False] + [True] * len(joints) + [False])

    def solve(goal: np.ndarray, q0: np.ndarray, tol: float) -> tuple[np.ndarray, bool]:
        init = np.concatenate([[0.0], q0[joints], [0.0]])
        sol = chain.inverse_kinematics(goal[:3, 3], goal[:3, :3], orientation_mode="all",
                                       initial_position=init)
        q = q0.copy()
        q[joints] = sol[1:-1]
        return q, True  # ikpy reports no success flag: every answer is a claim

    return solve


def pinocchio_solver(arm: Arm, seed: int = 0) -> Callable[[np.ndarray, np.ndarray, float],
                                                           tuple[np.ndarray, bool]]:
    """A Levenberg-Marquardt loop with random restarts on pinocchio's kinematics."""
    import pinocchio as pin

    joints, f = chain_of(arm)
    model = pin.Model()
    parent = 0
    for j in joints:
        t = arm.tree.joint_origin(j)
        parent = model.addJoint(parent, pin.JointModelRevoluteUnaligned(arm.tree.joint_axis(j)),
                                pin.SE3(t[:3, :3], t[:3, 3]), arm.joint_names[j])
    t = arm.tree.frame_offset(f)
    fid = model.addFrame(pin.Frame("tool", parent, pin.SE3(t[:3, :3], t[:3, 3]),
                                   pin.FrameType.OP_FRAME))
    lo, hi = arm.lower[joints], arm.upper[joints]
    model.lowerPositionLimit = lo
    model.upperPositionLimit = hi
    data = model.createData()
    rng = np.random.default_rng(seed)

    def solve(goal: np.ndarray, q0: np.ndarray, tol: float) -> tuple[np.ndarray, bool]:
        target = pin.SE3(goal[:3, :3], goal[:3, 3])
        q = q0[joints].copy()
        best, best_err = q.copy(), np.inf
        for attempt in range(51):
            if attempt:
                q = rng.uniform(lo, hi)
            for _ in range(100):
                pin.forwardKinematics(model, data, q)
                pin.updateFramePlacement(model, data, fid)
                diff = data.oMf[fid].actInv(target)
                err = pin.log6(diff).vector
                nerr = float(np.linalg.norm(err))
                if nerr < best_err:
                    best, best_err = q.copy(), nerr
                if np.linalg.norm(err[:3]) < tol and np.linalg.norm(err[3:]) < tol:
                    out = q0.copy()
                    out[joints] = q
                    return out, True
                jac = pin.computeFrameJacobian(model, data, q, fid, pin.LOCAL)
                jac = pin.Jlog6(diff.inverse()) @ jac
                lam = 1e-8 + 0.5 * nerr**2
                dq = jac.T @ np.linalg.solve(jac @ jac.T + lam * np.eye(6), err)
                q = np.clip(pin.integrate(model, q, dq), lo, hi)
        out = q0.copy()
        out[joints] = best
        return out, False

    return solve


# ---- the run ----------------------------------------------------------------------------------
def goals_for(arm: Arm, n: int, seed: int) -> np.ndarray:
    """Tool poses of uniform random configurations inside the limits."""
    return arm.fk_batch(arm.sample(np.random.default_rng(seed), n))


def run_peer(arm: Arm, solve: Callable[..., tuple[np.ndarray, bool]], poses: np.ndarray,
             tol: Tolerance, peer_tol: float) -> Tally:
    tally = Tally()
    q0 = arm.middle()
    for pose in poses[:10]:  # warm-up, not timed
        solve(pose, q0, peer_tol)
    for pose in poses:
        t0 = time.perf_counter()
        q, claimed = solve(pose, q0, peer_tol)
        dt = time.perf_counter() - t0
        q = np.asarray(q, dtype=float)
        ok = arm.within_limits(q) and evaluate(arm, (PoseGoal(pose, tolerance=tol),), q)[0].reached
        tally.add(dt, ok, claimed)
    return tally


def run_armctl(arm: Arm, solver: str, poses: np.ndarray, tol: Tolerance,
               direction: bool = False) -> Tally:
    tally = Tally()
    for pose in poses[:20]:  # compile / load / warm up outside the timing
        arm.ik(PoseGoal(pose), solver=solver, options=IKOptions(max_iterations=20, restarts=1))
    for i, pose in enumerate(poses):
        goal = (DirectionGoal(pose[:3, 3], pose[:3, 2], tolerance=tol) if direction
                else PoseGoal(pose, tolerance=tol))
        res = arm.ik(goal, solver=solver, options=IKOptions(seed=i))
        tally.add(res.time, res.success, res.success)
    return tally


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=1000)
    ap.add_argument("--ikpy-goals", type=int, default=100)
    ap.add_argument("--arms", nargs="+", default=["panda", "ur5e", "wx250s", "so101"])
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args(argv)
    rows: list[list[str]] = []
    batch_rows: list[list[str]] = []
    medians: dict[tuple[str, str, str], float] = {}
    for name in args.arms:
        arm = load_arm(name)
        poses = goals_for(arm, args.goals, args.seed)
        five = len(arm.chain()) < 6
        for tol, tag, rtb_tol in ((TIGHT, "1e-6", 1e-13), (LOOSE, "1mm/0.01", 1e-6)):
            for solver in ("auto", "dls", "pinv", "ccd", "jt", "ccd-jt"):
                if tag != "1e-6" and solver not in ("auto", "dls"):
                    continue
                n_goals = poses if solver in ("auto", "dls", "pinv") else poses[:args.ikpy_goals]
                tally = run_armctl(arm, solver, n_goals, tol, five)
                medians[(name, solver, tag)] = float(np.median(tally.times))
                rows.append(tally.row(name, f"armctl {solver}" + (" (5-DOF goal)" if five
                                                                   else ""), tag))
                print(" | ".join(rows[-1]), flush=True)
            if five:
                continue  # the peers take full poses only; a 5-joint arm cannot reach those
            peers = [("roboticstoolbox ik_LM", rtb_solver(arm), poses, rtb_tol),
                     ("pinocchio LM + restarts", pinocchio_solver(arm), poses[:args.ikpy_goals * 3],
                      tol.position),
                     ("ikpy", ikpy_solver(arm), poses[:args.ikpy_goals], 0.0)]
            for label, solve, sub, ptol in peers:
                tally = run_peer(arm, solve, sub, tol, ptol)
                medians[(name, label, tag)] = float(np.median(tally.times))
                suffix = f" (tol={ptol:g})" if label.startswith("robotics") else ""
                rows.append(tally.row(name, label + suffix, tag))
                print(" | ".join(rows[-1]), flush=True)
        res = solve_batch(arm, [DirectionGoal(p[:3, 3], p[:3, 2], tolerance=TIGHT) for p in poses]
                          if five else poses, tolerance=TIGHT)
        res = solve_batch(arm, [DirectionGoal(p[:3, 3], p[:3, 2], tolerance=TIGHT) for p in poses]
                          if five else poses, tolerance=TIGHT)
        batch_rows.append([name, str(len(res)), f"{100 * res.success.mean():.1f} %",
                           f"{res.time * 1e3:.1f}", f"{res.time / len(res) * 1e3:.3f}"])
    header = ["arm", "solver", "tolerance", "goals", "success", "median [ms]", "p95 [ms]",
              "false successes"]
    md = ["## Inverse kinematics (tools/bench_ik.py)", "",
          "Random reachable goals (FK of uniform random configurations inside the limits, seed "
          f"{args.seed}), started from the middle of the joint ranges; full poses, except on "
          "arms with fewer than 6 joints in the tool chain (SO-101), where armctl solves the "
          "5-DOF goal (position + tool z axis) and the full-pose peers are not run. Success = "
          "armctl's FK of the answer within the tolerance and inside the limits. 'False "
          "successes' counts answers the solver reported as solved that fail this check "
          "(ikpy reports no flag: each of its answers counts as a claim). Tolerances: '1e-6' = "
          "1e-6 m and 1e-6 rad; '1mm/0.01' = 1e-3 m and 0.01 rad. roboticstoolbox runs with "
          "tol=1e-13 for the tight and its default tol=1e-6 for the loose tolerance. ikpy, "
          "pinocchio, and armctl's slow methods (pinv excepted) run on the first "
          f"{args.ikpy_goals} (pinocchio {args.ikpy_goals * 3}) goals.", "",
          "| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    md += ["| " + " | ".join(r) + " |" for r in rows]
    ratio_rows = []
    for name in args.arms:
        for tag in ("1e-6", "1mm/0.01"):
            ref = medians.get((name, "roboticstoolbox ik_LM", tag))
            if ref:
                ratio_rows.append([name, tag] + [
                    f"{medians[(name, s, tag)] / ref:.2f}" for s in ("auto", "dls")])
    md += ["", "Median time of armctl relative to roboticstoolbox ik_LM in this run (target: at "
           "most 2; below 1 is faster):", "", "| arm | tolerance | auto | dls |",
           "|---|---|---|---|"]
    md += ["| " + " | ".join(r) + " |" for r in ratio_rows]
    md += ["", "Batch entry point (`armctl.ik.solve_batch`, dls, 1e-6, all goals in one "
           "compiled call):", "", "| arm | goals | success | total [ms] | per goal [ms] |",
           "|---|---|---|---|---|"]
    md += ["| " + " | ".join(r) + " |" for r in batch_rows]
    text = "\n".join(md)
    if args.no_write:
        print(text)
    else:
        cmd = "python tools/bench_ik.py " + " ".join(argv if argv is not None else sys.argv[1:])
        print(f"wrote {write_section('ik', text, cmd.strip())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
