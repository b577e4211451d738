"""Build step: compile armctl's numerical kernels into the package while it is built.

The project is described in pyproject.toml; this file adds one step to ``build_py``. After the
sources are copied to the build directory, ``python -m armctl.cli._precompile`` runs there (two
groups of commands in parallel processes), so numba writes its cache of every kernel the commands
use into the build directory's ``__pycache__`` folders, and the wheel carries it. numba keys
the cache by the source file's content, the Python version, numba's version and the CPU, so it
is valid where the wheel is installed on the machine that built it (``pip install .``); anywhere
else numba compiles on first use as without it.

The cache of the source tree is copied into the build directory first and the result back into
the source tree afterwards, so a second build, and the tests run from the source tree, find
the kernels compiled. Set ``ARMCTL_PRECOMPILE=0`` to skip the step. A failure of the step is
reported and the build goes on (the cache only saves time).
"""

from __future__ import annotations

import hashlib
import os
import pickle
import shutil
import subprocess
import sys
import time
from pathlib import Path

from setuptools import setup
from setuptools.command.build_py import build_py

ROOT = Path(__file__).resolve().parent
GROUPS = ("analytic", "numeric")  # armctl/cli/_precompile.py: the longest first
TIMEOUT = 1800.0  # [s] per process: a stuck one must not hold the build forever


def _fresh_files(index: Path) -> list[Path]:
    """The index ``index`` and its data files if they hold the present source, else none.

    numba's index is its version (pickled), then the pickled source stamp (numba 0.68 on: the
    SHA-256 digest of the source file) and a map from signatures to data files; an index of an
    older source, or of another numba, is left out (its data files would only fill the wheel).
    """
    try:
        import numba

        with open(index, "rb") as f:
            if pickle.load(f) != numba.__version__:
                return []
            stamp, overloads = pickle.loads(f.read())
        module = index.name.split(".", 1)[0]  # <module>.<qualname>-<line>.pyXY.nbi
        source = (index.parent.parent / f"{module}.py").read_bytes()
        if stamp != hashlib.sha256(source).digest():
            return []
        return [index, *(index.parent / name for name in overloads.values())]
    except Exception:  # unreadable, or another layout: not copied (it only saves time)
        return []


def _copy_caches(src: Path, dst: Path, only_fresh: bool) -> int:
    """Copy numba's cache files of package ``src`` into the same folders under ``dst``."""
    n = 0
    for index in src.rglob("__pycache__/*.nbi"):
        files = _fresh_files(index) if only_fresh else [
            index, *index.parent.glob(index.name[:-len(".nbi")] + ".*.nbc")]
        for f in files:
            target = dst / f.relative_to(src)
            try:
                target.parent.mkdir(parents=True, exist_ok=True)
                shutil.copyfile(f, target)
                n += 1
            except OSError:
                pass  # a missing data file, a read-only tree: the cache only saves time
    return n


def precompile(lib: Path) -> None:
    """Fill numba's cache of the package copied to ``lib`` (the build directory)."""
    source, built = ROOT / "armctl", lib / "armctl"
    if built != source:
        for old in built.rglob("__pycache__/*.nb[ic]"):  # an earlier build's
            old.unlink()
        _copy_caches(source, built, only_fresh=True)
    env = dict(os.environ)
    env.pop("NUMBA_CACHE_DIR", None)  # the cache goes beside the built sources
    env["PYTHONPATH"] = os.pathsep.join([str(lib), *filter(None, [env.get("PYTHONPATH")])])
    t = time.perf_counter()
    print("armctl: compiling the numerical kernels (about a minute; ARMCTL_PRECOMPILE=0 "
          "skips this)", flush=True)
    procs = [subprocess.Popen([sys.executable, "-m", "armctl.cli._precompile", group],
                              env=env, cwd=lib, stdout=subprocess.PIPE,
                              stderr=subprocess.STDOUT, text=True)
             for group in GROUPS]
    for group, proc in zip(GROUPS, procs, strict=True):
        try:
            out, _ = proc.communicate(timeout=TIMEOUT)
        except subprocess.TimeoutExpired:
            proc.kill()
            out, _ = proc.communicate()
        sys.stdout.write(out)
        if proc.returncode != 0:
            print(f"armctl: WARNING: precompiling group {group!r} failed (exit "
                  f"{proc.returncode}); those kernels compile on first use instead", flush=True)
    # Processes that compiled one kernel for different argument types at once may have kept
    # only one of them in its index: one more pass in one process compiles what is missing.
    try:
        check = subprocess.run([sys.executable, "-m", "armctl.cli._precompile", *GROUPS],
                               env=env, cwd=lib, stdout=subprocess.PIPE,
                               stderr=subprocess.STDOUT, text=True, timeout=TIMEOUT)
        sys.stdout.write(check.stdout)
    except subprocess.TimeoutExpired:
        print("armctl: WARNING: the last precompile pass timed out", flush=True)
    print(f"armctl: kernels compiled in {time.perf_counter() - t:.0f} s", flush=True)
    if built != source:
        _copy_caches(built, source, only_fresh=False)


class BuildPyWithKernels(build_py):
    """``build_py``, then numba's cache of the kernels in the build directory."""

    def run(self) -> None:
        """Copy the sources, then compile the kernels beside them (unless switched off)."""
        super().run()
        if os.environ.get("ARMCTL_PRECOMPILE", "1") == "0":
            return
        # an editable install runs the source tree: its cache is the one to fill
        lib = ROOT if getattr(self, "editable_mode", False) else Path(self.build_lib)
        try:
            precompile(lib)
        except Exception as exc:  # the build goes on; kernels then compile on first use
            print(f"armctl: WARNING: precompiling the kernels failed: {exc}", flush=True)


setup(cmdclass={"build_py": BuildPyWithKernels})
