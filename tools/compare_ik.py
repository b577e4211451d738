"""Reproduce the comparison of IK methods of the lecture (L. Kavan, *Metody skeletální animace*,
2002) on every bundled arm; writes its section of docs/ik-methods.md (between its
``compare:arms`` markers; the rest of the page is written by hand and by
``tools/compare_ik_chains.py``).

For every bundled arm and goal type (position, orientation, direction, pose; the two-armed torso
gets one goal per hand at once) random reachable goals are drawn (FK of uniform random
configurations inside the limits, fixed seed) and every solver is run from the same two starts:
the middle of the joint ranges and a random configuration. The methods are compared as single
attempts (no restarts) with a generous iteration budget; ``auto`` runs as shipped (restarts on).
Singular goals (stretched arm, aligned wrist axes) are built per arm by optimisation. Plots go to
docs/img/ik-*.png.

Usage: python tools/compare_ik.py [--goals 1000] [--budget 1000] [--arms so101 ur5e ...]
"""

from __future__ import annotations

import argparse
import datetime
import sys
import time
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np
from scipy.optimize import minimize, minimize_scalar

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _benchdoc import replace_block

from armctl.arm import Arm, load_arm
from armctl.config import bundled_configs
from armctl.ik import (
    DirectionGoal,
    IKOptions,
    OrientationGoal,
    PoseGoal,
    PositionGoal,
    Tolerance,
)
from armctl.ik.numerical import _METHODS, _PARAMS, run_method
from armctl.ik.registry import get_solver
from armctl.render.plots import color, new_figure, save_figure, style_axes

ROOT = Path(__file__).resolve().parent.parent
DOC = ROOT / "docs" / "ik-methods.md"
IMG = ROOT / "docs" / "img"
SOLVERS = ("pinv", "dls", "jt", "ccd", "ccd-jt", "auto")
KINDS = ("position", "orientation", "direction", "pose")
TOL = Tolerance()  # 1e-5 m, 1e-4 rad
COLORS = {solver: color(i) for i, solver in enumerate(SOLVERS)}  # the armctl plot palette


@dataclass
class Runs:
    """Per-run outcomes of one solver on one set of goals."""

    ok: list[bool] = field(default_factory=list)
    iters: list[int] = field(default_factory=list)
    times: list[float] = field(default_factory=list)
    motion: list[np.ndarray] = field(default_factory=list)

    def add(self, ok: bool, iters: int, t: float, dq: np.ndarray) -> None:
        self.ok.append(ok)
        self.iters.append(iters)
        self.times.append(t)
        self.motion.append(np.abs(dq))

    @property
    def rate(self) -> float:
        return 100.0 * float(np.mean(self.ok)) if self.ok else float("nan")

    def summary(self) -> list[str]:
        ok = np.array(self.ok)
        it = np.array(self.iters)
        ts = np.array(self.times) * 1e3
        per = ts / np.maximum(it, 1) * 1e3
        med_it = f"{np.median(it[ok]):.0f}" if ok.any() else "-"
        per_text = f"{np.median(per):.1f}" if it.size and it.min() > 0 else "-"
        return [f"{self.rate:.1f} %", med_it, f"{np.median(ts):.3f}",
                f"{np.percentile(ts, 95):.3f}", per_text]


def goals_for(arm: Arm, kind: str, q: np.ndarray, frames: tuple[str | None, ...]) -> list:
    out = []
    for f in frames:
        t = arm.fk(q, f)
        if kind == "position":
            out.append(PositionGoal(t[:3, 3], frame=f, tolerance=TOL))
        elif kind == "orientation":
            out.append(OrientationGoal(t[:3, :3], frame=f, tolerance=TOL))
        elif kind == "direction":
            out.append(DirectionGoal(t[:3, 3], t[:3, 2], frame=f, tolerance=TOL))
        else:
            out.append(PoseGoal(t, frame=f, tolerance=TOL))
    return out


