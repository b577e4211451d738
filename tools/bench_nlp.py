"""Benchmark of the NLP IK solver (CasADi) against scipy's SLSQP on the same pose goals.

Measures, per arm: build time of the CasADi problem; success rate and median time of cold
solves of random reachable pose goals (from the middle of the ranges, restarts within the
default budget); median time of warm-started solves of a streaming target; and SLSQP (single
start, same cost) on the same goals. Writes the ``nlp`` section of docs/benchmarks.md.

    python tools/bench_nlp.py [--n 1000] [--stream 500] [--no-write]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path

import numpy as np

from armctl.arm import Arm, load_arm
from armctl.config import bundled_configs
from armctl.ik import PoseGoal, PositionGoal
from armctl.ik.nlp import (
    AxisInCone,
    Constraint,
    InBox,
    InHalfSpace,
    InSphere,
    KeepOutSphere,
    NLPOptions,
    OnLine,
    OnPlane,
    clear_cache,
)
from armctl.ik.nlp.problem import get_problem
from armctl.kinematics.capsules import arm_capsules, segment_point_distance, world_segments

ROOT = Path(__file__).resolve().parent.parent
TEST_ARMS = ROOT / "tests" / "ik" / "nlp" / "data"


def _arm(name: str) -> tuple[Arm, str]:
    if name in bundled_configs():
        return load_arm(name), f"configs/{name}.yaml"
    return load_arm(TEST_ARMS / f"{name}.yaml"), f"tests/ik/nlp/data/{name}.yaml"


def _reached(arm: Arm, q: np.ndarray, target: np.ndarray) -> bool:
    return bool(PoseGoal(target).reached(arm.fk(q)) and arm.within_limits(q))


def _slsqp(arm: Arm, target: np.ndarray, q0: np.ndarray) -> np.ndarray:
    from scipy.optimize import minimize

    length = arm.tree.max_reach
    rho = 0.3

    def cost(q: np.ndarray) -> float:
        t = arm.fk(q)
        return float(np.sum((t[:3, 3] - target[:3, 3]) ** 2) / length ** 2
                     + rho ** 2 * np.sum((t[:3, :3] - target[:3, :3]) ** 2))

    bounds = list(zip(arm.lower, arm.upper, strict=True))
    res = minimize(cost, q0, method="SLSQP", bounds=bounds,
                   options={"maxiter": 200, "ftol": 1e-16})
    return np.clip(res.x, arm.lower, arm.upper)


class _Plain:
    """The plain formulation of the lecture (L. Kavan, *Metody skeletální animace*, 2002).

    min |p - p_t|^2 + |R - R_t|_F^2 within the limits, IPOPT defaults.
    """

    def __init__(self, arm: Arm):
        import casadi as ca

        from armctl.kinematics.symbolic import SymbolicFK

        sym = SymbolicFK(arm)
        rot, pos = sym.frame(None)
        p = ca.SX.sym("p", 12)
        cost = ca.sumsqr(pos - p[0:3]) + ca.sumsqr(rot - ca.reshape(p[3:12], 3, 3))
        self.arm = arm
        self.solver = ca.nlpsol("plain", "ipopt", {"x": sym.q, "p": p, "f": cost},
                                {"print_time": False, "ipopt.print_level": 0, "ipopt.sb": "yes"})

    def __call__(self, target: np.ndarray, q0: np.ndarray) -> np.ndarray:
        par = np.concatenate([target[:3, 3], target[:3, :3].ravel(order="F")])
        sol = self.solver(x0=q0, p=par, lbx=self.arm.lower, ubx=self.arm.upper)
        return np.clip(np.array(sol["x"]).reshape(-1), self.arm.lower, self.arm.upper)


def _constraints(arm: Arm, rng: np.random.Generator, q: np.ndarray) -> list[Constraint]:
    """Two random point constraints and a keep-out sphere, all satisfied by ``q``."""
    t = arm.fk(q)
    p = t[:3, 3]
    n = rng.normal(size=3)
    n /= np.linalg.norm(n)
    pool: list[Constraint] = [OnPlane(p, n), InHalfSpace(p - 0.05 * n, n), OnLine(p, n),
                              InBox(p - 0.1, p + 0.1), InSphere(p + 0.05 * n, 0.1),
                              AxisInCone(t[:3, 2], 0.3)]
    out = [pool[int(k)] for k in rng.choice(len(pool), size=2, replace=False)]
    caps = arm_capsules(arm)
    a, b = world_segments(arm, q, caps)
    for _ in range(20):  # an obstacle near the arm that this posture clears
        c = p + 0.3 * rng.normal(size=3)
        clear = min(segment_point_distance(a[k], b[k], c) - cap.radius
                    for k, cap in enumerate(caps))
        if clear > 0.08:
            out.append(KeepOutSphere(c, 0.05))
            break
    return out


def _met(arm: Arm, goal: PositionGoal, cons: list[Constraint], q: np.ndarray) -> bool:
    """The one success check of both solvers: the goal by FK, every hard constraint, limits."""
    return bool(goal.reached(arm.fk(q)) and arm.within_limits(q)
                and all(c.violation(arm, q) <= c.tolerance for c in cons if c.hard))


class _Naive:
    """Plain CasADi + IPOPT on a constrained problem, with random restarts.

    ``min |p - p_t|^2`` subject to the joint limits and the constraints' own rows (the same
    CasADi expressions as armctl's problem), IPOPT with default options (exact Hessian, MUMPS);
    one solver per constraint structure (built on first use, the build timed with that solve),
    the numbers as parameters. From the given start, then random starts until the answer
    passes :func:`_met` or the budget is spent.
    """

    def __init__(self, arm: Arm, budget: float):
        from armctl.kinematics.symbolic import SymbolicFK

        self.arm = arm
        self.budget = budget
        self.sym = SymbolicFK(arm)
        self.built: dict[tuple[object, ...], tuple[object, np.ndarray, np.ndarray]] = {}

    def _solver(self, cons: list[Constraint]) -> tuple[object, np.ndarray, np.ndarray]:
        key = tuple(c.structure() for c in cons)
        if key not in self.built:
            import casadi as ca

            sym = self.sym
            rot, pos = sym.frame(None)
            p = ca.SX.sym("p", 3 + sum(len(c.params()) for c in cons))
            rows, lbg = [], []
            at = 3
            for c in cons:
                size = len(c.params())
                segs = []
                if c.on_links:
                    for cap in arm_capsules(self.arm, getattr(c, "link_radius", None)):
                        a, b = np.array(cap.a), np.array(cap.b)
                        segs.append((sym.point(cap.body, a), sym.point(cap.body, b), cap.radius,
                                     float(np.linalg.norm(b - a))))
                r = c.rows(ca, rot, pos, segs, p[at:at + size])
                at += size
                rows.append(r)
                lbg += [0.0 if c.equality else -np.inf] * int(r.numel())
            nlp = {"x": sym.q, "p": p, "f": ca.sumsqr(pos - p[0:3]), "g": ca.vertcat(*rows)}
            solver = ca.nlpsol("naive", "ipopt", nlp, {"print_time": False,
                                                        "ipopt.print_level": 0,
                                                        "ipopt.sb": "yes"})
            self.built[key] = (solver, np.array(lbg), np.zeros(len(lbg)))
        return self.built[key]

    def __call__(self, goal: PositionGoal, cons: list[Constraint], q0: np.ndarray,
                 rng: np.random.Generator) -> tuple[np.ndarray, bool, int]:
        """(answer, success, attempts)."""
        t0 = time.perf_counter()
        solver, lbg, ubg = self._solver(cons)
        par = np.concatenate([goal.position, *(c.params() for c in cons)])
        arm, start, attempts = self.arm, q0, 0
        while True:
            attempts += 1
            sol = solver(x0=start, p=par, lbx=arm.lower, ubx=arm.upper,  # type: ignore[operator]
                         lbg=lbg, ubg=ubg)
            q = np.clip(np.array(sol["x"], dtype=float).reshape(-1), arm.lower, arm.upper)
            if _met(arm, goal, cons, q):
                return q, True, attempts
            if time.perf_counter() - t0 >= self.budget:
                return q, False, attempts
            start = arm.sample(rng)


def bench_constrained(name: str, n: int) -> dict[str, object]:
    """armctl's NLP and the naive peer on the same constrained problems, interleaved."""
    arm, source = _arm(name)
    rng = np.random.default_rng(7)
    budget = NLPOptions().time_limit
    naive = _Naive(arm, budget)
    peer_rng = np.random.default_rng(8)
    ok, times, ok_n, times_n, att_n = 0, [], 0, [], []
    cpu: list[float] = []
    cpu_n: list[float] = []
    for k in range(n):
        q = arm.sample(rng)
        cons = _constraints(arm, rng, q)
        goal = PositionGoal(arm.fk(q)[:3, 3])
        q0 = arm.sample(rng)
        for who in ((0, 1) if k % 2 == 0 else (1, 0)):  # alternate which runs first
            t0, c0 = time.perf_counter(), time.process_time()
            if who == 0:
                res = arm.ik(goal, q0, solver="nlp", constraints=cons)
                times.append(time.perf_counter() - t0)
                cpu.append(time.process_time() - c0)
                ok += _met(arm, goal, cons, res.q)
            else:
                qn, _, attempts = naive(goal, cons, q0, peer_rng)
                times_n.append(time.perf_counter() - t0)
                cpu_n.append(time.process_time() - c0)
                ok_n += _met(arm, goal, cons, qn)
                att_n.append(attempts)
    return {"arm": name, "source": source, "n": n, "ok": ok,
            "median": float(np.median(times)), "p90": float(np.percentile(times, 90)),
            "naive_ok": ok_n, "naive_median": float(np.median(times_n)),
            "naive_p90": float(np.percentile(times_n, 90)),
            "naive_attempts": float(np.mean(att_n)), "cpu": float(np.median(cpu)),
            "naive_cpu": float(np.median(cpu_n)), "load": os.getloadavg()[0]}


