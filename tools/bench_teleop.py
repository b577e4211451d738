"""Teleoperation loop: rate, leader-read-to-follower-write latency, dropped cycles.

Each arm of a bundled pair runs as ``armctl sim CONFIG --wire-timing`` in its own process (the
simulated servos on a pty, replies paced at the baud rate, as hardware would be); this process
opens both ptys and runs :class:`armctl.robot.teleop.Teleop` in real time, while a thread
hand-guides the leader through its simulator's console (``set JOINT VALUE``, a slow sweep of
two joints). Per cycle: one sync read of the leader's 6 joints, one sync write of the
follower's 6 goals.

Usage: python tools/bench_teleop.py [--seconds S] [--no-write] [--json OUT]
"""

from __future__ import annotations

import argparse
import json
import math
import os
import subprocess
import sys
import threading
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from armctl.arm import Arm, load_arm
from armctl.config.motion import ExitPolicy
from armctl.robot import Robot
from armctl.robot.teleop import Teleop, TeleopOptions, TeleopStats

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _benchdoc import write_section

PAIRS = (("so101_leader", "so101", "Feetech STS3215 (SO-101)"),
         ("koch_leader", "koch_follower", "Dynamixel XL330/XL430 (Koch)"))
ENV = dict(os.environ, PYTHONUNBUFFERED="1")


class Sim:
    """``armctl sim CONFIG --wire-timing --json`` in its own process."""

    def __init__(self, config: str):
        self.proc = subprocess.Popen(
            [sys.executable, "-m", "armctl", "sim", config, "--wire-timing", "--json"],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True, env=ENV)
        assert self.proc.stdout is not None
        head = ""
        while not head.rstrip().endswith("}"):
            line = self.proc.stdout.readline()
            if not line:
                raise RuntimeError(f"armctl sim {config} ended before it printed its port")
            head += line
        self.port: str = json.loads(head)["port"]
        self._lock = threading.Lock()

    def send(self, line: str) -> str:
        """One console line; its reply line."""
        assert self.proc.stdin is not None and self.proc.stdout is not None
        with self._lock:
            self.proc.stdin.write(line + "\n")
            self.proc.stdin.flush()
            return self.proc.stdout.readline()

    def close(self) -> None:
        if self.proc.poll() is None:
            self.proc.kill()
        self.proc.wait(10)


def on_port(config: str, port: str) -> Arm:
    """The bundled arm with its bus on ``port``."""
    arm = load_arm(config)
    assert arm.spec.bus is not None
    return Arm(replace(arm.spec, bus=replace(arm.spec.bus, port=port)))


def guide(sim: Sim, stop: threading.Event) -> None:
    """Hand-guide the leader: a slow sweep of shoulder_pan and elbow_flex at about 50 Hz."""
    t0 = time.monotonic()
    while not stop.is_set():
        t = time.monotonic() - t0
        sim.send(f"set shoulder_pan {0.4 * math.sin(2 * math.pi * 0.3 * t):.5f}")
        sim.send(f"set elbow_flex {0.5 + 0.3 * math.sin(2 * math.pi * 0.2 * t):.5f}")
        time.sleep(0.02)


def run(leader: str, follower: str, seconds: float, rate: float) -> tuple[TeleopStats, float]:
    """One teleoperation of ``seconds`` at ``rate`` [Hz] on two ``armctl sim`` processes.

    Returns:
        The figures, and the span of the follower's shoulder_pan commands [rad] (the sweep
        it copied from the leader).
    """
    lead_sim, fol_sim = Sim(leader), Sim(follower)
    stop = threading.Event()
    try:
        with Robot.open(on_port(leader, lead_sim.port), hold=False,
                        exit_policy=ExitPolicy.HOLD) as lead, \
                Robot.open(on_port(follower, fol_sim.port), exit_policy=ExitPolicy.HOLD) as fol:
            tele = Teleop(lead, fol, TeleopOptions(rate_hz=rate, duration=seconds))
            tele.start()
            hand = threading.Thread(target=guide, args=(lead_sim, stop), daemon=True)
            hand.start()
            pan = fol.bus.joint_names.index("shoulder_pan")
            sent: list[float] = []
            stats = tele.run(lambda c: sent.append(float(c.command[pan])))
            stop.set()
            hand.join(5)
        return stats, max(sent) - min(sent)
    finally:
        stop.set()
        lead_sim.close()
        fol_sim.close()


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seconds", type=float, default=10.0, help="length of each run [s]")
    parser.add_argument("--no-write", action="store_true",
                        help="print the table only; leave docs/benchmarks.md alone")
    parser.add_argument("--json", type=Path, help="also save the measurements in this file")
    args = parser.parse_args()
    rows: list[str] = []
    load0 = os.getloadavg()[0]
    saved: list[dict[str, Any]] = []
    for leader, follower, what in PAIRS:
        for rate in (100.0, 200.0):
            s, span = run(leader, follower, args.seconds, rate)
            rows.append(f"| {leader} -> {follower} | {what} | {rate:.0f} | "
                        f"{s.achieved_rate:.1f} | {1e3 * s.latency_median:.2f} | "
                        f"{1e3 * s.latency_p99:.2f} | {s.dropped} of "
                        f"{s.cycles + s.dropped} | {span:.2f} |")
            print(rows[-1], flush=True)
            saved.append({"pair": f"{leader}->{follower}", "rate": rate,
                          "achieved": s.achieved_rate, "median": s.latency_median,
                          "p99": s.latency_p99, "dropped": s.dropped, "cycles": s.cycles,
                          "span": span})
    if args.json is not None:
        args.json.write_text(json.dumps({"rows": saved}, indent=1), encoding="utf-8")
    md = "\n".join([
        "## Teleoperation loop (`tools/bench_teleop.py`)",
        "",
        "A bundled leader/follower pair, each arm as `armctl sim CONFIG --wire-timing` in its "
        "own process (simulated servos on a pty, replies paced at 1 Mbps), driven by "
        f"`armctl.robot.teleop.Teleop` in real time for {args.seconds:g} s per row while a "
        "thread hand-guides the leader through its simulator's console. A cycle is one sync "
        "read of the leader's 6 joints, the limits (clamp, velocity and acceleration), and one "
        "sync write of the follower's 6 goals. *Latency*: from the start of the leader's read "
        "to the end of the follower's write in the same cycle. *Dropped*: cycles whose "
        "deadline passed before they could start (skipped, never bunched), of all deadlines. "
        "*Pan sweep copied*: the span of the follower's shoulder_pan commands (the leader is "
        "swept over 0.8 rad).",
        "",
        "| pair | servos | set rate [Hz] | achieved [Hz] | latency median [ms] | "
        "latency p99 [ms] | dropped cycles | pan sweep copied [rad] |",
        "|---|---|---:|---:|---:|---:|---:|---:|",
        *rows,
        "",
        f"Load average of the machine: {load0:.1f} at the start, {os.getloadavg()[0]:.1f} at "
        "the end (the simulators, the hand-guiding thread and the loop share the cores).",
    ])
    cmd = "python tools/bench_teleop.py" + (f" --seconds {args.seconds:g}"
                                            if args.seconds != 10.0 else "")
    if args.no_write:
        print(md)
    else:
        print(write_section("teleop", md, cmd))


if __name__ == "__main__":
    main()
