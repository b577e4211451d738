"""Benchmark: single-call FK and Jacobian, and batched FK, against pinocchio in the same run.

Usage: python tools/bench_kinematics.py [--calls N] [--batch N]
Writes the "kinematics" section of docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import sys
import time
from collections.abc import Callable
from pathlib import Path

import numpy as np
import pinocchio as pin

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _benchdoc import write_section

import armctl

ROOT = Path(__file__).resolve().parent.parent
ARMS = (("ur5e", 6), ("panda", 7))


def per_call_us(fn: Callable[[], object], calls: int, repeats: int = 5) -> float:
    """Best of ``repeats`` mean times per call [us] (the least disturbed run)."""
    best = float("inf")
    for _ in range(repeats):
        t = time.perf_counter()
        for _ in range(calls):
            fn()
        best = min(best, (time.perf_counter() - t) / calls * 1e6)
    return best


def bench_arm(name: str, calls: int, batch: int) -> dict[str, float]:
    arm = armctl.load_arm(ROOT / "configs" / f"{name}.yaml")
    urdf = ROOT / "tests" / "data" / "urdf" / f"{name}.urdf"
    model = pin.buildModelFromUrdf(str(urdf))
    data = model.createData()
    fid = model.getFrameId(arm.tool)
    rng = np.random.default_rng(0)
    q = arm.sample(rng)
    qp = pin.neutral(model)
    for jn, v in zip(arm.joint_names, q, strict=True):
        qp[model.joints[model.getJointId(jn)].idx_q] = v
    arm.fk(q)
    arm.jacobian(q)

    def pin_fk() -> object:
        pin.forwardKinematics(model, data, qp)
        return pin.updateFramePlacement(model, data, fid)

    def pin_jac() -> object:
        return pin.computeFrameJacobian(model, data, qp, fid, pin.LOCAL_WORLD_ALIGNED)

    out = {
        "armctl_fk": per_call_us(lambda: arm.fk(q), calls),
        "pin_fk": per_call_us(pin_fk, calls),
        "armctl_jac": per_call_us(lambda: arm.jacobian(q), calls),
        "pin_jac": per_call_us(pin_jac, calls),
    }
    qs = arm.sample(rng, batch)
    arm.fk_batch(qs[:8])
    best = float("inf")
    for _ in range(3):
        t = time.perf_counter()
        arm.fk_batch(qs)
        best = min(best, time.perf_counter() - t)
    out["batch_rate"] = batch / best
    # pinocchio's per-pose loop, for the same batch (a sample of it, to keep the run short)
    m = min(batch, 20000)
    t = time.perf_counter()
    for k in range(m):
        pin.framesForwardKinematics(model, data, qp + 0.0 * k)
    out["pin_batch_rate"] = m / (time.perf_counter() - t)
    return out


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--calls", type=int, default=20000)
    parser.add_argument("--batch", type=int, default=1_000_000)
    args = parser.parse_args()
    rows = []
    for name, dof in ARMS:
        r = bench_arm(name, args.calls, args.batch)
        rows.append(
            f"| {name} ({dof} DOF) | {r['armctl_fk']:.2f} | {r['pin_fk']:.2f} | "
            f"{r['armctl_fk'] / r['pin_fk']:.1f}x | {r['armctl_jac']:.2f} | {r['pin_jac']:.2f} | "
            f"{r['armctl_jac'] / r['pin_jac']:.1f}x | {r['batch_rate'] / 1e6:.2f} M/s | "
            f"{r['pin_batch_rate'] / 1e6:.2f} M/s |")
        print(rows[-1], flush=True)
    md = "\n".join([
        "## Kinematics: FK and Jacobian",
        "",
        "Single calls from Python (`arm.fk(q)`, `arm.jacobian(q)` with input checks) against "
        "pinocchio (`forwardKinematics` + `updateFramePlacement`; `computeFrameJacobian`) on "
        "the same URDF, best of 5 runs. Batched FK: `arm.fk_batch(qs)` on one core, against "
        "pinocchio's `framesForwardKinematics` called per pose. Targets: single calls within 4x of "
        "pinocchio; batched 6-DOF FK at least 1 M poses/s per core.",
        "",
        "| arm | armctl FK [us] | pinocchio FK [us] | ratio | armctl J [us] | pinocchio J [us] "
        "| ratio | armctl batched FK | pinocchio per-pose loop |",
        "|---|---|---|---|---|---|---|---|---|",
        *rows,
    ])
    cmd = "python tools/bench_kinematics.py " + " ".join(sys.argv[1:])
    print(write_section("kinematics", md, cmd.strip()))


if __name__ == "__main__":
    main()
