"""Batched IK against single calls and against a Python loop over roboticstoolbox; writes the
``ik-batch`` section of docs/benchmarks.md.

Protocol: per robot (the reference robots of tools/bench_ik_call.py by default), N random
reachable full-pose goals (FK of uniform random configurations inside the limits, seed 2026)
and N random starts inside the limits (seed 2027), tolerance 1e-6 m / 1e-6 rad. After an untimed
warm-up on part of the goals, each pass runs, the order alternating per pass:

* ``solve_batch(arm, poses, starts, tolerance=tol, workers=1)`` (the default solver,
  ``auto``), one call, one thread;
* a Python loop over roboticstoolbox ``ETS.ik_LM`` (C++, tol 1e-13, joint limits on, the same
  chain and call as tools/bench_ik_call.py) on the same goals and starts;
* ``solve_batch`` again with its default workers (one thread per CPU), wall time only (its
  answers must equal the one-thread batch's).

Batch and calls run with ``IKOptions(time_limit=10.0)``, far above any solve's time, so that a
loaded machine cannot cut a search short in one run and not in another. Both are timed by the
wall clock and by the process's CPU time (the machine is shared: CPU
time is what a loaded machine distorts least); throughput = goals per second. Success = armctl's
FK of the answer within 1e-6 m and 1e-6 rad and inside the limits, for both. Once per robot the
goals are also solved by single calls, ``arm.ik(PoseGoal(T, tolerance=tol), q0)``, and compared
goal by goal with the batch: a goal a call solves and the batch misses is counted.

Usage: python tools/bench_ik_batch.py [--goals 10000] [--passes 5] [--arms ...] [--no-write]
"""

from __future__ import annotations

import argparse
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

TOL = 1e-6


def _clock() -> tuple[float, float]:
    return time.perf_counter(), time.process_time()


