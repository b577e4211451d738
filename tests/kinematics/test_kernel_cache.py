"""The kernel cache the build makes is used where the package is installed, and compiles report.

The build (setup.py) compiles the kernels into the package's ``__pycache__`` folders; pip then
writes the files elsewhere, with new modification times. numba keys its cache by the source's
content, so the copy must load without compiling. A compile on an empty cache says so.
"""

from __future__ import annotations

import json
import os
import shutil
import subprocess
import sys
from pathlib import Path
from typing import Any

from armctl_testpaths import REPO

_SCRIPT = """\
import json, logging, sys
from armctl.kinematics import compile_progress as cp
logging.basicConfig(level=logging.INFO, stream=sys.stderr, format="%(message)s")
cp.report_compiles(delay=0.05, every=30.0)
import numpy as np
import armctl
from armctl.kinematics import _kernels
arm = armctl.load_arm("ur5e")
t = arm.tree
q = np.array([0.1, -0.2, 0.3, -0.4, 0.5, -0.6])
poses = _kernels.fk_all(q, t.joints, t.parent, t.anchor, t.frames)
print(json.dumps({"file": armctl.__file__, "poses": poses.tolist(),
                  "compiled": [r.name for r in cp.compile_records()]}))
"""


def _run(root: Path) -> tuple[dict[str, Any], str]:
    env = {k: v for k, v in os.environ.items()
           if not k.startswith("NUMBA_") and k != "PYTHONPATH"}
    proc = subprocess.run([sys.executable, "-c", _SCRIPT], cwd=root, env=env,
                          capture_output=True, text=True, timeout=300)
    assert proc.returncode == 0, proc.stderr
    out: dict[str, Any] = json.loads(proc.stdout.strip().splitlines()[-1])
    assert Path(out["file"]).resolve().is_relative_to(root.resolve()), out["file"]
    return out, proc.stderr


def test_a_cache_built_in_one_folder_loads_from_another(tmp_path: Path) -> None:
    built, installed = tmp_path / "build", tmp_path / "site"
    shutil.copytree(REPO / "armctl", built / "armctl",
                    ignore=shutil.ignore_patterns("__pycache__"))
    first, err = _run(built)
    assert any(n.endswith("._kernels.fk_all") for n in first["compiled"]), first["compiled"]
    # a compile on an empty cache says so (the command line shows these lines on stderr)
    assert "compiling the numerical kernels for" in err, err
    assert "numerical kernels in" in err, err
    assert list((built / "armctl" / "kinematics" / "__pycache__").glob("_kernels.fk_all-*.nbi"))

    # as pip installs a wheel: the same files, written anew elsewhere (new modification times)
    shutil.copytree(built / "armctl", installed / "armctl", copy_function=shutil.copyfile)
    src = installed / "armctl" / "kinematics" / "_kernels.py"
    os.utime(src, (src.stat().st_atime + 3600, src.stat().st_mtime + 3600))
    second, err = _run(installed)
    assert second["compiled"] == []  # loaded from the copied cache
    assert "compiling" not in err, err
    assert second["poses"] == first["poses"]