def bench_arm(name: str, n: int, n_stream: int) -> dict[str, object]:
    arm, source = _arm(name)
    rng = np.random.default_rng(2026)
    targets = [arm.fk(q) for q in arm.sample(rng, n)]
    opts = NLPOptions()
    # build time: a fresh cache, first problem (includes CasADi's code generation for SX)
    clear_cache()
    t0 = time.perf_counter()
    problem = get_problem(arm, (PoseGoal(targets[0]),), (), opts)
    _ = problem.solvers[True], problem.solvers[False]  # both instances (built on first use)
    build = time.perf_counter() - t0
    arm.ik(targets[0], solver="nlp", options=opts)  # warm the JIT of the solver that seeds NLP
    ok, times, restarts = 0, [], []
    for t in targets:
        res = arm.ik(PoseGoal(t), solver="nlp", options=opts)
        ok += res.success and _reached(arm, res.q, t)
        times.append(res.time)
        restarts.append(res.restarts)
    # the NLP's own restarts, without the numerical seed solver
    plain = NLPOptions(seed_solver="")
    ok_n, times_n = 0, []
    for t in targets:
        res = arm.ik(PoseGoal(t), solver="nlp", options=plain)
        ok_n += res.success and _reached(arm, res.q, t)
        times_n.append(res.time)
    plain_solver = _Plain(arm)
    ok_p, times_p = 0, []
    for t in targets:
        t0 = time.perf_counter()
        q = plain_solver(t, arm.middle())
        times_p.append(time.perf_counter() - t0)
        ok_p += _reached(arm, q, t)
    ok_s, times_s = 0, []
    for t in targets:
        t0 = time.perf_counter()
        q = _slsqp(arm, t, arm.middle())
        times_s.append(time.perf_counter() - t0)
        ok_s += _reached(arm, q, t)
    # streaming: a random walk of the target, each solve warm-started from the previous answer
    q_t = arm.sample(rng)
    res = arm.ik(PoseGoal(arm.fk(q_t)), q_t, solver="nlp", options=opts)
    q_prev = res.q
    stream, stream_ok = [], 0
    for _ in range(n_stream):
        q_t = np.clip(q_t + 0.01 * rng.standard_normal(arm.dof), arm.lower, arm.upper)
        res = arm.ik(PoseGoal(arm.fk(q_t)), q_prev, solver="nlp", options=opts)
        stream.append(res.time)
        stream_ok += res.success
        q_prev = res.q
    return {"arm": name, "source": source, "dof": arm.dof, "build": build, "n": n,
            "ok": ok, "median": float(np.median(times)), "p99": float(np.percentile(times, 99)),
            "mean_restarts": float(np.mean(restarts)), "slsqp_ok": ok_s,
            "plain_ok": ok_p, "plain_median": float(np.median(times_p)),
            "noseed_ok": ok_n, "noseed_median": float(np.median(times_n)),
            "slsqp_median": float(np.median(times_s)), "stream_n": n_stream,
            "stream_ok": stream_ok, "stream_median": float(np.median(stream))}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--n", type=int, default=1000, help="random pose goals per arm")
    ap.add_argument("--stream", type=int, default=500, help="streaming solves per arm")
    ap.add_argument("--constrained", type=int, default=200,
                    help="random constrained problems per arm")
    ap.add_argument("--arms", nargs="+", default=["ur5e", "panda"])
    ap.add_argument("--constrained-only", action="store_true",
                    help="only the constrained problems (print only)")
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args(argv)
    if args.constrained_only:
        for a in args.arms:
            print(bench_constrained(a, args.constrained))
        return 0
    rows = [bench_arm(a, args.n, args.stream) for a in args.arms]
    crows = [bench_constrained(a, args.constrained) for a in args.arms]
    lines = [
        "## NLP IK (CasADi) vs scipy SLSQP",
        "",
        "Random reachable pose goals (FK of uniform samples inside the limits), solved from the "
        "middle of the joint ranges; success = position within 1e-5 m and rotation within "
        "1e-4 rad by FK, inside the limits. NLP: default `NLPOptions` (0.2 s budget; without "
        "hard constraints `Method.AUTO` runs `sqpmethod`; restarts seeded by `dls`, then "
        "random). NLP without seed: the same with `seed_solver=\"\"` (the start, then random "
        "restarts only). Plain: the formulation of the lecture (L. Kavan, *Metody skeletální "
        "animace*, 2002) as is, `|p - p_t|^2 + |R - R_t|_F^2` "
        "within the limits, CasADi + IPOPT with default options (exact Hessian), one start. "
        "SLSQP: one start, the same scaled pose cost, bounds. Streaming: the "
        "target follows a random walk of 0.01 rad per joint and step, each solve warm-started "
        "from the previous answer.",
        "",
        "| arm | DOF | build [s] | NLP success | NLP median [ms] | NLP p99 [ms] | "
        "mean restarts | NLP without seed: success | median [ms] | plain success | "
        "plain median [ms] | SLSQP success | SLSQP median [ms] | streaming success | "
        "streaming median [ms] |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in rows:
        n, sn = int(r["n"]), int(r["stream_n"])  # type: ignore[call-overload]
        lines.append(
            f"| {r['arm']} ({r['source']}) | {r['dof']} | {r['build']:.3f} | "
            f"{100 * r['ok'] / n:.1f} % ({r['ok']}/{n}) | {1e3 * r['median']:.2f} | "  # type: ignore[operator]
            f"{1e3 * r['p99']:.1f} | {r['mean_restarts']:.2f} | "  # type: ignore[operator]
            f"{100 * r['noseed_ok'] / n:.1f} % | {1e3 * r['noseed_median']:.2f} | "  # type: ignore[operator]
            f"{100 * r['plain_ok'] / n:.1f} % | {1e3 * r['plain_median']:.2f} | "  # type: ignore[operator]
            f"{100 * r['slsqp_ok'] / n:.1f} % | {1e3 * r['slsqp_median']:.2f} | "  # type: ignore[operator]
            f"{100 * r['stream_ok'] / sn:.1f} % | {1e3 * r['stream_median']:.2f} |")  # type: ignore[operator]
    lines += [
        "",
        "Constrained problems: a position goal plus two random point constraints (plane, "
        "half-space, line, box, sphere, tool-axis cone) and a keep-out sphere near the arm, all "
        "met by one random configuration (so every problem is feasible); hard constraints, so "
        "`Method.AUTO` runs IPOPT; random start. The structures (which constraint types) vary, "
        "so some solves include building their problem. Naive: the same problems in plain "
        "CasADi + IPOPT, `min |p - p_t|^2` subject to the limits and the same constraint rows, "
        "default IPOPT options (exact Hessian), one solver per structure (its build timed with "
        "the solve that needs it), from the same start, then random restarts until success or "
        "the same 0.2 s budget. The two run interleaved (alternating which goes first); "
        "success for both = the goal by FK within its tolerance, every constraint's violation "
        "by FK within its tolerance, inside the limits. Time: wall time of the whole call "
        "(CPU: the process's CPU time, which a loaded machine inflates less); both solvers' "
        "budgets are wall time, so a heavily loaded machine costs both some success. Load: the "
        "1-minute load average at the end of the arm's run "
        f"({os.cpu_count()} CPUs).",
        "",
        "| arm | problems | armctl success | armctl median [ms] | armctl p90 [ms] | "
        "armctl CPU median [ms] | naive success | naive median [ms] | naive p90 [ms] | "
        "naive CPU median [ms] | naive mean attempts | load |",
        "|---|---|---|---|---|---|---|---|---|---|---|---|",
    ]
    for r in crows:
        lines.append(f"| {r['arm']} | {r['n']} | {100 * r['ok'] / r['n']:.1f} % | "  # type: ignore[operator]
                     f"{1e3 * r['median']:.1f} | {1e3 * r['p90']:.1f} | "  # type: ignore[operator]
                     f"{1e3 * r['cpu']:.1f} | "  # type: ignore[operator]
                     f"{100 * r['naive_ok'] / r['n']:.1f} % | "  # type: ignore[operator]
                     f"{1e3 * r['naive_median']:.1f} | {1e3 * r['naive_p90']:.1f} | "  # type: ignore[operator]
                     f"{1e3 * r['naive_cpu']:.1f} | "  # type: ignore[operator]
                     f"{r['naive_attempts']:.2f} | {r['load']:.1f} |")
    md = "\n".join(lines)
    print(md)
    if not args.no_write:
        sys.path.insert(0, str(Path(__file__).resolve().parent))
        from _benchdoc import write_section

        cmd = "python tools/bench_nlp.py" + "".join(f" {a}" for a in (argv or sys.argv[1:]))
        write_section("nlp", md, cmd)
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
