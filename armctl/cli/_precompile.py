"""Compile the numerical kernels before the first command needs them.

numba compiles each kernel for the argument types of its first call and caches the machine code
beside the source (``__pycache__``), keyed by the source's content (numba 0.68 and later), so a
cache made while the package is built stays valid where it is installed. This module runs the
commands that compute, on the built-in simulated bus and moving nothing, so that every kernel
they call is compiled for the argument types they call it with. The package's build
(``setup.py``) runs it in a few processes at once, one per group of commands::

    python -m armctl.cli._precompile [GROUP ...]     # groups: numeric, analytic (default: all)

A command that fails here is reported and the others still run (the cache only saves time).
"""

from __future__ import annotations

import contextlib
import io
import os
import sys
import tempfile
import time
from collections.abc import Sequence
from pathlib import Path

__all__ = ["GROUPS", "KEYFRAMES", "main", "run_group"]

#: A keyframe program for ``play``: joint and pose keyframes (the two kinds play solves).
KEYFRAMES = """\
armctl_keyframes: 1
arm: so101
units: {angle: deg, length: m}
joints: [shoulder_pan, shoulder_lift, elbow_flex, wrist_flex, wrist_roll]
keyframes:
- {name: start, q: [0, -30, 60, 20, 0], dwell: 0.1}
- {name: above, pose: {xyz: [0.22, 0.0, 0.12]}}
- {name: down, pose: {xyz: [0.2, 0.0, 0.05], rpy: [180, 0, 180]}}
"""

#: A scene with a box obstacle beside the SO-101, for the commands that check it.
_SCENE = """\
armctl: 1
padding: 0.005
obstacles:
  - {name: post, shape: box, size: [0.04, 0.04, 0.3], origin: {xyz: [0.342, -0.187, 0.15]}}
"""

_POSE_UR = ("--xyz", "0.4", "0.1", "0.4", "--rpy", "3.14159", "0", "0")
_POSE_PANDA = ("--xyz", "0.4", "0.1", "0.4", "--rpy", "3.14159", "0", "0")
_DOWN = ("--xyz", "0.2", "0.0", "0.05", "--direction", "z", "0", "0", "-1")

#: Command lines by group; ``{keys}`` and ``{scene}`` are replaced by the paths of a keyframe
#: file and a scene file. The groups take about the same time to compile, so that two processes
#: finish together.
GROUPS: dict[str, tuple[tuple[str, ...], ...]] = {
    "numeric": (
        ("ik", "so101", "--xyz", "0.2", "0", "0.15"),
        ("ik", "so101", *_DOWN),
        *(("ik", "so101", "--xyz", "0.2", "0", "0.15", "--solver", s)
          for s in ("dls", "pinv", "jt", "ccd", "ccd-jt")),
        ("move-to-pose", "so101", "--xyz", "0.2", "0", "0.15", "--dry-run"),
        ("move-to-pose", "so101", *_DOWN, "--dry-run"),
        ("move-to-pose", "so101", "--xyz", "0.2", "0", "0.15", "--linear", "--dry-run"),
        ("move-joints", "so101", "0", "-30", "60", "20", "0", "0", "--deg", "--dry-run"),
        ("play", "{keys}", "so101", "--dry-run"),
        ("move-joints", "so101", "1", "0", "0", "0", "0", "0", "--scene", "{scene}", "--plan",
         "--plan-time", "1", "--dry-run"),
        ("collisions", "so101"),
        ("collisions", "so101", "--generate", "--samples", "100"),
        ("status", "so101", "--once", "--sim"),
        ("teleop", "so101_leader", "so101", "--sim", "--duration", "0.3"),
    ),
    "analytic": (
        ("ik", "ur5e", *_POSE_UR, "--solver", "analytic", "--all"),
        ("ik", "ur5e", *_POSE_UR, "--solver", "analytic"),
        ("ik", "so101", *_DOWN, "--solver", "analytic", "--all"),
        ("ik", "omx", "--xyz", "0.2", "0", "0.1", "--direction", "x", "1", "0", "0",
         "--solver", "analytic", "--all"),
        ("ik", "wx250s", "--xyz", "0.3", "0", "0.2", "--rpy", "0", "0", "0",
         "--solver", "analytic", "--all"),
        ("ik", "panda", *_POSE_PANDA, "--solver", "analytic", "--all"),
        ("ik", "ur5e", *_POSE_UR),  # auto: numerical, then the closed form
        # an arm with ball joints: the multi-DOF kernels, tangent-space IK, their collisions
        ("ik", "figure", "--xyz", "0.4", "-0.25", "1.15"),
        ("collisions", "figure"),
    ),
}