def _measure(name: str, args: argparse.Namespace) -> dict[str, Any]:
    from bench_ik import rtb_solver
    from bench_ik_call import load_robot

    from armctl.ik import IKOptions, PoseGoal, Tolerance, evaluate, solve_batch

    arm = load_robot(name)
    n = args.goals
    q_goal = arm.sample(np.random.default_rng(args.seed), n)
    poses = arm.fk_batch(q_goal)
    starts = arm.sample(np.random.default_rng(args.seed + 1), n)
    tol = Tolerance(TOL, TOL)
    # a time limit far above any solve's time: on a loaded machine the default (0.2 s) can cut
    # a long search short in one run and not in another, and the comparisons need the same
    # answers; roboticstoolbox has none (its budget is 100 searches of 30 iterations)
    opts = IKOptions(time_limit=10.0)
    rtb = rtb_solver(arm)

    def ok(q: np.ndarray, pose: np.ndarray) -> bool:
        return bool(arm.within_limits(q)
                    and evaluate(arm, (PoseGoal(pose, tolerance=tol),), q)[0].reached)

    # a pass of each on part of the goals first, untimed: compiled kernels (the closed form's
    # too) loaded, caches warm
    warm = min(n, 1000)
    solve_batch(arm, poses[:warm], starts[:warm], tolerance=tol, options=opts)
    for i in range(warm // 5):
        rtb(poses[i], starts[i], 1e-13)
    out: dict[str, Any] = {"batch": [], "threads": [], "rtb": [], "n": n}
    batch_res = None
    rtb_ok = 0
    for p in range(args.passes):
        for who in (("batch", "threads", "rtb") if p % 2 == 0 else ("rtb", "threads", "batch")):
            w0, c0 = _clock()
            if who == "batch":
                batch_res = solve_batch(arm, poses, starts, tolerance=tol, workers=1,
                                        options=opts)
            elif who == "threads":
                threaded = solve_batch(arm, poses, starts, tolerance=tol, options=opts)
            else:
                answers = [rtb(poses[i], starts[i], 1e-13)[0] for i in range(n)]
            w1, c1 = _clock()
            out[who].append((w1 - w0, c1 - c0))
            if who == "rtb" and p == 0:
                rtb_ok = sum(ok(np.asarray(a, dtype=float), poses[i])
                             for i, a in enumerate(answers))
    assert batch_res is not None
    out["threads_same"] = bool(np.array_equal(threaded.q, batch_res.q))
    batch_ok = np.array([ok(batch_res.q[i], poses[i]) for i in range(n)])
    out["batch_ok"] = int(batch_ok.sum())
    out["batch_false"] = int((batch_res.success & ~batch_ok).sum())
    out["rtb_ok"] = int(rtb_ok)
    w0, c0 = _clock()
    calls = [arm.ik(PoseGoal(poses[i], tolerance=tol), starts[i], options=opts)
             for i in range(n)]
    w1, c1 = _clock()
    out["calls"] = (w1 - w0, c1 - c0)
    call_ok = np.array([c.success for c in calls])
    out["calls_ok"] = int(call_ok.sum())
    out["missed"] = int((call_ok & ~batch_res.success).sum())
    out["extra"] = int((~call_ok & batch_res.success).sum())
    out["same_q"] = int(sum(np.allclose(batch_res.q[i], calls[i].q, rtol=0.0, atol=1e-12)
                            for i in range(n)))
    return out


def _threads() -> int:
    """The threads ``solve_batch`` uses by default for a large batch."""
    return os.cpu_count() or 1


def main(argv: list[str] | None = None) -> int:
    from bench_ik_call import REFERENCE, robot_label

    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("--goals", type=int, default=10000)
    ap.add_argument("--passes", type=int, default=5)
    ap.add_argument("--arms", nargs="+", default=list(REFERENCE))
    ap.add_argument("--seed", type=int, default=2026)
    ap.add_argument("--no-write", action="store_true", help="print only")
    args = ap.parse_args(argv)
    load = [os.getloadavg()[0]]
    head = ["robot", "goals", "batch success", "calls success", "call solved, batch missed",
            "same answer as the call", "rtb success", "batch, 1 thread [goals/s] wall / CPU",
            "rtb loop [goals/s] wall / CPU", "batch / rtb, 1 thread, CPU (per-pass range)",
            "batch / rtb, 1 thread, wall", f"batch, {_threads()} threads [goals/s] wall",
            f"batch / rtb, {_threads()} threads, wall"]
    rows = []
    for name in args.arms:
        r = _measure(name, args)
        n = r["n"]
        tw = np.array([w for w, _ in r["threads"]])
        ratio_t = np.array([w for w, _ in r["rtb"]]) / tw
        bw = np.array([w for w, _ in r["batch"]])
        bc = np.array([c for _, c in r["batch"]])
        rw = np.array([w for w, _ in r["rtb"]])
        rc = np.array([c for _, c in r["rtb"]])
        ratio_c = rc / bc
        ratio_w = rw / bw
        print(name, "per pass: batch CPU", np.round(bc, 3).tolist(), "rtb CPU",
              np.round(rc, 3).tolist(), flush=True)
        rows.append([
            robot_label(name), str(n),
            f"{100 * r['batch_ok'] / n:.2f} % ({r['batch_false']} false)",
            f"{100 * r['calls_ok'] / n:.2f} %", str(r["missed"]), f"{r['same_q']} / {n}",
            f"{100 * r['rtb_ok'] / n:.2f} %",
            f"{n / np.median(bw):,.0f} / {n / np.median(bc):,.0f}",
            f"{n / np.median(rw):,.0f} / {n / np.median(rc):,.0f}",
            f"{np.median(rc) / np.median(bc):.2f} ({ratio_c.min():.2f}-{ratio_c.max():.2f})",
            f"{np.median(rw) / np.median(bw):.2f} ({ratio_w.min():.2f}-{ratio_w.max():.2f})",
            f"{n / np.median(tw):,.0f}" + ("" if r["threads_same"] else " (answers differ!)"),
            f"{np.median(rw) / np.median(tw):.2f} ({ratio_t.min():.2f}-{ratio_t.max():.2f})"])
        print(" | ".join(rows[-1]), flush=True)
    load.append(os.getloadavg()[0])
    md = ["## Batched IK against calls and a loop over roboticstoolbox "
          "(tools/bench_ik_batch.py)", "",
          f"{args.goals} random reachable full-pose goals per robot (FK of uniform random "
          f"configurations inside the limits, seed {args.seed}) from random starts inside the "
          f"limits (seed {args.seed + 1}), 1e-6 m / 1e-6 rad, one thread. After an untimed "
          f"warm-up on part of the goals, each of {args.passes} passes runs "
          "`solve_batch(arm, poses, starts, tolerance=tol, workers=1, options=opts)` (the "
          "default solver "
          "`auto`, one thread), the same with the default workers (one thread per CPU, "
          f"{_threads()} here) and a Python loop over roboticstoolbox `ETS.ik_LM` (C++, "
          "tol=1e-13, joint limits on) on the same goals and starts, the order alternating per "
          "pass; throughput = goals per second of wall time and of the process's CPU time (the "
          "machine is shared: CPU time is what the load distorts least; the threaded batch is "
          "given by wall time only). Success = armctl's FK "
          "of the answer within the tolerance and inside the limits (a false success: reported "
          "solved, failing this check). The same goals are also solved one call at a time "
          "(`arm.ik(PoseGoal(T, tolerance=tol), q0, options=opts)`) and compared goal by goal; "
          "`opts = IKOptions(time_limit=10.0)`, a limit far above any solve's time (on a loaded "
          "machine the default 0.2 s can cut a long search short in one run and not in another; "
          "roboticstoolbox's budget is 100 searches of 30 iterations): 'call solved, "
          "batch missed' counts goals a call solves and the batch does not; 'same answer' "
          "counts batch answers equal to the call's (1e-12). Targets: no goal missed; at least "
          "2x the throughput of the loop over roboticstoolbox.", "",
          "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    md += ["| " + " | ".join(r) + " |" for r in rows]
    md += ["", f"1-minute load average: {load[0]:.1f} at the start, {load[1]:.1f} at the end, "
           "on 2 CPUs."]
    text = "\n".join(md)
    print(text)
    if not args.no_write:
        from _benchdoc import write_section

        cmd = "python tools/bench_ik_batch.py " + " ".join(
            argv if argv is not None else sys.argv[1:])
        print(f"wrote {write_section('ik-batch', text, cmd.strip())}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
