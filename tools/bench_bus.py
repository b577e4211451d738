"""Closed-loop bus rate: one sync read of positions + one sync write of goals per cycle.

Runs 6-servo arms on the simulated bus at 1 Mbps with wire timing on (replies paced at 10 bit
times per byte plus each servo's return delay), through the real SDKs, and compares the
achieved rate with the limit computed from the packet lengths and return delays. A second run
with wire timing off gives the software cost per cycle; the calling thread's CPU time per cycle
is the Python overhead of armctl plus the SDK (the simulator runs in another thread).

Usage: python tools/bench_bus.py [--cycles N] [--no-write] [--json OUT] [--before IN
[--before-label TEXT]]
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
from typing import Any

from armctl.config import load_spec
from armctl.config.bus import Protocol
from armctl.servo import ArmBus, Register

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _benchdoc import write_section


def cycle_bytes(protocol: Protocol, n: int, size: int) -> int:
    """Bytes on the wire in one cycle: the sync read, ``n`` status packets, the sync write.

    Args:
        protocol: Wire protocol.
        n: Servos.
        size: Data bytes per servo (the goal / present position register).
    """
    if protocol is Protocol.DYNAMIXEL:
        # e-Manual Protocol 2.0: header FF FF FD 00, ID, LEN (2), INST, params, CRC (2);
        # sync read/write params: start address (2), data length (2), then per servo its id
        # (and its data); a status packet: header, ID, LEN (2), INST 0x55, ERR, data, CRC (2)
        read, status, write = 10 + 4 + n, 11 + size, 10 + 4 + n * (1 + size)
    else:
        # Feetech SCS/STS (Protocol 1.0 framing): FF FF, ID, LEN, INST or ERR, params, checksum;
        # sync read/write params: start address, data length, then per servo its id (and data)
        read, status, write = 6 + 2 + n, 6 + size, 6 + 2 + n * (1 + size)
    return read + n * status + write


def limit(protocol: Protocol, n: int, size: int, baud: int, delays: list[float]) -> float:
    """Cycles per second the wire allows: 10 bit times a byte (8N1) plus the return delays [s]."""
    return 1.0 / (cycle_bytes(protocol, n, size) * 10.0 / baud + sum(delays))


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
            line = proc.stdout.readline()
            if not line:  # end of file: the simulator exited (its error is on stderr)
                raise SystemExit(f"'armctl sim {config}' exited with code {proc.wait()} "
                                 "before printing its port")
            head += line
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
    parser.add_argument("--no-write", action="store_true",
                        help="print the table only; leave docs/benchmarks.md alone")
    parser.add_argument("--json", type=Path, help="also save the measurements in this file")
    parser.add_argument("--before", type=Path,
                        help="measurements saved (--json) by an earlier version, to compare")
    parser.add_argument("--before-label", default="before",
                        help="what the earlier version was, for the comparison table")
    args = parser.parse_args()
    rows = []
    saved: list[dict[str, Any]] = []
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
            saved.append({"bus": name, "simulator": where, "limit": timed["limit"],
                          "mean": rate, "median": typical, "software": free["median"],
                          "python": free["cpu"]})
    if args.json is not None:
        args.json.write_text(json.dumps({"rows": saved}, indent=1), encoding="utf-8")
    md = "\n".join([
        "## Servo bus: closed-loop sync read + sync write (`tools/bench_bus.py`)",
        "",
        "One cycle = `ArmBus.read_joints()` (one sync read of 6 present positions, error bytes "
        "checked) + `ArmBus.write_joints()` (limits checked, one sync write of 6 goals), "
        "through the real SDKs on the simulated bus at 1 Mbps. *Limit*: the wire time of the "
        "cycle's packets (for N servos and D data bytes each: Dynamixel 2.0 sync read 14 + N "
        "bytes, status packets 11 + D, sync write 14 + N (1 + D); Feetech 8 + N, 6 + D and "
        "8 + N (1 + D); 10 bit times a byte) plus the servos' return delays (0 here). "
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
        *(_comparison(args.before, args.before_label, saved) if args.before else []),
    ])
    cmd = "python tools/bench_bus.py" + (f" --cycles {args.cycles}" if args.cycles != 2000
                                         else "")
    if args.before is not None:
        cmd += f" --before {args.before.name} --before-label '{args.before_label}'"
    if args.no_write:
        print(md)
    else:
        print(write_section("bus", md, cmd))


def _comparison(path: Path, label: str, now: list[dict[str, Any]]) -> list[str]:
    """Markdown lines comparing these measurements with those saved in ``path``."""
    before = {(r["bus"], r["simulator"]): r for r in json.loads(path.read_text())["rows"]}
    lines = ["", f"Compared with {label} (measured by this tool in the same session, "
             "`--json`):", "",
             "| bus | simulator | median cycle, before | median cycle, now | "
             "Python before [ms/cycle] | Python now [ms/cycle] |",
             "|---|---|---:|---:|---:|---:|"]
    for r in now:
        b = before.get((r["bus"], r["simulator"]))
        if b is None:
            continue
        lines.append(f"| {r['bus']} | {r['simulator']} | "
                     f"{100 * b['median'] / b['limit']:.0f} % | "
                     f"{100 * r['median'] / r['limit']:.0f} % | "
                     f"{1e3 * b['python']:.3f} | {1e3 * r['python']:.3f} |")
    return lines


if __name__ == "__main__":
    main()
