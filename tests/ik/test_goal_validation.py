"""Goal input checks: cheap (no SVD for a rotation that is orthonormal already), still clear.

Truth: NumPy's SVD, determinant and norms on the same matrices, and the pose-error definition of
:func:`armctl.spatial.pose_error` (independent of the goals' own arithmetic).
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numpy as np
import pytest

from armctl.errors import InputError
from armctl.ik import (
    DirectionGoal,
    LookAtGoal,
    OrientationGoal,
    PoseGoal,
    PositionGoal,
    Tolerance,
)
from armctl.spatial import orthonormalize, pose_error, rpy_to_matrix


def _random_pose(rng: np.random.Generator) -> np.ndarray:
    t = np.eye(4)
    t[:3, :3] = rpy_to_matrix(rng.uniform(-np.pi, np.pi, 3))
    t[:3, 3] = rng.uniform(-1.0, 1.0, 3)
    return t


def test_an_orthonormal_rotation_is_kept_exactly() -> None:
    rng = np.random.default_rng(1)
    for _ in range(50):
        t = _random_pose(rng)
        goal = PoseGoal(t)
        assert np.array_equal(goal.pose, t)
        assert not goal.pose.flags.writeable
        assert goal.pose is not t  # a copy: the caller's array may change afterwards


def test_a_nearly_orthonormal_rotation_is_projected_to_the_nearest_one() -> None:
    rng = np.random.default_rng(2)
    t = _random_pose(rng)
    bent = t.copy()
    bent[:3, :3] += 1e-8 * rng.standard_normal((3, 3))  # within 1e-6: accepted
    goal = PoseGoal(bent)
    r = goal.pose[:3, :3]
    assert np.abs(r @ r.T - np.eye(3)).max() < 1e-14
    assert np.allclose(r, orthonormalize(bent[:3, :3]), atol=1e-15)
    rot = OrientationGoal(bent[:3, :3]).rotation
    assert np.abs(rot @ rot.T - np.eye(3)).max() < 1e-14


@pytest.mark.parametrize(("change", "what"), [
    (lambda r: r * 1.001, "largest |R R^T - I| entry 0.002"),
    (lambda r: r @ np.diag([1.0, 1.0, -1.0]), "det -1"),
    (lambda r: r + 1e-5, "not a rotation matrix"),
])
def test_a_matrix_that_is_no_rotation_is_refused_with_the_numbers(
        change: Callable[[np.ndarray], np.ndarray], what: str) -> None:
    rng = np.random.default_rng(3)
    t = _random_pose(rng)
    t[:3, :3] = change(t[:3, :3])
    r = t[:3, :3]
    # independent truth: the old criterion, by NumPy
    assert np.abs(r @ r.T - np.eye(3)).max() > 1e-6 or np.linalg.det(r) < 0
    with pytest.raises(InputError, match="goal pose rotation is not a rotation matrix") as err:
        PoseGoal(t)
    assert what in str(err.value)
    with pytest.raises(InputError, match="goal rotation is not a rotation matrix"):
        OrientationGoal(r)


@pytest.mark.parametrize("bad", [np.nan, np.inf, -np.inf])
def test_non_finite_numbers_are_refused(bad: float) -> None:
    t = np.eye(4)
    t[1, 3] = bad
    with pytest.raises(InputError, match="finite"):
        PoseGoal(t)
    r = np.eye(3)
    r[2, 0] = bad
    with pytest.raises(InputError, match="finite"):
        OrientationGoal(r)
    with pytest.raises(InputError, match="goal position must be 3 finite numbers"):
        PositionGoal([0.0, bad, 0.0])
    with pytest.raises(InputError, match="goal direction must be 3 finite numbers"):
        DirectionGoal([0.0, 0.0, 0.0], [bad, 0.0, 1.0])


def test_huge_finite_numbers_are_finite() -> None:
    # their sum overflows to inf: the check then looks at each number
    goal = PositionGoal([1e308, 1e308, 0.0])
    assert goal.position.tolist() == [1e308, 1e308, 0.0]


def test_wrong_shapes_and_zero_directions_are_refused() -> None:
    with pytest.raises(InputError, match="4x4 transform, got shape \\(3, 3\\)"):
        PoseGoal(np.eye(3))
    with pytest.raises(InputError, match="3x3 rotation matrix"):
        OrientationGoal(np.eye(4))
    with pytest.raises(InputError, match="goal position must be 3 finite numbers"):
        PositionGoal([1.0, 2.0])
    with pytest.raises(InputError, match="goal direction must not be the zero vector"):
        DirectionGoal([0.0, 0.0, 0.0], [0.0, 0.0, 0.0])


def test_the_last_row_of_a_pose_is_that_of_a_transform() -> None:
    t = np.eye(4)
    t[3] = (1.0, 2.0, 3.0, 4.0)
    assert PoseGoal(t).pose[3].tolist() == [0.0, 0.0, 0.0, 1.0]


def test_unit_vectors_are_normalised() -> None:
    goal = DirectionGoal([0.0, 0.0, 0.0], [3.0, 0.0, 4.0], axis=[0.0, 2.0, 0.0])
    assert np.allclose(goal.direction, [0.6, 0.0, 0.8], atol=1e-16)
    assert goal.axis.tolist() == [0.0, 1.0, 0.0]
    assert not goal.direction.flags.writeable


def test_goal_errors_match_the_pose_error_of_spatial() -> None:
    rng = np.random.default_rng(4)
    for _ in range(200):
        target, current = _random_pose(rng), _random_pose(rng)
        if rng.uniform() < 0.3:  # small errors too, where accuracy matters most
            current = target.copy()
            current[:3, :3] = current[:3, :3] @ rpy_to_matrix(rng.normal(0.0, 1e-7, 3))
            current[:3, 3] += rng.normal(0.0, 1e-7, 3)
        err = pose_error(current, target)
        dp, dr = PoseGoal(target).errors(current)
        assert dp == pytest.approx(np.linalg.norm(err[:3]), rel=1e-12, abs=1e-15)
        assert dr == pytest.approx(np.linalg.norm(err[3:]), rel=1e-7, abs=1e-13)
        assert PositionGoal(target[:3, 3]).errors(current) == (pytest.approx(dp, abs=0), 0.0)
        assert OrientationGoal(target[:3, :3]).errors(current)[1] == pytest.approx(dr, abs=0)
        axis = rng.standard_normal(3)
        axis /= np.linalg.norm(axis)
        direction = DirectionGoal(target[:3, 3], target[:3, :3] @ axis, axis=axis)
        w = current[:3, :3] @ axis
        truth = math.acos(np.clip(w @ (target[:3, :3] @ axis), -1.0, 1.0))
        assert direction.errors(current)[1] == pytest.approx(truth, abs=1e-7)
        point = rng.uniform(-2.0, 2.0, 3)
        d = point - current[:3, 3]
        truth = math.acos(np.clip(w @ d / np.linalg.norm(d), -1.0, 1.0))
        assert LookAtGoal(point, axis=axis).errors(current) == (0.0, pytest.approx(truth,
                                                                                    abs=1e-7))


def test_tolerance_and_weight_are_still_checked() -> None:
    with pytest.raises(InputError, match="tolerances must be positive"):
        Tolerance(0.0, 1e-3)
    with pytest.raises(InputError, match="weight must be positive"):
        PoseGoal(np.eye(4), weight=0.0)
