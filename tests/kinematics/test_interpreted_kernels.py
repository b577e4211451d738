"""The kernels run by the interpreter give the compiled kernels' results, to the bit.

A process that computes a few poses uses the interpreted kernels (no numba to load); every
other use compiles them. Both must agree exactly, or a command's output would depend on what
else the process had loaded.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numpy as np
import pytest
from armctl_testpaths import BUNDLED, CONFIGS

import armctl
from armctl.kinematics import _kernels
from armctl.kinematics import model as model_module


@pytest.mark.parametrize("name", BUNDLED)
def test_interpreted_kernels_equal_the_compiled_ones(name: str) -> None:
    arm = armctl.load_arm(CONFIGS / f"{name}.yaml")
    t = arm.tree
    rng = np.random.default_rng(7)
    for q in arm.sample(rng, 5):
        q = np.ascontiguousarray(q)
        want = _kernels.fk_all(q, t.joints, t.parent, t.anchor, t.frames)
        got = _kernels.interpreted("fk_all")(q, t.joints, t.parent, t.anchor, t.frames)
        assert np.array_equal(got, want)
        for frame in (arm.tool, arm.frame_names[len(arm.frame_names) // 2]):
            rows, idx = arm._chain_of(arm.frame_index(frame))
            assert np.array_equal(_kernels.interpreted("chain_fk")(q, rows, idx),
                                  _kernels.chain_fk(q, rows, idx))
            assert np.array_equal(_kernels.interpreted("chain_jacobian")(q, rows, idx, arm.nv),
                                  _kernels.chain_jacobian(q, rows, idx, arm.nv))


def test_an_unknown_kernel_is_an_attribute_error() -> None:
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        _kernels.nonexistent  # noqa: B018
    with pytest.raises(AttributeError, match="no kernel 'nonexistent'"):
        _kernels.interpreted("nonexistent")


def test_the_compiled_kernels_take_over_after_a_few_calls() -> None:
    # in a fresh interpreter: numba is not loaded until the single-pose calls run out
    code = f"""\
import json, sys
import numpy as np
import armctl
from armctl.kinematics import model
arm = armctl.load_arm("ur5e")
seen = []
for i in range({model_module._INTERPRETED_CALLS} + 2):
    arm.fk(np.full(6, 0.1 * i))
    seen.append("numba" in sys.modules)
print(json.dumps({{"seen": seen, "module": type(model.K).__name__}}))
"""
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    out = json.loads(proc.stdout.strip().splitlines()[-1])
    n = model_module._INTERPRETED_CALLS
    assert out["seen"][:n] == [False] * n  # interpreted: numba not imported
    assert out["seen"][n:] == [True, True]  # then the compiled kernels
    assert out["module"] == "module"  # the stand-in has given way to the kernel module


def test_a_batch_always_uses_the_compiled_kernels() -> None:
    code = """\
import json, sys
import numpy as np
import armctl
arm = armctl.load_arm("ur5e")
arm.fk_batch(np.zeros((3, 6)))
print(json.dumps("numba" in sys.modules))
"""
    env = {k: v for k, v in os.environ.items() if not k.startswith("NUMBA_")}
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True, env=env,
                          timeout=300)
    assert proc.returncode == 0, proc.stderr
    assert json.loads(proc.stdout.strip().splitlines()[-1]) is True
