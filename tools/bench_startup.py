"""Benchmark: how long armctl commands take from the shell, warm and on the first run.

Warm: each command runs once to warm the caches (not counted), then ``--runs`` times; the
median and the fastest run are reported, with the machine's load average. With ``--baseline
TREE`` (another source tree of armctl, e.g. an export of an earlier commit) its runs are
interleaved with this checkout's, so both see the same load.

Cold (``--cold``): each compute command runs once with an empty numba cache (a fresh
``NUMBA_CACHE_DIR``), as the first command after installing does; the kernels compiled, their
total compile time and the costliest ones are listed.

Every command runs in a new interpreter as the ``armctl`` script does (``from armctl.cli
import main``); the interpreter's own start is part of the time.

Usage: python tools/bench_startup.py [--runs N] [--cold] [--baseline TREE] [--no-write]
Writes the "startup" section of docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _benchdoc import write_section

ROOT = Path(__file__).resolve().parent.parent

#: (command line, target [s] warm or None).
WARM = (
    (["--help"], 0.15),
    (["info", "so101"], 0.3),
    (["fk", "ur5e", "0", "0", "0", "0", "0", "0"], 0.4),
    (["ik", "so101", "--xyz", "0.2", "0", "0.15"], None),
    (["move-to-pose", "so101", "--xyz", "0.2", "0", "0.15", "--dry-run"], None),
)

#: Commands run with an empty kernel cache (``--cold``).
COLD = (
    ["fk", "ur5e", "0", "0", "0", "0", "0", "0"],
    ["move-to-pose", "so101", "--xyz", "0.2", "0", "0.15", "--dry-run"],
    ["ik", "ur5e", "--xyz", "0.4", "0.1", "0.4", "--rpy", "3.14159", "0", "0", "--solver",
     "analytic", "--all"],
)

_DRIVER = "import sys; from armctl.cli import main; sys.exit(main())"

#: Runs a command and writes the kernels it compiled (name, seconds, own seconds) as JSON. With
#: armctl's compile_progress the listener starts when numba is imported (a tree without it
#: imports numba at start anyway, so listening from the start changes nothing there).
_COLD_DRIVER = """\
import json, sys, time
try:
    from armctl.kinematics import compile_progress
except ImportError:
    compile_progress = None
records, open_ = [], []
if compile_progress is not None:
    compile_progress.report_compiles_once_loaded(delay=3600.0)
else:
    from numba.core import event

    class Listener(event.Listener):
        def on_start(self, ev):
            f = ev.data["dispatcher"].py_func
            open_.append([f"{f.__module__}.{f.__qualname__}", time.perf_counter(), 0.0])

        def on_end(self, ev):
            name, start, nested = open_.pop()
            now = time.perf_counter()
            records.append([name, now - start, now - start - nested])
            if open_:
                open_[-1][2] += now - start

    event.register("numba:compile", Listener())
from armctl.cli import main
try:
    code = main(sys.argv[2:])
finally:
    if compile_progress is not None:
        records = [[r.name, r.seconds, r.own_seconds]
                   for r in compile_progress.compile_records()]
    with open(sys.argv[1], "w") as f:
        json.dump(records, f)
