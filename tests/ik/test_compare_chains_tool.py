"""tools/compare_ik_chains.py: its chains, its measures and a smoke run of the whole study."""

from __future__ import annotations

import importlib.util
import math
import sys
from pathlib import Path

import numpy as np
import pytest
from armctl_testpaths import REPO


def _tool():  # type: ignore[no-untyped-def]
    sys.path.insert(0, str(REPO / "tools"))  # the tool imports its neighbour _benchdoc
    spec = importlib.util.spec_from_file_location("compare_ik_chains",
                                                  REPO / "tools" / "compare_ik_chains.py")
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules[spec.name] = module  # its dataclasses look their module up
    spec.loader.exec_module(module)
    return module


T = _tool()


@pytest.mark.parametrize("n, planar", [(4, True), (10, False), (40, False)])
def test_a_generated_chain_has_reach_one_metre(tmp_path: Path, n: int, planar: bool) -> None:
    arm = T.chain(n, planar, tmp_path)
    assert arm.dof == n
    assert np.allclose(arm.fk(np.zeros(n))[:3, 3], [1.0, 0.0, 0.0])  # stretched along x
    axes = {tuple(arm.tree.joint_axis(j)) for j in range(n)}
    assert axes == ({(0.0, 0.0, 1.0)} if planar else
                    {(0.0, 0.0, 1.0), (0.0, 1.0, 0.0), (1.0, 0.0, 0.0)})
    rng = np.random.default_rng(0)
    tips = np.array([arm.fk(q)[:3, 3] for q in arm.sample(rng, 200)])
    assert np.linalg.norm(tips, axis=1).max() <= 1.0 + 1e-12
    if planar:
        assert np.allclose(tips[:, 2], 0.0)


def test_evenness_is_per_solve_and_the_tip_share_is_the_last_five() -> None:
    runs = T.Runs()
    runs.add(True, 3, 0.001, np.ones(10), 0.0)  # every joint alike
    runs.add(True, 3, 0.001, np.r_[np.zeros(9), 2.0], 0.0)  # the tip joint alone
    runs.add(False, 3, 0.001, np.zeros(10), 0.0)  # did not move
    assert runs.even[0] == pytest.approx(1.0) and runs.distal[0] == pytest.approx(0.5)
    assert runs.even[1] == pytest.approx(0.0) and runs.distal[1] == pytest.approx(1.0)
    assert math.isnan(runs.even[2]) and runs.moved[2] == 0.0
    assert runs.rate() == pytest.approx(200 / 3)


def test_the_fixed_gain_is_stable_at_the_stretched_chain(tmp_path: Path) -> None:
    arm = T.chain(10, False, tmp_path)
    alpha = T.fixed_gain(arm)["jt_gain"]
    jac = arm.jacobian(np.zeros(10)).copy()
    jac[3:] *= math.sqrt(2.0) * 0.25 * arm.tree.max_reach
    assert alpha * np.linalg.eigvalsh(jac @ jac.T)[-1] == pytest.approx(1.0)


def test_the_quick_study_runs_and_reports_every_claim(capsys: pytest.CaptureFixture[str]) -> None:
    assert T.main(["--quick", "--no-write"]) == 0
    out = capsys.readouterr().out
    for claim in ("cheap per step", "CCD converges faster than J^T", "spreads motion evenly",
                  "no trouble with singularities", "complement each other",
                  "fewer steps than CCD", "trouble near a singular J", "Ker(J^T)",
                  "weights w1, w2", "fixed gain"):
        assert claim in out
    assert "| 10 | spatial | on its line |" in out
