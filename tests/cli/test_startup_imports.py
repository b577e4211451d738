"""What the command line imports before it does its work: which modules, never how long.

Each case runs in a fresh interpreter (this test process has imported everything already) and
lists the heavy third-party packages that ended up in ``sys.modules``.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
from typing import Any

import numpy as np
import pytest

import armctl
from armctl.kinematics import _kernels

#: Heavy packages (numba brings llvmlite and scipy; the vendor SDKs and pyserial talk to ports).
HEAVY = ("numpy", "numba", "llvmlite", "scipy", "casadi", "matplotlib", "serial",
         "dynamixel_sdk", "scservo_sdk", "yaml")

_RUN = """\
import contextlib, io, json, sys
heavy = {heavy!r}
out = io.StringIO()
code = None
with contextlib.redirect_stdout(out):
{body}
loaded = sorted(h for h in heavy if h in sys.modules)
print(json.dumps({{"loaded": loaded, "code": code, "out": out.getvalue()}}))
"""


def _run(body: str) -> dict[str, Any]:
    """Run ``body`` (4-space indented, may set ``code``) in a fresh interpreter."""
    script = _RUN.format(heavy=HEAVY, body=body)
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    proc = subprocess.run([sys.executable, "-c", script], capture_output=True, text=True,
                          env=env, timeout=120)
    assert proc.returncode == 0, proc.stderr
    out: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    return out


def _main(*argv: str) -> dict[str, Any]:
    return _run(f"    from armctl.cli import main\n    code = main({list(argv)!r})")


def test_building_the_parser_imports_nothing_heavy() -> None:
    res = _run("    import armctl.cli\n    armctl.cli.build_parser()")
    assert res["loaded"] == []


def test_top_level_help_imports_nothing_heavy() -> None:
    res = _main("--help")
    assert res["code"] == 0
    assert "move-to-pose" in str(res["out"]) and "info" in str(res["out"])
    assert res["loaded"] == []


def test_a_commands_help_still_lists_its_deferred_arguments() -> None:
    # the goal flags come from the goal types (armctl.ik): added when `ik` is used
    res = _main("ik", "--help")
    assert res["code"] == 0
    for flag in ("--xyz", "--rpy", "--quat", "--direction", "--look-at", "--tol-pos", "--all"):
        assert flag in str(res["out"]), flag


def test_import_armctl_alone_loads_no_arm_machinery() -> None:
    res = _run("    import armctl\n    assert armctl.__version__")
    assert res["loaded"] == []


@pytest.mark.parametrize("arm", ["so101", "ur5e"])
def test_info_does_not_import_the_compiler(arm: str) -> None:
    res = _main("info", arm)
    assert res["code"] == 0
    assert f"arm {arm!r}" in str(res["out"])
    assert "analytic IK family" in str(res["out"])
    for heavy in ("numba", "llvmlite", "casadi", "matplotlib"):
        assert heavy not in res["loaded"], res["loaded"]


@pytest.mark.parametrize(("argv", "shown"), [
    (("arms",), "so101"),
    (("collisions", "so101"), "adjacent"),  # shows the matrix: nothing to compute
    (("ports",), ""),
])
def test_verbs_that_compute_nothing_import_neither_compiler_nor_casadi(
        argv: tuple[str, ...], shown: str) -> None:
    res = _main(*argv)
    assert res["code"] == 0, res
    assert shown in str(res["out"])
    for heavy in ("numba", "llvmlite", "casadi", "matplotlib"):
        assert heavy not in res["loaded"], (argv, res["loaded"])


def test_fk_does_not_import_the_compiler_and_matches_the_compiled_kernels() -> None:
    res = _main("fk", "ur5e", "0.1", "0.2", "0.3", "0.4", "0.5", "0.6", "--json")
    assert res["code"] == 0
    for heavy in ("numba", "llvmlite", "casadi", "matplotlib"):
        assert heavy not in res["loaded"], res["loaded"]
    data = json.loads(str(res["out"]))
    arm = armctl.load_arm("ur5e")
    t = arm.tree
    q = np.array([0.1, 0.2, 0.3, 0.4, 0.5, 0.6])
    pose = _kernels.fk_all(q, t.joints, t.parent, t.anchor, t.frames)[arm.frame_index(arm.tool)]
    # the interpreted kernels do the compiled ones' arithmetic: the same numbers to the bit
    assert data["matrix"] == pose.tolist()


def test_ik_reports_compiles_only_once_numba_is_loaded() -> None:
    body = ("    from armctl.kinematics import compile_progress as cp\n"
            "    cp.report_compiles_once_loaded()\n"
            "    before = 'numba' in sys.modules or cp._installed is not None\n"
            "    import numba\n"
            "    code = [before, cp._installed is not None,\n"
            "            type(numba.__spec__.loader).__name__]")
    res = _run(body)
    before, installed, loader = res["code"]
    assert before is False  # nothing imported numba just to listen to it
    assert installed is True  # the listener is registered once numba is in
    assert loader == "SourceFileLoader"  # and numba keeps its own loader
