"""Motion benchmark: planning time per move, and loop rate, jitter and tracking error on the
simulated bus. Writes the ``motion`` section of docs/benchmarks.md.

Usage: python tools/bench_motion.py [--moves N] [--no-write]
"""

from __future__ import annotations

import argparse
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))

from _benchdoc import write_section

from armctl.arm import load_arm
from armctl.config.motion import ExitPolicy
from armctl.ik import PositionGoal
from armctl.motion import (
    Interpolation,
    Keyframe,
    KeyframeProgram,
    MotionLimits,
    PlaybackOptions,
    plan_joint_move,
    plan_program,
    ruckig_move,
)
from armctl.motion.cartesian import plan_line
from armctl.robot import Robot


def _stats(xs: list[float]) -> tuple[float, float, float]:
    a = np.array(xs)
    return float(np.median(a)), float(np.percentile(a, 99)), float(a.max())


def bench_planning(n: int) -> list[list[str]]:
    arm = load_arm("so101")
    lim = MotionLimits.from_model(arm)
    rng = np.random.default_rng(0)
    rows = []
    qs = arm.sample(rng, 2 * n)
    t_ruckig, t_move = [], []
    for k in range(n):
        t0 = time.perf_counter()
        ruckig_move(qs[2 * k], qs[2 * k + 1], lim)
        t_ruckig.append(time.perf_counter() - t0)
        t0 = time.perf_counter()
        plan_joint_move(qs[2 * k], qs[2 * k + 1], lim)
        t_move.append(time.perf_counter() - t0)
    rows.append(["Ruckig profile only (6 joints)", *_ms(t_ruckig), "-"])
    rows.append(["joint move, profile + check of every 2 ms sample", *_ms(t_move), "-"])
    names = arm.joint_names[:5]
    programs = []
    for _ in range(max(5, n // 20)):
        kfs = tuple(Keyframe(q=tuple(rng.uniform(arm.lower[:5] * 0.8, arm.upper[:5] * 0.8)))
                    for _ in range(10))
        programs.append(KeyframeProgram(arm.name, names, kfs))
    for interp in Interpolation:
        for blend in (True, False):
            times, durations = [], []
            opts = PlaybackOptions(interp, blend=blend, ease_in=False)
            for prog in programs:
                start = np.zeros(arm.dof)
                start[:5] = prog.keyframes[0].q
                t0 = time.perf_counter()
                plan = plan_program(prog, arm, lim, start, opts)
                times.append(time.perf_counter() - t0)
                durations.append(plan.duration)
            how = "blended" if blend else "stop at each"
            rows.append([f"10 keyframes, {interp.value}, {how}, checked", *_ms(times),
                         f"{np.mean(durations):.2f}"])
    times = []
    q0 = np.array([0.0, -0.8, 0.8, 0.6, 0.0, 0.0])
    p0 = arm.fk(q0)[:3, 3]
    plan_line(arm, q0, PositionGoal(p0 + 0.01), lim)  # warm-up: compiles the IK kernels
    for _ in range(max(5, n // 50)):
        goal = PositionGoal(p0 + rng.uniform(-0.04, 0.04, 3))
        t0 = time.perf_counter()
        plan_line(arm, q0, goal, lim)
        times.append(time.perf_counter() - t0)
    rows.append(["straight line (IK every 5 mm), checked", *_ms(times), "-"])
    return rows


def _ms(xs: list[float]) -> list[str]:
    med, p99, mx = _stats(xs)
    return [f"{med * 1000:.3f}", f"{p99 * 1000:.3f}", f"{mx * 1000:.3f}", str(len(xs))]


def bench_streaming(moves: int) -> list[list[str]]:
    arm = load_arm("so101")
    rows = []
    rng = np.random.default_rng(1)
    targets = [arm.middle() + 0.5 * (arm.sample(rng) - arm.middle()) for _ in range(moves)]
    for rate in (50.0, 100.0):
        with Robot.open(arm, exit_policy=ExitPolicy.HOLD) as robot:  # the config's speed
            robot.executor.rate_hz = rate
            cycles, elapsed, jit, io, track, rms, overruns = 0, 0.0, [], [], [], [], 0
            for q in targets:
                plan = robot.plan_joints(q)
                res = robot.execute(plan, record=True)
                s = res.stats
                cycles += s.cycles - 1  # intervals between cycle starts
                elapsed += s.elapsed
                jit.append(s.jitter_p99)
                io.append(s.io_time_mean)
                overruns += s.overruns
                track.append(float(np.max(s.max_tracking_error)))
                rms.append(float(np.sqrt(np.mean((res.log_meas[1:] - res.log_cmd[:-1]) ** 2))))
            rows.append([f"{rate:g}", f"{cycles / elapsed:.1f}", f"{np.median(jit) * 1000:.2f}",
                         f"{max(jit) * 1000:.2f}", str(overruns), f"{np.mean(io) * 1000:.2f}",
                         f"{np.degrees(np.max(track)):.2f}", f"{np.degrees(np.mean(rms)):.3f}"])
    return rows


def _table(headers: list[str], rows: list[list[str]]) -> str:
    out = ["| " + " | ".join(headers) + " |", "|" + "---|" * len(headers)]
    out += ["| " + " | ".join(r) + " |" for r in rows]
    return "\n".join(out)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--moves", type=int, default=8, help="moves streamed per loop rate")
    parser.add_argument("--plans", type=int, default=500, help="joint moves planned")
    parser.add_argument("--no-write", action="store_true", help="print only")
    args = parser.parse_args()
    plan_rows = bench_planning(args.plans)
    stream_rows = bench_streaming(args.moves)
    md = (
        "## Motion: planning and streaming\n\n"
        "Planning time per move on the bundled SO-101 (5 joints + gripper, limits from its "
        "YAML); every plan is checked sample by sample against the position, velocity and "
        "acceleration limits before it is returned. The keyframe rows plan the same random "
        "programs with each interpolation; their motion times compare the interpolations.\n\n"
        + _table(["plan", "median [ms]", "p99 [ms]", "max [ms]", "runs",
                  "mean motion time [s]"], plan_rows)
        + "\n\nStreaming random joint moves (the config's speed factor 0.5) to the simulated "
        "SO-101 bus (the real Feetech SDK on a pty, one sync write + one sync read of 6 servos "
        "per cycle). Jitter is how late a cycle starts after its deadline; tracking error is "
        "|measured - command of the previous cycle| (the simulated servos' own lag).\n\n"
        + _table(["target [Hz]", "achieved [Hz]", "jitter p99, median over moves [ms]",
                  "jitter p99, worst move [ms]", "missed deadlines", "write+read [ms]",
                  "max tracking error [deg]", "RMS tracking error [deg]"], stream_rows)
    )
    print(md)
    if not args.no_write:
        cmd = "python tools/bench_motion.py" + (f" --moves {args.moves}" if args.moves != 8
                                                else "")
        print(f"written to {write_section('motion', md, cmd)}")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
