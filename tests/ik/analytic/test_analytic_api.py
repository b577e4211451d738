"""``arm.ik_all``, the ``"analytic"`` registry entry and the CLI family line."""

from __future__ import annotations

import json

import numpy as np
import pytest
from analytic_arms import PUMA560, dh_arm

from armctl.arm import load_arm
from armctl.errors import InputError
from armctl.ik import IKStatus, OrientationGoal, PoseGoal, available_solvers


def test_ik_all_lists_2pi_variants_sorted_and_marked() -> None:
    arm = load_arm("ur5e")
    q = np.array([0.4, -1.2, 1.1, -0.5, 0.9, 2.0])
    q_ref = q + 0.1
    sols = arm.ik_all(arm.fk(q), q_ref=q_ref, variants=True)
    dist = np.linalg.norm(sols.q - q_ref, axis=1)
    assert np.all(np.diff(dist) >= 0)  # nearest first
    assert np.allclose(sols.q[0], q, atol=1e-9)
    inside = np.all((sols.q >= arm.lower - 1e-9) & (sols.q <= arm.upper + 1e-9), axis=1)
    assert np.array_equal(inside, sols.within_limits)
    rows = {tuple(np.round(r, 6)) for r in sols.q}
    two_pi = 2 * np.pi
    for r in sols.q:  # every in-range 2*pi shift of every joint is listed too
        for j in range(6):
            for k in (-1, 1):
                v = r[j] + k * two_pi
                if arm.lower[j] <= v <= arm.upper[j]:
                    shifted = r.copy()
                    shifted[j] = v
                    assert tuple(np.round(shifted, 6)) in rows
    assert sols.best is not None and np.allclose(sols.best, sols.valid[0])
    assert not sols.singular and "UR type" in sols.family


def test_limits_mark_solutions_outside() -> None:
    arm = dh_arm("puma", PUMA560, lower=-1.0, upper=1.0)
    q = np.array([0.2, -0.3, 0.4, 0.5, 0.6, -0.7])
    sols = arm.ik_all(arm.fk(q), q_ref=q)
    assert sols.within_limits.sum() >= 1 and (~sols.within_limits).sum() >= 1
    for r, ok in zip(sols.q, sols.within_limits, strict=True):
        assert ok == bool(np.all(np.abs(r) <= 1.0 + 1e-9))


def test_registry_solver_returns_the_nearest_valid_solution() -> None:
    assert "analytic" in available_solvers()
    arm = load_arm("ur5e")
    q = np.array([0.4, -1.2, 1.1, -0.5, 0.9, 2.0])
    res = arm.ik(arm.fk(q), q0=q + 0.2, solver="analytic")
    assert res.success and res.status is IKStatus.CONVERGED and res.solver == "analytic"
    assert np.allclose(res.q, q, atol=1e-9)
    assert res.position_error <= 1e-9 and res.rotation_error <= 1e-9


def test_registry_solver_failures() -> None:
    arm = dh_arm("puma", PUMA560, lower=-0.5, upper=0.5)
    q = np.array([2.5, 2.0, -2.2, 2.6, 1.5, 2.8])  # far outside the narrow limits
    res = arm.ik(arm.fk(q), solver="analytic")
    assert not res.success and res.status is IKStatus.INFEASIBLE
    far = arm.fk(np.zeros(6))
    far[:3, 3] = (5.0, 0.0, 0.0)
    res = arm.ik(far, solver="analytic")
    assert not res.success and res.status is IKStatus.UNREACHABLE
    with pytest.raises(InputError, match="orientation"):
        arm.ik(OrientationGoal(np.eye(3)), solver="analytic")
    with pytest.raises(InputError, match="one goal"):
        arm.ik([PoseGoal(far, frame="tool"), PoseGoal(far, frame="l6")], solver="analytic")


def test_bad_pose_arrays_are_rejected() -> None:
    arm = load_arm("ur5e")
    with pytest.raises(InputError, match="4x4"):
        arm.ik_all(np.eye(3))
    bad = np.eye(4)
    bad[0, 0] = 2.0
    with pytest.raises(InputError, match="rotation"):
        arm.ik_all(bad)


def test_cli_info_shows_the_family(capsys: pytest.CaptureFixture[str]) -> None:
    from armctl.cli import main

    assert main(["info", "ur5e", "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert "UR type" in data["ik_family"]
    assert main(["info", "wx250s"]) == 0
    assert "analytic IK family: spherical wrist" in capsys.readouterr().out


def test_cli_ik_all_lists_every_solution(capsys: pytest.CaptureFixture[str]) -> None:
    from armctl.cli import main

    arm = load_arm("wx250s")
    q = np.array([0.3, -0.2, 0.4, 0.5, 0.6, -0.7, 0.0])
    t = arm.fk(q)
    from armctl.spatial import matrix_to_rpy

    xyz = [f"{v:.12f}" for v in t[:3, 3]]
    rpy = [f"{v:.12f}" for v in matrix_to_rpy(t[:3, :3])]
    args = ["ik", "wx250s", "--xyz", *xyz, "--rpy", *rpy, "--solver", "analytic", "--all"]
    assert main([*args, "--json"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["count"] == len(arm.ik_all(t)) and "spherical wrist" in data["family"]
    assert all(s["position_error"] <= 1e-9 for s in data["solutions"])
    assert main(args) == 0
    assert "solutions" in capsys.readouterr().out
    assert main(["ik", "wx250s", "--xyz", "3", "0", "0", "--rpy", "0", "0", "0", "--solver",
                 "analytic", "--all"]) == 3
    assert main(["ik", "wx250s", "--xyz", *xyz, "--rpy", *rpy, "--all"]) == 2  # needs analytic