def solve(arm: Arm, solver: str, goals: list, q0: np.ndarray, budget: int, seed: int,
          trace: np.ndarray | None = None):
    """One attempt of a method with the whole budget (no early stop when progress is slow);
    ``auto`` as shipped."""
    if solver == "auto":
        return get_solver("auto")(arm, tuple(goals), q0, IKOptions(seed=seed), ())
    opts = IKOptions(max_iterations=budget, restarts=0, time_limit=5.0, seed=seed)
    params = replace(_PARAMS[_METHODS[solver]], window=budget + 1)
    return run_method(solver, arm, tuple(goals), q0, opts, (), trace=trace, params=params)


def iteration_cost(arm: Arm, solver: str, q_goals: np.ndarray,
                   frames: tuple[str | None, ...]) -> float:
    """Median wall time of one iteration [us] over 20 pose goals.

    Per goal: the time of a run of up to 300 iterations towards an unreachably tight pose goal
    minus that of a run of 1 iteration, per extra iteration, so that the fixed cost of a call and
    of the check of its answer cancel (a ``dls`` run ends early once round-off stops its
    progress).
    """
    tight = Tolerance(1e-300, 1e-300)
    params = replace(_PARAMS[_METHODS[solver]], window=10**6)
    out = []
    for i, q in enumerate(q_goals[:20]):
        goals = tuple(PoseGoal(arm.fk(q, f), frame=f, tolerance=tight) for f in frames)

        def timed(budget: int, goals: tuple[PoseGoal, ...] = goals,
                  seed: int = i) -> tuple[float, int]:
            opts = IKOptions(max_iterations=budget, restarts=0, time_limit=5.0, seed=seed)
            t0 = time.perf_counter()
            res = run_method(solver, arm, goals, arm.middle(), opts, (), params=params)
            return time.perf_counter() - t0, res.iterations

        t_long, n_long = timed(300)
        t_short, n_short = timed(1)
        if n_long > n_short:
            out.append((t_long - t_short) / (n_long - n_short))
    return float(np.median(out)) * 1e6 if out else float("nan")


# ---- singular goals ---------------------------------------------------------------------------
def stretched(arm: Arm, rng: np.random.Generator, n: int) -> np.ndarray:
    """Configurations that maximise the tool's distance from the first joint: stretched arms."""
    chain = list(arm.chain())
    origin = arm.fk(arm.middle(), arm.spec.joint(arm.joint_names[chain[0]]).child)[:3, 3]
    lo, hi = arm.lower[chain], arm.upper[chain]
    out = []
    for q in arm.sample(rng, n):
        def neg(x: np.ndarray, q: np.ndarray = q) -> float:
            qq = q.copy()
            qq[chain] = x
            return -float(np.linalg.norm(arm.fk(qq)[:3, 3] - origin))
        res = minimize(neg, q[chain], bounds=list(zip(lo, hi, strict=True)), method="L-BFGS-B")
        qq = q.copy()
        qq[chain] = res.x
        out.append(qq)
    return np.array(out)


def wrist_aligned(arm: Arm, rng: np.random.Generator, n: int) -> np.ndarray:
    """Configurations where the first and last of the last three tool-chain axes are parallel."""
    chain = list(arm.chain())
    if len(chain) < 3:
        return np.zeros((0, arm.dof))
    a, b, c = chain[-3:]
    ja, jc = (arm.spec.joint(arm.joint_names[k]) for k in (a, c))

    def axis(q: np.ndarray, joint) -> np.ndarray:
        return arm.fk(q, joint.child)[:3, :3] @ np.asarray(joint.axis)

    out = []
    for q in arm.sample(rng, n):
        def cross(x: float, q: np.ndarray = q) -> float:
            qq = q.copy()
            qq[b] = x
            return float(np.linalg.norm(np.cross(axis(qq, ja), axis(qq, jc))))
        res = minimize_scalar(cross, bounds=(arm.lower[b], arm.upper[b]), method="bounded",
                              options={"xatol": 1e-10})
        qq = q.copy()
        qq[b] = res.x
        if cross(res.x) < 1e-4:
            out.append(qq)
    return np.array(out).reshape(-1, arm.dof)


