"""Benchmark: how long armctl commands take from the shell, warm and on the first run.

Warm: each command runs once to warm the caches (not counted), then ``--runs`` times; the
median and the fastest run are reported, with the machine's load average. With ``--baseline
TREE`` (another source tree of armctl, e.g. an export of an earlier commit) its runs are
interleaved with this checkout's, so both see the same load.

Cold (``--cold``): each compute command runs once with an empty numba cache (a fresh
``NUMBA_CACHE_DIR``), as the first command after installing does; the kernels compiled, their
total compile time and the costliest ones are listed.

Installed (``--install``): the tree's files (no caches, no ``.git``) are copied to a scratch
folder and installed with ``pip install`` into a new virtual environment (the time of that is
reported: pip's own download cache is used for the dependencies); then each command of
``FIRST`` runs as the first command after that install (the package's kernel cache is put back
as the install left it before each), with the kernels it compiled.

Every command runs in a new interpreter as the ``armctl`` script does (``from armctl.cli
import main``); the interpreter's own start is part of the time. A run without ``--cold`` and
``--install`` keeps the document's first-run tables (naming the command that made them).

Usage: python tools/bench_startup.py [--runs N] [--cold] [--install] [--baseline TREE]
[--no-write]
Writes the "startup" section of docs/benchmarks.md.
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
from _benchdoc import write_section

from armctl.cli._precompile import KEYFRAMES  # the keyframe program its first runs play

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

#: One command of each verb that computes, timed as the first after installing (``--install``);
#: ``{keys}`` is a keyframe file for ``play``.
FIRST = (
    ["fk", "ur5e", "0", "0", "0", "0", "0", "0"],
    ["ik", "so101", "--xyz", "0.2", "0", "0.15"],
    ["ik", "ur5e", "--xyz", "0.4", "0.1", "0.4", "--rpy", "3.14159", "0", "0", "--solver",
     "analytic", "--all"],
    ["move-to-pose", "so101", "--xyz", "0.2", "0", "0.15", "--dry-run"],
    ["move-joints", "so101", "0", "-30", "60", "20", "0", "0", "--deg", "--dry-run"],
    ["play", "{keys}", "so101", "--dry-run"],
    ["collisions", "so101", "--generate", "--samples", "200"],
    ["status", "so101", "--once", "--sim"],
    ["teleop", "so101_leader", "so101", "--sim", "--duration", "0.3"],
    ["move-to-pose", "so101", "--xyz", "0.2", "0.0", "0.05", "--direction", "z", "0", "0", "-1"],
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


#: Runs of a command that failed are repeated this many times (the simulated servos of a
#: dry run can miss a reply on a machine loaded far beyond its cores); then the bench stops.
RETRIES = 2


def run_once(tree: Path, argv: list[str]) -> float:
    """Wall time of one command [s] (its output discarded); raises if it fails."""
    for attempt in range(RETRIES + 1):
        t = time.perf_counter()
        proc = subprocess.run([sys.executable, "-c", _DRIVER, *argv], env=_env(tree),
                              cwd=tree, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                              text=True)
        dt = time.perf_counter() - t
        if proc.returncode == 0:
            return dt
        print(f"armctl {' '.join(argv)} failed ({proc.returncode}), attempt {attempt + 1}: "
              f"{proc.stderr[-500:]}", flush=True)
    raise SystemExit(f"armctl {' '.join(argv)} failed ({proc.returncode}): {proc.stderr}")


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
    for attempt in range(RETRIES + 1):
        with tempfile.TemporaryDirectory(prefix="armctl-numba-") as cache:
            out = Path(cache) / "compiles.json"
            t = time.perf_counter()
            proc = subprocess.run([sys.executable, "-c", _COLD_DRIVER, str(out), *argv],
                                  env=_env(tree, str(Path(cache) / "kernels")), cwd=tree,
                                  stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            dt = time.perf_counter() - t
            if proc.returncode == 0:
                records = json.loads(out.read_text()) if out.exists() else []
                return dt, [tuple(r) for r in records]
        print(f"armctl {' '.join(argv)} failed ({proc.returncode}), attempt {attempt + 1}: "
              f"{proc.stderr[-500:]}", flush=True)
    raise SystemExit(f"armctl {' '.join(argv)} failed ({proc.returncode}): {proc.stderr}")


_NOT_COPIED = shutil.ignore_patterns(".git", "__pycache__", "build", "dist", "*.egg-info",
                                     ".venv", ".mypy_cache", ".ruff_cache", ".pytest_cache",
                                     ".hypothesis", "*.nbi", "*.nbc", "*.pyc")


def _caches(package: Path) -> list[Path]:
    return [f for f in package.rglob("__pycache__/*") if f.suffix in (".nbi", ".nbc")]


def installed(tree: Path) -> tuple[float, float | None, list[tuple[str, float, int, int]]]:
    """Install ``tree`` into a new venv; then each command of FIRST as the first one.

    Returns:
        The install's wall time [s], the kernel compile time the build reported [s] (None if
        it reported none), and (command, wall time [s], kernels compiled, exit code) per
        command.
    """
    rows: list[tuple[str, float, int, int]] = []
    with tempfile.TemporaryDirectory(prefix="armctl-install-") as tmp:
        work = Path(tmp)
        src = work / "src"
        shutil.copytree(tree, src, ignore=_NOT_COPIED)
        subprocess.run([sys.executable, "-m", "venv", str(work / "venv")], check=True)
        py = str(work / "venv" / "bin" / "python")
        env = {k: v for k, v in os.environ.items()
               if not k.startswith(("NUMBA_", "PYTHON", "VIRTUAL_ENV", "ARMCTL_"))}
        env["ARMCTL_HOME"] = str(work / "home")
        t = time.perf_counter()
        proc = subprocess.run([py, "-m", "pip", "install", "-v", str(src)], env=env,
                              cwd=work, capture_output=True, text=True)
        install = time.perf_counter() - t
        if proc.returncode != 0:
            raise SystemExit(f"pip install {tree} failed: {proc.stdout[-3000:]}"
                             f"{proc.stderr[-3000:]}")
        compiled = re.search(r"armctl: kernels compiled in (\d+) s", proc.stdout + proc.stderr)
        package = Path(subprocess.run([py, "-c", "import armctl, os; print(os.path.dirname("
                                       "armctl.__file__))"], env=env, cwd=work, check=True,
                                      capture_output=True, text=True).stdout.strip())
        snapshot = work / "snapshot"
        for f in _caches(package):
            (snapshot / f.relative_to(package)).parent.mkdir(parents=True, exist_ok=True)
            shutil.copy2(f, snapshot / f.relative_to(package))
        keys = work / "keys.yaml"
        keys.write_text(KEYFRAMES, encoding="utf-8")
        for argv in FIRST:
            for f in _caches(package):  # the cache as the install left it
                f.unlink()
            if snapshot.exists():
                shutil.copytree(snapshot, package, dirs_exist_ok=True)
            args = [str(keys) if a == "{keys}" else a for a in argv]
            out = work / "compiles.json"
            t = time.perf_counter()
            run = subprocess.run([py, "-c", _COLD_DRIVER, str(out), *args], env=env, cwd=work,
                                 stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
            dt = time.perf_counter() - t
            if run.returncode not in (0, 3):  # 3: no solution (still a computed answer)
                print(f"  armctl {' '.join(args)} failed ({run.returncode}): "
                      f"{run.stderr[-2000:]}", flush=True)
            records = json.loads(out.read_text()) if out.exists() else []
            rows.append((" ".join(argv).replace("{keys}", "KEYS.yaml"), dt, len(records),
                         run.returncode))
            print(f"  {rows[-1][0]}: {dt:.1f} s, {len(records)} kernels compiled, exit "
                  f"{run.returncode}", flush=True)
    return install, float(compiled.group(1)) if compiled else None, rows


def _kept_first_runs() -> list[str]:
    """The first-run tables of the document's last ``--cold``/``--install`` run, with its command.

    A run of the warm table alone (a few minutes less than one with first runs) keeps them.
    """
    from _benchdoc import DOC

    text = DOC.read_text(encoding="utf-8") if DOC.exists() else ""
    match = re.search(r"<!-- bench:startup -->(.*?)<!-- /bench:startup -->", text, re.S)
    if match is None:
        return []
    section = match.group(1)
    produced = re.search(r"\nProduced by `([^`]*)` on (\S+)", section)
    kept = section.find("\nThe tables of first runs below")
    if kept >= 0 and produced is not None:  # kept once already: with its own command
        return ["", section[kept:produced.start()].strip()]
    start = min((i for i in (section.find("\nFirst run"), section.find("\nFirst command"))
                 if i >= 0), default=-1)
    if start < 0 or produced is None:
        return []
    body = section[start:produced.start()].strip()
    return ["", f"The tables of first runs below are those of `{produced.group(1)}` on "
            f"{produced.group(2)}.", "", body]


def _load() -> str:
    one, five, _ = os.getloadavg()
    return f"{one:.1f} / {five:.1f}"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--runs", type=int, default=10, help="timed runs per command")
    parser.add_argument("--cold", action="store_true",
                        help="also time the first run of compute commands (empty kernel cache)")
    parser.add_argument("--install", action="store_true",
                        help="also time each compute command as the first after a fresh "
                             "'pip install' into a new virtual environment")
    parser.add_argument("--baseline", type=Path, default=None,
                        help="another armctl source tree to time alongside (e.g. an earlier "
                             "commit exported with git archive)")
    parser.add_argument("--baseline-label", default="an earlier tree",
                        help="what the baseline tree is, for the document")
    parser.add_argument("--no-write", action="store_true", help="print, do not write the doc")
    args = parser.parse_args()

    # the arms' calibrations of this user would apply to the bundled arms: none here
    os.environ["ARMCTL_HOME"] = tempfile.mkdtemp(prefix="armctl-bench-home-")
    trees = [ROOT] + ([args.baseline.resolve()] if args.baseline else [])
    names = ["now"] + (["baseline"] if args.baseline else [])
    load_before = _load()
    times = warm(trees, args.runs) if args.runs > 0 else {}
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
    for ci, (argv, target) in enumerate(WARM if times else ()):
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

    if args.install:
        lines += ["", "First command after installing: this tree copied without caches and "
                  "installed with `pip install` into a new virtual environment (dependencies "
                  "from pip's download cache), then each command as the first one after that "
                  "install (the package's cache put back as the install left it before each; "
                  f"load average before: {_load()}). A tree whose build compiles nothing "
                  "starts with an empty cache: its first runs are the cold runs above.", "",
                  "How: the build compiles the kernels (`setup.py` runs the commands of "
                  "`armctl/cli/_precompile.py` in two processes, then once more in one to "
                  "fill in what a race between the two left out) and the wheel carries numba's "
                  "cache, which numba 0.68 keys by the source file's content, not its "
                  "modification time, so it holds where pip writes the files. Compiling at the "
                  "first use cannot meet 10 s on two cores: the analytic solver alone compiles "
                  "about 200 kernels in 40-60 s on a quiet machine (the cold runs above), and "
                  "LLVM's share of that is about a third (numba's typing and lowering the rest), "
                  "so neither two processes nor fewer optimisation passes would bring it under "
                  "10 s.", ""]
        results = []  # this tree only: the baseline's first runs are its cold runs above
        for name, tree in zip(names[:1], trees[:1], strict=True):
            print(f"installing {name} ({tree})", flush=True)
            results.append((name, *installed(tree)))
        for name, install, compiling, _ in results:
            lines.append(f"- {name}: `pip install` {install:.0f} s"
                         + (f", of which compiling the kernels {compiling:.0f} s"
                            if compiling is not None else " (no compile time reported)"))
        lines += ["", "| command | " + " | ".join(f"{n} wall [s] | {n} kernels compiled"
                                                for n, *_ in results) + " |",
                  "|---|" + "---|---|" * len(results)]
        for i in range(len(FIRST)):
            cells = []
            for _, _, _, rows in results:
                failed = f" (exit {rows[i][3]})" if rows[i][3] not in (0, 3) else ""
                cells += [f"{rows[i][1]:.1f}{failed}", str(rows[i][2])]
            lines.append(f"| `armctl {results[0][3][i][0]}` | " + " | ".join(cells) + " |")

    if times and not args.cold and not args.install:
        lines += _kept_first_runs()
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
