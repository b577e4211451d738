"""IK of an arm with ball joints against the same arm written with three revolute axes per ball.

Writes the ``ik-ball`` section of docs/benchmarks.md.

The bundled ``figure`` has ball joints at its shoulders and hips (IK in the tangent space:
Python steps around the compiled FK, Jacobian and residual, :mod:`armctl.ik.tangent`; ``nlp``
with a quaternion per ball joint). Its twin, built here, writes each ball joint as three
revolute axes meeting in one point (x-z-y for a shoulder, y-x-z for a hip, ranges like the
cone's), which the compiled engine solves. Both solve the same goals on the right palm from
random starts, interleaved goal by goal: full poses (FK of random configurations of the ball
figure; goals the twin cannot reach inside its ranges count against it) and positions.
Success is checked by armctl's FK of the answer (the goal's tolerance) and the limits.

Usage: python tools/bench_ball_ik.py [--goals 100] [--nlp-goals 15]
"""

from __future__ import annotations

import argparse
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

sys.path.insert(0, str(Path(__file__).resolve().parent))

#: Three revolute axes standing in for a ball joint: (axis, range [deg]) per axis.
THREE_AXES = {
    "shoulder": (([1, 0, 0], (-95, 100)), ([0, 0, 1], (-100, 100)), ([0, 1, 0], (-90, 90))),
    "hip": (([0, 1, 0], (-120, 30)), ([1, 0, 0], (-45, 45)), ([0, 0, 1], (-45, 45))),
}


def three_axis_twin(folder: Path) -> Path:
    """The bundled figure with each ball joint written as three revolute axes."""
    from armctl.config import bundled_configs_dir

    doc = yaml.safe_load((bundled_configs_dir() / "figure.yaml").read_text(encoding="utf-8"))
    joints: list[dict[str, Any]] = []
    for j in doc["joints"]:
        if j["type"] != "ball":
            joints.append(j)
            continue
        kind = "shoulder" if "shoulder" in j["name"] else "hip"
        parent = j["parent"]
        for k, (axis, (lo, hi)) in enumerate(THREE_AXES[kind], start=1):
            child = j["child"] if k == 3 else f"{j['name']}__{k}"
            joints.append({"name": f"{j['name']}_{k}", "type": "revolute", "parent": parent,
                           "child": child, "axis": axis,
                           "limits": {"lower": f"{lo} deg", "upper": f"{hi} deg"},
                           **({"origin": j["origin"]} if k == 1 else {})})
            parent = child
    doc["joints"] = joints
    for key in ("poses", "collision", "skin"):
        doc.pop(key, None)
    out = folder / "figure_three_axes.yaml"
    out.write_text(yaml.safe_dump(doc, sort_keys=False), encoding="utf-8")
    return out


def run(goals: int, nlp_goals: int) -> tuple[str, str]:
    import armctl
    from armctl.ik import PoseGoal, PositionGoal

    ball = armctl.load_arm("figure")
    with tempfile.TemporaryDirectory() as tmp:
        twin = armctl.load_arm(three_axis_twin(Path(tmp)))
    rng = np.random.default_rng(0)
    targets = [ball.fk(ball.sample(rng), "right_palm") for _ in range(goals)]
    starts = {id(a): [a.sample(np.random.default_rng(1)) for _ in range(goals)]
              for a in (ball, twin)}
    rows = []
    for kind in ("pose", "position"):
        for solver in ("dls", "pinv", "nlp"):
            n = nlp_goals if solver == "nlp" else goals
            stats: dict[int, list[float]] = {id(ball): [], id(twin): []}
            wins = {id(ball): 0, id(twin): 0}
            for arm in (ball, twin):  # load the kernels before the clock
                arm.ik(PositionGoal(targets[0][:3, 3], frame="right_palm"), solver=solver)
            for i in range(n):
                order = (ball, twin) if i % 2 == 0 else (twin, ball)
                for arm in order:
                    goal = (PoseGoal(targets[i], frame="right_palm") if kind == "pose"
                            else PositionGoal(targets[i][:3, 3], frame="right_palm"))
                    t = time.perf_counter()
                    res = arm.ik(goal, starts[id(arm)][i], solver)
                    stats[id(arm)].append(time.perf_counter() - t)
                    wins[id(arm)] += bool(res.success and arm.within_limits(res.q))
            tb = float(np.median(stats[id(ball)])) * 1e3
            tt = float(np.median(stats[id(twin)])) * 1e3
            rows.append(f"| {kind} | {solver} | {n} | {tb:.2f} | {wins[id(ball)]} | {tt:.3f} "
                        f"| {wins[id(twin)]} | {tb / tt:.0f}x |")
    md = "\n".join([
        "## IK with ball joints (`tools/bench_ball_ik.py`)",
        "",
        "The bundled `figure` (ball joints at shoulders and hips; tangent-space IK in Python "
        "around the compiled kernels, `nlp` with quaternion variables) against its twin with "
        "three revolute axes per ball joint (the compiled engine), on the same goals for the "
        "right palm from random starts, interleaved. Median wall time per call and successes "
        "(FK of the answer within the goal's tolerance, inside the limits). Pose goals come "
        "from the ball figure's configurations: some lie outside the twin's three ranges.",
        "",
        "| goal | solver | goals | ball [ms] | solved | three axes [ms] | solved | ratio |",
        "|---|---|---|---|---|---|---|---|",
        *rows,
    ])
    return md, f"python tools/bench_ball_ik.py --goals {goals} --nlp-goals {nlp_goals}"


def main() -> None:
    from _benchdoc import write_section

    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--goals", type=int, default=100)
    p.add_argument("--nlp-goals", type=int, default=15)
    args = p.parse_args()
    md, command = run(args.goals, args.nlp_goals)
    print(md)
    print(f"wrote {write_section('ik-ball', md, command)}")


if __name__ == "__main__":
    main()