# ---- the study --------------------------------------------------------------------------------
def study(args: argparse.Namespace) -> str:
    arms = args.arms or list(bundled_configs())
    rng_master = np.random.default_rng(args.seed)
    tables: list[str] = []
    summary: dict[tuple[str, str, str, str], Runs] = {}
    traces: dict[str, dict[str, np.ndarray]] = {}
    singular_rows: list[list[str]] = []
    singular: dict[tuple[str, str], Runs] = {}
    costs: dict[tuple[str, str], float] = {}
    t_start = time.time()
    for name in arms:
        arm = load_arm(name)
        frames: tuple[str | None, ...] = (tuple(arm.end_effectors) if len(arm.end_effectors) > 1
                                          else (None,))
        rng = np.random.default_rng(rng_master.integers(1 << 31))
        q_goals = arm.sample(rng, args.goals)
        q_rand = arm.sample(rng, args.goals)
        mid = arm.middle()
        for i in range(args.goals):  # random starts move only the tool-chain joints
            keep = np.ones(arm.dof, dtype=bool)
            for f in frames:
                keep[list(arm.chain(f))] = False
            q_rand[i, keep] = mid[keep]
        for kind in KINDS:
            for solver in SOLVERS:
                for start in ("mid", "random"):
                    runs = Runs()
                    for i in range(args.goals):
                        q0 = mid if start == "mid" else q_rand[i]
                        res = solve(arm, solver, goals_for(arm, kind, q_goals[i], frames), q0,
                                    args.budget, i)
                        runs.add(res.success, res.iterations, res.time, res.q - q0)
                    summary[(name, kind, solver, start)] = runs
            print(f"{name} {kind} done ({time.time() - t_start:.0f} s)", flush=True)
        for solver in SOLVERS[:-1]:
            costs[(name, solver)] = iteration_cost(arm, solver, q_goals, frames)
        # error-versus-iteration traces: pose goals from the middle
        traces[name] = {}
        n_tr = min(args.goals, 50)
        for solver in SOLVERS[:-1]:
            tr = np.full((n_tr, args.trace, 2), np.nan)
            for i in range(n_tr):
                buf = np.empty((args.trace, 2))
                solve(arm, solver, goals_for(arm, "pose", q_goals[i], frames), mid, args.trace,
                      i, buf)
                tr[i] = buf
            traces[name][solver] = tr
        # singular goals
        srng = np.random.default_rng(7)
        n_sing = max(10, args.goals // 10)
        for label, qs in (("stretched", stretched(arm, srng, n_sing)),
                          ("wrist aligned", wrist_aligned(arm, srng, n_sing))):
            if len(qs) == 0:
                continue
            for solver in SOLVERS:
                runs = Runs()
                for i, q in enumerate(qs):
                    res = solve(arm, solver, goals_for(arm, "pose", q, frames), mid,
                                args.budget, i)
                    runs.add(res.success, res.iterations, res.time, res.q - mid)
                singular[(name, label)] = runs
                singular_rows.append([name, label, str(len(qs)), solver, *runs.summary()[:3]])
                summary[(name, "singular:" + label, solver, "mid")] = runs
    # tables
    header = ["arm", "goal", "solver", "start", "success", "median iterations", "median [ms]",
              "p95 [ms]", "per iteration [us]"]
    lines = ["| " + " | ".join(header) + " |", "|" + "---|" * len(header)]
    for (name, kind, solver, start), runs in summary.items():
        if kind.startswith("singular:"):
            continue
        lines.append("| " + " | ".join([name, kind, solver, start, *runs.summary()]) + " |")
    tables.append("\n".join(lines))
    sh = ["arm", "singular goal", "goals", "solver", "success", "median iterations",
          "median [ms]"]
    tables.append("\n".join(["| " + " | ".join(sh) + " |", "|" + "---|" * len(sh)]
                            + ["| " + " | ".join(r) + " |" for r in singular_rows]))
    ch = ["arm", *SOLVERS[:-1]]
    tables.append("\n".join(["| " + " | ".join(ch) + " |", "|" + "---|" * len(ch)] + [
        "| " + " | ".join([name] + [f"{costs[(name, s)]:.1f}" for s in SOLVERS[:-1]]) + " |"
        for name in arms]))
    plots(arms, summary, traces, args)
    return report(arms, summary, tables, costs, args, time.time() - t_start)


def motion_share(runs: Runs, chain: list[int]) -> np.ndarray:
    m = np.array([d[chain] for d in runs.motion])
    tot = m.sum(axis=1, keepdims=True)
    return (m / np.where(tot > 0, tot, 1))[tot[:, 0] > 1e-9]


def evenness(share: np.ndarray) -> float:
    """Normalised entropy of one solve's motion shares: 1 = spread evenly over the joints."""
    p = share[share > 0]
    n = share.shape[0]
    return float(-(p * np.log(p)).sum() / np.log(n)) if n > 1 else 1.0


def _grid(n: int) -> tuple[object, list]:
    """A figure with one axes per arm (three per row), in the armctl plot style."""
    cols = min(3, n)
    rows = (n + cols - 1) // cols
    fig, axes = new_figure(rows, cols, size=(5.0 * cols, 3.6 * rows), dpi=90)
    for ax in axes[n:]:
        ax.axis("off")
    return fig, axes


def plots(arms: list[str], summary: dict, traces: dict, args: argparse.Namespace) -> None:
    IMG.mkdir(parents=True, exist_ok=True)
    # error vs iteration
    fig, axes = _grid(len(arms))
    for ax, name in zip(axes, arms, strict=False):
        for solver, tr in traces[name].items():
            err = tr[:, :, 0] + tr[:, :, 1] * 0.1  # position [m] + 0.1 m x rotation [rad]
            for row in err:  # a finished run keeps its last error
                for k in range(1, len(row)):
                    if np.isnan(row[k]):
                        row[k] = row[k - 1]
            med = np.nanmedian(err, axis=0)
            ax.plot(np.arange(len(med)), np.maximum(med, 1e-12), label=solver,
                    color=COLORS[solver])
        style_axes(ax, f"{name}: pose goals from mid-range", "iteration",
                   "median error [m + 0.1 m/rad]", log_y=True, legend=ax is axes[0])
    save_figure(fig, IMG / "ik-error-vs-iteration.png")
    # success vs iteration budget
    fig, axes = _grid(len(arms))
    budgets = np.unique(np.logspace(0, np.log10(args.budget), 60).astype(int))
    for ax, name in zip(axes, arms, strict=False):
        for solver in SOLVERS[:-1]:
            runs = summary[(name, "pose", solver, "mid")]
            ok = np.array(runs.ok)
            it = np.array(runs.iters)
            ax.plot(budgets, [100 * np.mean(ok & (it <= b)) for b in budgets], label=solver,
                    color=COLORS[solver])
        ax.set_xscale("log")
        ax.set_ylim(0, 101)
        style_axes(ax, f"{name}: pose goals, one attempt", "iteration budget", "success [%]",
                   legend=ax is axes[0])
    save_figure(fig, IMG / "ik-success-vs-budget.png")
    # joint-motion distribution
    fig, axes = _grid(len(arms))
    for ax, name in zip(axes, arms, strict=False):
        arm = load_arm(name)
        chain = list(arm.chain())
        width = 0.8 / 5
        for k, solver in enumerate(SOLVERS[:-1]):
            share = motion_share(summary[(name, "position", solver, "mid")], chain)
            if len(share):
                ax.bar(np.arange(len(chain)) + k * width, share.mean(axis=0), width,
                       label=solver, color=COLORS[solver])
        ax.set_xticks(np.arange(len(chain)) + 0.4)
        ax.set_xticklabels([str(j + 1) for j in range(len(chain))])
        style_axes(ax, f"{name}: share of joint motion, position goals",
                   "joint (base to tool)", "mean |dq_j| / sum |dq|", legend=ax is axes[0])
    save_figure(fig, IMG / "ik-joint-motion.png")


def _agg(summary: dict, solver: str, pred) -> Runs:
    out = Runs()
    for (name, kind, s, start), runs in summary.items():
        if s == solver and pred(name, kind, start):
            out.ok += runs.ok
            out.iters += runs.iters
            out.times += runs.times
    return out


def report(arms: list[str], summary: dict, tables: list[str], costs: dict,
           args: argparse.Namespace, elapsed: float) -> str:
    normal = lambda n, k, s: not k.startswith("singular")  # noqa: E731
    sing = lambda n, k, s: k.startswith("singular")  # noqa: E731
    agg = {s: _agg(summary, s, normal) for s in SOLVERS}
    agg_sing = {s: _agg(summary, s, sing) for s in SOLVERS}

    def paired_iters(a: Runs, b: Runs) -> tuple[float, float, int]:
        both = np.array(a.ok) & np.array(b.ok)
        if not both.any():
            return float("nan"), float("nan"), 0
        return (float(np.median(np.array(a.iters)[both])),
                float(np.median(np.array(b.iters)[both])), int(both.sum()))

    def cost(s: str) -> float:
        return float(np.median([costs[(name, s)] for name in arms]))

    even: dict[str, float] = {}
    distal: dict[str, float] = {}
    for s in SOLVERS[:-1]:
        per_solve: list[float] = []
        tip: list[float] = []
        for name in arms:
            arm = load_arm(name)
            share = motion_share(summary[(name, "position", s, "mid")], list(arm.chain()))
            per_solve += [evenness(row) for row in share]
            tip += list(share[:, -2:].sum(axis=1)) if len(share) else []
        even[s] = float(np.median(per_solve)) if per_solve else float("nan")
        distal[s] = float(np.median(tip)) if tip else float("nan")
    claims = []

    def verdict(ok: bool) -> str:
        return "**confirmed**" if ok else "**not confirmed**"

    c, j = agg["ccd"], agg["jt"]
    ic, ij, nb = paired_iters(c, j)
    claims.append(
        f"- *CCD converges faster than J^T in practice*: {verdict(c.rate > j.rate and ic < ij)}. "
        f"With the same budget CCD reached {c.rate:.1f} % of the goals, J^T {j.rate:.1f} %; on "
        f"the {nb} goals both reached, CCD needed a median {ic:.0f} iterations (sweeps), J^T "
        f"{ij:.0f}.")
    p = agg["pinv"]
    ip, ic2, nb2 = paired_iters(p, c)
    claims.append(
        f"- *The pseudoinverse converges in fewer steps than CCD*: {verdict(ip < ic2)} (median "
        f"{ip:.0f} vs {ic2:.0f} iterations on the {nb2} goals both reached; pinv also reached "
        f"{p.rate:.1f} % against {c.rate:.1f} %). *Each pseudoinverse step costs more*: "
        f"{verdict(cost('pinv') > cost('ccd'))} (median over the arms {cost('pinv'):.1f} us per "
        f"pinv iteration, {cost('ccd'):.1f} us per CCD sweep, {cost('jt'):.1f} us per J^T step,"
        f" {cost('dls'):.1f} us per dls iteration). "
        + (f"The SVD of a 6 x n matrix is small: a pseudoinverse step costs "
           f"{cost('pinv') / cost('ccd'):.1f} times a CCD sweep, which updates n joints one after "
           "the other." if cost("pinv") > cost("ccd") else
           "A CCD sweep, which updates n joints one after the other, costs more here than the "
           "SVD of a 6 x n matrix."))
    top = max(even, key=lambda s: even[s])
    claims.append(
        f"- *J^T spreads motion over all joints*: {verdict(even['jt'] > even['ccd'])} against "
        f"CCD (per solve, the normalised entropy of the shares of |dq_j|, 1 = even; median over "
        f"the solves: J^T {even['jt']:.2f}, CCD {even['ccd']:.2f}, pinv {even['pinv']:.2f}, dls "
        f"{even['dls']:.2f}, ccd-jt {even['ccd-jt']:.2f}; the most even here is {top}; share "
        f"of the two joints nearest the tool: J^T {distal['jt']:.2f}, CCD {distal['ccd']:.2f}). "
        "Arms of 4-7 joints leave little room to spread: see the chains of up to 40 joints "
        "above.")
    cs, ps = agg_sing["ccd"], agg_sing["pinv"]
    sing_arms = {n for (n, k, _s, _t) in summary if k.startswith("singular:")}
    base = {s: _agg(summary, s, lambda n, k, t: n in sing_arms and k == "pose" and t == "mid")
            for s in SOLVERS}  # like for like: ordinary pose goals, from the middle
    drop_c, drop_p = base["ccd"].rate - cs.rate, base["pinv"].rate - ps.rate
    by_label = {label: _agg(summary, "ccd", lambda n, k, s, lb=label: k == "singular:" + lb)
                for label in ("stretched", "wrist aligned")}
    where = ("" if by_label["stretched"].rate >= by_label["wrist aligned"].rate else
             " It loses most on the stretched goals, which lie on the boundary of the workspace"
             f" (CCD {by_label['stretched'].rate:.1f} % stretched, "
             f"{by_label['wrist aligned'].rate:.1f} % wrist aligned).")
    claims.append(
        f"- *CCD has no trouble with singularities*: {verdict(drop_c <= max(drop_p, 5.0))}. "
        f"On the singular pose goals CCD reached {cs.rate:.1f} % (ordinary pose goals of the "
        f"same arms, from the same start: {base['ccd'].rate:.1f} %), pinv {ps.rate:.1f} % "
        f"({base['pinv'].rate:.1f} %), dls {agg_sing['dls'].rate:.1f} % "
        f"({base['dls'].rate:.1f} %), J^T {agg_sing['jt'].rate:.1f} % "
        f"({base['jt'].rate:.1f} %). "
        + ("CCD loses less there than the pseudoinverse." if drop_c <= drop_p else
           "CCD loses more there than the pseudoinverse." + where))
    starts = {st: {s: _agg(summary, s, lambda n, k, t, st=st: normal(n, k, t) and t == st)
                   for s in SOLVERS[:-1]} for st in ("mid", "random")}
    newton, heuristic = ("pinv", "dls"), ("jt", "ccd", "ccd-jt")

    def start_loss(group: tuple[str, ...]) -> float:
        """Mean loss of success [points] from a random start instead of the middle."""
        return float(np.mean([starts["mid"][s].rate - starts["random"][s].rate for s in group]))

    loss_n, loss_h = start_loss(newton), start_loss(heuristic)
    claims.append(
        "- Not a claim of the lecture, but measured here: from a random start instead of the "
        "middle of the ranges, one attempt of " + ", ".join(
            f"{s} reached {starts['random'][s].rate:.1f} % (mid {starts['mid'][s].rate:.1f} %)"
            for s in SOLVERS[:-1])
        + f". The heuristics depend {'less' if loss_h < loss_n else 'no less'} on the start than "
        f"the Newton-type methods (they lose {loss_h:.1f} points on average, pinv and dls "
        f"{loss_n:.1f}); random restarts (as in `auto`) make up for that.")
    cj = agg["ccd-jt"]
    claims.append(
        f"- *CCD and J^T complement each other*: {verdict(cj.rate > max(c.rate, j.rate))} "
        f"(ccd-jt {cj.rate:.1f} %, CCD {c.rate:.1f} %, J^T {j.rate:.1f} %).")
    worst_newton = min(agg[s].rate for s in newton)
    best_heuristic = max(agg[s].rate for s in heuristic)
    margin = worst_newton - best_heuristic
    than = ("far more goals than" if margin >= 5.0 else "more goals than" if margin > 0 else
            "no more goals than the best of")
    damping = ("also helps" if agg_sing["dls"].rate > ps.rate else "does not help")
    claims.append(
        f"- *The pseudoinverse is the best founded*: the Newton-type methods (pinv "
        f"{p.rate:.1f} %, dls {agg['dls'].rate:.1f} % in one attempt) reach {than} the "
        f"heuristics (best: {max(heuristic, key=lambda s: agg[s].rate)} {best_heuristic:.1f} %); "
        f"damping (dls) {damping} near singular configurations (singular goals: dls "
        f"{agg_sing['dls'].rate:.1f} %, pinv {ps.rate:.1f} %). With restarts, "
        f"`auto` reached {agg['auto'].rate:.1f} % of the ordinary and "
        f"{agg_sing['auto'].rate:.1f} % of the singular goals.")
    today = datetime.date.today().isoformat()
    cmd = "python tools/compare_ik.py " + " ".join(sys.argv[1:])
    return TEMPLATE.format(
        goals=args.goals, budget=args.budget, arms=", ".join(arms), tol_p=TOL.position,
        tol_r=TOL.rotation, claims="\n".join(claims), table=tables[0],
        singular=tables[1], costs=tables[2],
        fewer=" (fewer than the default 1000, for time)" if args.goals < 1000 else "",
        cmd=cmd.strip(), date=today, minutes=elapsed / 60, seed=args.seed)


TEMPLATE = """<!-- compare:arms -->
## The methods on the bundled robot arms

The lecture's claims (in italics) on the robot arms armctl ships (4-7 joints); each verdict is
computed from the measurements of this section. The same claims on chains of 4 to 40 joints:
[above](#the-methods-on-chains-of-4-to-40-joints).

{claims}

### Protocol

- Arms: {arms} (the bundled configs); the two-armed torso gets one goal per hand at once.
- Goals: {goals} per arm and goal type{fewer}, FK of uniform random configurations inside the
  limits (seed {seed}), so every goal is reachable. Direction goals use the tool's z axis.
- Tolerance {tol_p} m / {tol_r} rad (the default). Each method makes one attempt (no restarts)
  with a budget of {budget} iterations, from the middle of the joint ranges (`mid`) and from a
  random configuration (`random`, the same for every method); `auto` runs as shipped (restarts
  on, default budgets) to show what a user gets.
- Singular goals: "stretched" = configurations that maximise the tool's distance from the first
  joint (found by L-BFGS-B from random starts), "wrist aligned" = the first and last of the last
  three tool-chain axes made parallel by moving the middle one (|w_a x w_c| < 1e-4). Pose goals,
  from the middle.
- "per iteration" is the median of solve time / iterations (Python overhead included; "-" where
  some solves took no iteration, e.g. closed-form answers of `auto`); a CCD iteration is a full
  sweep. The cost of one iteration alone is in the last table.

### Plots

![error vs iteration](img/ik-error-vs-iteration.png)

Median error over 50 pose goals from the middle of the ranges, per iteration of one attempt (a
run that has converged keeps its last error).

![success vs iteration budget](img/ik-success-vs-budget.png)

Share of pose goals reached within a given number of iterations (one attempt).

![joint motion](img/ik-joint-motion.png)

How each method spreads the motion over the joints (position goals from the middle): mean share
of `|dq_j|` in the total.

### Results

{table}

#### Singular goals

{singular}

#### Cost of one iteration [us]

Median over 20 pose goals of the time of a run of up to 300 iterations minus that of a
1-iteration run, per extra iteration (the fixed cost of a call cancels; a CCD iteration is a
sweep over all joints).

{costs}

Produced by `{cmd}` on {date} ({minutes:.0f} min). Speed against other libraries: see the `ik`
section of docs/benchmarks.md (tools/bench_ik.py).
<!-- /compare:arms -->"""


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(description=" ".join(__doc__.split("\n\n")[0].split()))
    ap.add_argument("--goals", type=int, default=1000, help="goals per arm and goal type")
    ap.add_argument("--budget", type=int, default=1000, help="iterations of one attempt")
    ap.add_argument("--trace", type=int, default=200, help="iterations in the error plot")
    ap.add_argument("--arms", nargs="*", help="bundled arm names (default: all)")
    ap.add_argument("--seed", type=int, default=2026)
    args = ap.parse_args(argv)
    text = study(args)
    replace_block(DOC, "compare:arms", text.rstrip())
    print(f"wrote {DOC}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
