"""What publishing the live state costs the control loop, and how fresh watchers see it.

Three measurements:

1. The executor hook alone (:func:`armctl.robot.live_publisher.cycle_hook`): time per call with
   0, 1 and 4 watchers connected (each following in its own thread), over many calls.
2. The real loop: ``armctl sim so101 --wire-timing`` in its own process, a robot on its pty
   streams the same joint move at 50 Hz in real time: not publishing, publishing to nobody, and
   publishing to 4 watchers in their own processes (each reads every line); cycle lateness
   (jitter) and the time of one write + read per cycle, as the executor reports them.
3. Delivery: the age of each snapshot when a watcher in this process has read it (its ``time``
   field against the wall clock), median and 99th percentile.

Usage: python tools/bench_live_state.py [--repeats N] [--no-write]
"""

from __future__ import annotations

import argparse
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

from armctl.robot import Robot
from armctl.robot.executor import CycleInfo
from armctl.robot.live_publisher import LivePublisher, cycle_hook, hello_for
from armctl.robot.live_state import Activity
from armctl.robot.live_watch import attach

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _benchdoc import write_section

ENV = dict(os.environ, PYTHONUNBUFFERED="1")
GOAL = np.array([0.5, -0.3, 0.3, 0.2, 0.3, 0.3])


def hook_cost(watchers: int, calls: int = 50_000) -> tuple[float, float]:
    """Median and 99th percentile time of one hook call [us] with ``watchers`` following."""
    port = "/dev/null"
    pub = LivePublisher(hello_for("so101", "so101", port, [f"j{i}" for i in range(6)],
                                  ["rad"] * 6)).start()
    followers = [attach(port) for _ in range(watchers)]
    for w in followers:
        assert w is not None
        w.follow()
    hook = cycle_hook(pub, Activity.MOVE, "move", None)
    info = CycleInfo(0.1, 1.0, np.zeros(6), np.ones(6), 0.0, False)
    times = np.empty(calls)
    clock = time.perf_counter_ns
    for k in range(calls):
        t0 = clock()
        hook(info)
        times[k] = clock() - t0
    for w in followers:
        assert w is not None
        w.close()
    pub.close()
    return float(np.median(times)) / 1e3, float(np.percentile(times, 99)) / 1e3


def delivery_age(seconds: float = 3.0) -> tuple[float, float, int]:
    """Median and p99 age [ms] of a snapshot when read, and how many were read."""
    port = "/dev/null"
    with LivePublisher(hello_for("so101", "so101", port, [f"j{i}" for i in range(6)],
                                 ["rad"] * 6)) as pub:
        pub.cycle(Activity.MOVE, "move", 0.0, 1.0, np.zeros(6), np.zeros(6))
        watcher = attach(port)
        assert watcher is not None
        ages = []
        end = time.monotonic() + seconds
        while time.monotonic() < end:
            snap = watcher.next()
            ages.append(time.time() - snap.time)
        watcher.close()
    a = np.array(ages) * 1e3
    return float(np.median(a)), float(np.percentile(a, 99)), len(a)


#: A watcher process that reads every line until the owner ends (no parsing, no display: the
#: cost measured is the owner's).
READER = ("import socket, sys\n"
          "from armctl.robot.live_state import socket_path\n"
          "c = socket.socket(socket.AF_UNIX)\n"
          "c.connect(str(socket_path(sys.argv[1])))\n"
          "while c.recv(65536):\n"
          "    pass\n")


def stream(port: str, watchers: int, repeats: int, publish: bool = True) -> dict[str, float]:
    """Jitter and I/O time of a real-time joint move on ``port`` with ``watchers`` watching."""
    procs: list[subprocess.Popen[bytes]] = []
    p99, mean, io = [], [], []
    with Robot.open("so101", port=port, publish=publish) as robot:
        for _ in range(watchers):
            procs.append(subprocess.Popen([sys.executable, "-c", READER, port],
                                          stdout=subprocess.DEVNULL, env=ENV))
        deadline = time.monotonic() + 60.0
        while robot.live is not None and robot.live.watchers < watchers \
                and time.monotonic() < deadline:
            time.sleep(0.1)
        for k in range(repeats):
            goal = GOAL if k % 2 == 0 else np.zeros(6)
            res = robot.move_joints(goal, speed=0.3)
            assert res.result is not None
            s = res.result.stats
            p99.append(s.jitter_p99)
            mean.append(s.jitter_mean)
            io.append(s.io_time_mean)
        seen = 0 if robot.live is None else robot.live.watchers
    for p in procs:
        p.wait(timeout=30)  # they end when the robot releases the port
    return {"publish": publish, "watchers": seen, "jitter_mean_ms": 1e3 * float(np.mean(mean)),
            "jitter_p99_ms": 1e3 * float(np.max(p99)), "io_ms": 1e3 * float(np.mean(io))}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--repeats", type=int, default=4, help="moves per configuration")
    parser.add_argument("--no-write", action="store_true", help="leave docs/benchmarks.md alone")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory(prefix="al") as runtime:
        os.environ["XDG_RUNTIME_DIR"] = ENV["XDG_RUNTIME_DIR"] = runtime  # sockets of this run
        return _run(args)


def _run(args: argparse.Namespace) -> int:

    hooks = {n: hook_cost(n) for n in (0, 1, 4)}
    age = delivery_age()
    sim = subprocess.Popen([sys.executable, "-m", "armctl", "sim", "so101", "--wire-timing",
                            "--json"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                           env=ENV)
    assert sim.stdout is not None and sim.stdin is not None
    head = ""
    while not head.rstrip().endswith("}"):
        head += sim.stdout.readline()
    port = json.loads(head)["port"]
    try:
        loops = [stream(port, 0, args.repeats, publish=False), stream(port, 0, args.repeats),
                 stream(port, 4, args.repeats)]
    finally:
        sim.stdin.write("quit\n")
        sim.stdin.flush()
        sim.wait(timeout=10)

    lines = ["## Live state (watching a running motion)", "",
             "The executor hook stores each cycle for watchers; a server thread sends 25 "
             "snapshots a second.", "",
             "| watchers following | hook per cycle, median [us] | p99 [us] |", "|---|---|---|"]
    lines += [f"| {n} | {m:.2f} | {p:.2f} |" for n, (m, p) in hooks.items()]
    lines += ["", f"Snapshot age when read by a watcher: median {age[0]:.2f} ms, p99 "
              f"{age[1]:.2f} ms ({age[2]} snapshots).", "",
              "A joint move of the SO-101 at 50 Hz in real time on `armctl sim so101 "
              "--wire-timing` (its own process), the robot in this one, watchers in their own "
              f"processes reading every line ({args.repeats} moves each):", "",
              "| publishing | watchers | cycle lateness mean [ms] | worst p99 [ms] | "
              "write + read [ms] |", "|---|---|---|---|---|"]
    lines += [f"| {'yes' if r['publish'] else 'no'} | {r['watchers']:.0f} | "
              f"{r['jitter_mean_ms']:.3f} | {r['jitter_p99_ms']:.3f} | {r['io_ms']:.3f} |"
              for r in loops]
    text = "\n".join(lines)
    print(text)
    if not args.no_write:
        write_section("live-state", text, "python tools/bench_live_state.py")
    return 0


if __name__ == "__main__":
    sys.exit(main())
