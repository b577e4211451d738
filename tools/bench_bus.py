"""Closed-loop bus rate: one sync read of positions + one sync write of goals per cycle.

Runs 6-servo arms on the simulated bus at 1 Mbps with wire timing on (replies paced at 10 bit
times per byte plus each servo's return delay), through the real SDKs, and compares the
achieved rate with the limit computed from the packet lengths and return delays. A second run
with wire timing off gives the software cost per cycle; the calling thread's CPU time per cycle
is the Python overhead of armctl plus the SDK (the simulator runs in another thread).

Usage: python tools/bench_bus.py [--cycles N] [--no-write]
"""

from __future__ import annotations

import argparse
import contextlib
import itertools
import json
import os
import statistics
import subprocess
import sys
import time
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

from armctl.config import load_spec
from armctl.config.bus import Protocol
from armctl.servo import ArmBus, Register

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _benchdoc import write_section

# packet sizes [bytes] (Dynamixel 2.0: header 7 + INST + params + CRC 2; Feetech: header 4 +
# INST/ERR + params + checksum), for N servos and D data bytes each
SIZES = {
    Protocol.DYNAMIXEL: {"read_inst": lambda n: 14 + n, "reply": lambda d: 11 + d,
                         "write": lambda n, d: 14 + n * (1 + d)},
    Protocol.FEETECH: {"read_inst": lambda n: 8 + n, "reply": lambda d: 6 + d,
                       "write": lambda n, d: 8 + n * (1 + d)},
}


def limit(protocol: Protocol, n: int, size: int, baud: int, delays: list[float]) -> float:
    """Cycles per second the wire allows: bytes x 10 bit / baud plus the return delays."""
    s = SIZES[protocol]
    nbytes = s["read_inst"](n) + n * s["reply"](size) + s["write"](n, size)
    return 1.0 / (nbytes * 10.0 / baud + sum(delays))


@contextlib.contextmanager
def standalone_sim(config: str, wire: bool) -> Iterator[str]:
    """``armctl sim`` in its own process (no GIL shared with the host); yields its pty."""
    cmd = [sys.executable, "-m", "armctl", "sim", config, "--json"]
    if wire:
        cmd.append("--wire-timing")
    proc = subprocess.Popen(cmd, stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True,
                            env=dict(os.environ, PYTHONUNBUFFERED="1"))
    try:
        assert proc.stdout is not None and proc.stdin is not None
        head = ""
        while not head.rstrip().endswith("}"):
            head += proc.stdout.readline()
        yield json.loads(head)["port"]
        proc.stdin.write("quit\n")
        proc.stdin.flush()
        proc.wait(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()


def run(config: str, cycles: int, wire: bool, separate: bool) -> dict[str, float]:
    spec = load_spec(config)
    assert spec.bus is not None
    with contextlib.ExitStack() as stack:
        if separate:
            port = stack.enter_context(standalone_sim(config, wire))
            spec = replace(spec, bus=replace(spec.bus, port=port))
        ab = stack.enter_context(ArmBus.from_spec(spec, wire_timing=wire))
        q = ab.read_joints()
        for _ in range(20):  # warm up
            ab.read_joints()
            ab.write_joints(q)
        stamps = [0.0] * (cycles + 1)
        c0 = time.thread_time()
        stamps[0] = time.perf_counter()
        for k in range(cycles):
            q = ab.read_joints()
            ab.write_joints(q)
            stamps[k + 1] = time.perf_counter()
        cpu = (time.thread_time() - c0) / cycles
        wall = (stamps[-1] - stamps[0]) / cycles
        median = statistics.median(b - a for a, b in itertools.pairwise(stamps))
        sb = ab.servo_bus
        delays = [2e-6 * sb.read(j.servo_id, Register.RETURN_DELAY) for j in ab.mapping.joints]
        size = sb.table(ab.mapping.ids[0]).spec(Register.GOAL_POSITION).size
        assert spec.bus is not None
        lim = limit(spec.bus.protocol, len(ab.mapping.ids), size, spec.bus.baudrate, delays)
    return {"wall": wall, "median": median, "cpu": cpu, "limit": lim}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--cycles", type=int, default=2000)
    args = parser.parse_args()
    rows = []
    load_before = os.getloadavg()[0]
    for name, config in (("Dynamixel 2.0 (6 x XM430, UR5e)", "ur5e"),
                         ("Feetech STS (6 x STS3215, SO-101)", "so101")):
        for separate in (True, False):
            timed = run(config, args.cycles, True, separate)
            free = run(config, args.cycles, False, separate)
            rate, typical = 1.0 / timed["wall"], 1.0 / timed["median"]
            where = "own process" if separate else "in-process thread"
            rows.append(f"| {name} | {where} | {timed['limit']:.0f} | {rate:.0f} "
                        f"({100 * rate / timed['limit']:.0f} %) | {typical:.0f} "
                        f"({100 * typical / timed['limit']:.0f} %) | "
                        f"{1e3 * free['median']:.3f} | {1e3 * free['cpu']:.3f} |")
            print(rows[-1], flush=True)
    md = "\n".join([
        "## Servo bus: closed-loop sync read + sync write (`tools/bench_bus.py`)",
        "",
        "One cycle = `ArmBus.read_joints()` (one sync read of 6 present positions, error bytes "
        "checked) + `ArmBus.write_joints()` (limits checked, one sync write of 6 goals), "
        "through the real SDKs on the simulated bus at 1 Mbps. *Limit*: the wire time of the "
        "cycle's packets (10 bit times a byte) plus the servos' return delays (0 here). "
        "*Achieved*: from the mean cycle time, and from the median one (robust to cycles "
        "that waited for a core on a busy machine). *Software*: the median cycle with wire "
        "timing off; *Python*: the CPU time of the calling "
        "thread per cycle (armctl + SDK). The simulator runs either as `armctl sim` in its own "
        "process (as hardware would: no interpreter shared with the host) or as the in-process "
        "thread that `port: sim` starts (sharing the host's GIL and cores).",
        "",
        "| bus | simulator | limit [Hz] | achieved, mean [Hz] | achieved, median cycle [Hz] | "
        "software [ms/cycle] | Python [ms/cycle] |",
        "|---|---|---:|---:|---:|---:|---:|",
        *rows,
        "",
        f"Load average of the machine during the run: {load_before:.1f} at the start, "
        f"{os.getloadavg()[0]:.1f} at the end (on a busy machine the simulator's and the host's "
        "thread wake-ups wait for a core, and that time adds to every cycle).",
    ])
    cmd = "python tools/bench_bus.py" + (f" --cycles {args.cycles}" if args.cycles != 2000
                                         else "")
    print(write_section("bus", md, cmd))


if __name__ == "__main__":
    main()