sys.exit(code)
"""


def _env(tree: Path, cache: str | None = None) -> dict[str, str]:
    env = dict(os.environ)
    env["PYTHONPATH"] = str(tree) + os.pathsep + env.get("PYTHONPATH", "")
    if cache is not None:
        env["NUMBA_CACHE_DIR"] = cache
    return env


def run_once(tree: Path, argv: list[str]) -> float:
    """Wall time of one command [s] (its output discarded); raises if it fails."""
    t = time.perf_counter()
    proc = subprocess.run([sys.executable, "-c", _DRIVER, *argv], env=_env(tree), cwd=tree,
                          stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
    dt = time.perf_counter() - t
    if proc.returncode != 0:
        raise SystemExit(f"armctl {' '.join(argv)} failed ({proc.returncode}): {proc.stderr}")
    return dt


def warm(trees: list[Path], runs: int) -> dict[tuple[int, int], list[float]]:
    """Times per (tree, command), runs interleaved across trees and commands."""
    for tree in trees:  # warm-up: caches (numba's, the OS's) filled, not counted
        for argv, _ in WARM:
            run_once(tree, argv)
    times: dict[tuple[int, int], list[float]] = {}
    for _ in range(runs):
        for ci, (argv, _) in enumerate(WARM):
            for ti, tree in enumerate(trees):
                times.setdefault((ti, ci), []).append(run_once(tree, argv))
    return times


def cold(tree: Path, argv: list[str]) -> tuple[float, list[tuple[str, float, float]]]:
    """Wall time [s] with an empty kernel cache and the compiles (name, s, own s)."""
    with tempfile.TemporaryDirectory(prefix="armctl-numba-") as cache:
        out = Path(cache) / "compiles.json"
        t = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", _COLD_DRIVER, str(out), *argv],
                              env=_env(tree, str(Path(cache) / "kernels")), cwd=tree,
                              stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        dt = time.perf_counter() - t
        if proc.returncode != 0:
            raise SystemExit(f"armctl {' '.join(argv)} failed ({proc.returncode}): "
                             f"{proc.stderr}")
        records = [tuple(r) for r in json.loads(out.read_text())] if out.exists() else []
    return dt, records


def _load() -> str:
    one, five, _ = os.getloadavg()
    return f"{one:.1f} / {five:.1f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=10, help="timed runs per command")
    parser.add_argument("--cold", action="store_true",
                        help="also time the first run of compute commands (empty kernel cache)")
    parser.add_argument("--baseline", type=Path, default=None,
                        help="another armctl source tree to time alongside (e.g. an earlier "
                             "commit exported with git archive)")
    parser.add_argument("--baseline-label", default="an earlier tree",
                        help="what the baseline tree is, for the document")
    parser.add_argument("--no-write", action="store_true", help="print, do not write the doc")
    args = parser.parse_args()

    trees = [ROOT] + ([args.baseline.resolve()] if args.baseline else [])
    names = ["now"] + (["baseline"] if args.baseline else [])
    load_before = _load()
    times = warm(trees, args.runs)
    load_after = _load()
    cpus = os.cpu_count()

    head = ["command", *(f"{n} median [s]" for n in names), *(f"{n} fastest [s]" for n in names),
            "target [s]"]
    lines = ["## Start-up", "",
             f"Warm: {args.runs} runs per command after one warm-up run, interleaved"
             + (f" with the baseline tree ({args.baseline_label})" if args.baseline else "")
             + f"; {cpus} CPUs, load average (1 / 5 min) {load_before} before, {load_after} "
             "after. Each run is a new interpreter running `from armctl.cli import main` with "
             "the arguments (what the `armctl` script does).", "",
             "| " + " | ".join(head) + " |", "|" + "---|" * len(head)]
    for ci, (argv, target) in enumerate(WARM):
        med = [statistics.median(times[(ti, ci)]) for ti in range(len(trees))]
        best = [min(times[(ti, ci)]) for ti in range(len(trees))]
        row = [f"`armctl {' '.join(argv)}`", *(f"{m:.3f}" for m in med),
               *(f"{b:.3f}" for b in best), f"{target:g}" if target else "-"]
        lines.append("| " + " | ".join(row) + " |")
        print(" ".join(row), flush=True)

    if args.cold:
        lines += ["", "First run (an empty numba cache, as after installing): wall time, the "
                  "kernels compiled and the three that cost the most compile time of their own "
                  f"(load average before: {_load()}). Compile times vary by half or more with "
                  "the load of a shared machine; the kernel counts do not.", "",
                  "| tree | command | wall [s] | kernels compiled | compiling [s] | costliest "
                  "(own s) |", "|---|---|---|---|---|---|"]
        for argv in COLD:
            for name, tree in zip(names, trees, strict=True):
                wall, records = cold(tree, argv)
                total = sum(r[2] for r in records)  # own times: nested ones not twice
                top = sorted(records, key=lambda r: -r[2])[:3]
                top_text = ", ".join(f"{r[0].rsplit('.', 1)[-1]} {r[2]:.1f}" for r in top)
                row = [name, f"`armctl {' '.join(argv)}`", f"{wall:.1f}", str(len(records)),
                       f"{total:.1f}", top_text or "-"]
                lines.append("| " + " | ".join(row) + " |")
                print(" ".join(row), flush=True)

    md = "\n".join(lines)
    if args.no_write:
        print(md)
        return
    argv = sys.argv[1:]
    if args.baseline:  # the tree's path is this machine's: the document names it TREE
        argv = ["TREE" if a == str(args.baseline) else a for a in argv]
        argv = [a.replace(str(args.baseline), "TREE") if a.startswith("--baseline=") else a
                for a in argv]
    cmd = "python tools/bench_startup.py " + " ".join(
        f"'{a}'" if " " in a else a for a in argv)
    print(write_section("startup", md, cmd.strip()))


if __name__ == "__main__":
    main()