def _kinematics() -> None:
    """The kinematics calls of commands this module cannot run in a build.

    ``workspace`` and ``render`` (the plotting extra) call the batched forward kinematics, and
    the NLP solver (casadi) checks its answers with all frames' poses; the compiled kernels
    take over once numba is loaded (by the commands before).
    """
    import numpy as np

    import armctl

    rng = np.random.default_rng(0)
    for name in ("so101", "ur5e", "figure"):
        arm = armctl.load_arm(name)
        qs = arm.sample(rng, 8)
        arm.fk_batch(qs)
        arm.jacobian_batch(qs)
        for q in qs:
            arm.fk_all(q)
            arm.fk_frames(q)
            arm.fk(q)
            arm.jacobian(q)
            arm.fk_jacobian(q)


def run_group(name: str, files: dict[str, Path]) -> list[str]:
    """Run the commands of group ``name`` (their output discarded).

    Args:
        name: A key of :data:`GROUPS`.
        files: The files that stand for ``{keys}`` and ``{scene}`` in the command lines.

    Returns:
        One line per command that failed (empty when all ran).
    """
    from armctl.cli import main as cli_main
    from armctl.kinematics.compile_progress import compile_records

    failed: list[str] = []
    for argv in GROUPS[name]:
        before = len(compile_records())  # the command line starts the records
        args = [str(files[a[1:-1]]) if a in ("{keys}", "{scene}") else a for a in argv]
        t = time.perf_counter()
        out = io.StringIO()
        try:
            with contextlib.redirect_stdout(out), contextlib.redirect_stderr(out):
                code = cli_main(args)
        except BaseException as exc:  # one command's failure must not stop the others
            code = -1
            out.write(f"{type(exc).__name__}: {exc}")
        # exit 3 (no solution) still compiled what the solver needed
        status = "ok" if code in (0, 3) else f"exit {code}"
        compiled = len(compile_records()) - before
        print(f"precompile {name}: armctl {' '.join(args)}: {status} "
              f"({time.perf_counter() - t:.1f} s, {compiled} kernels compiled)",
              file=sys.stderr, flush=True)
        if status != "ok":
            failed.append(f"armctl {' '.join(args)}: {status}: {out.getvalue()[-500:]}")
    if name == "numeric":
        before, t = len(compile_records()), time.perf_counter()
        try:
            _kinematics()
        except Exception as exc:  # reported like a command's failure
            failed.append(f"kinematics calls: {type(exc).__name__}: {exc}")
        print(f"precompile {name}: kinematics calls ({time.perf_counter() - t:.1f} s, "
              f"{len(compile_records()) - before} kernels compiled)", file=sys.stderr,
              flush=True)
    return failed


def main(argv: Sequence[str] | None = None) -> int:
    """Run the named groups (all without names); 0 if every command ran, else 1."""
    names = list(sys.argv[1:] if argv is None else argv) or list(GROUPS)
    unknown = [n for n in names if n not in GROUPS]
    if unknown:
        print(f"precompile: unknown group(s) {unknown}; the groups are {sorted(GROUPS)}",
              file=sys.stderr)
        return 2
    failed: list[str] = []
    with tempfile.TemporaryDirectory(prefix="armctl-precompile-") as tmp:
        os.environ["ARMCTL_HOME"] = tmp  # calibrations of the simulated arms go here
        files = {"keys": Path(tmp) / "keys.yaml", "scene": Path(tmp) / "scene.yaml"}
        files["keys"].write_text(KEYFRAMES, encoding="utf-8")
        files["scene"].write_text(_SCENE, encoding="utf-8")
        cwd = os.getcwd()
        os.chdir(tmp)
        try:
            for name in names:
                failed += run_group(name, files)
        finally:
            os.chdir(cwd)
    for line in failed:
        print(f"precompile: failed: {line}", file=sys.stderr)
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
