"""The per-cycle joint <-> tick conversion of a whole arm equals the per-joint one.

:meth:`JointMapping.from_ticks` and :meth:`JointMapping.goal_ticks` use constants computed once
per mapping. They are checked against :class:`JointMap`'s own methods (exactly: the same floats,
the same errors) and against a reference written here from the formula in the module docstring
of :mod:`armctl.servo.mapping`, over random readings and goals, for every bundled arm and for
variants of its joints: reversed, multi-turn, calibrated zero ticks that put the encoder wrap
inside the travel, ranges of a turn or more, unbounded ranges.
"""

from __future__ import annotations

import math
import zlib
from dataclasses import replace

import numpy as np
import pytest
from armctl_testpaths import BUNDLED

from armctl.config import load_spec
from armctl.config.schema import JointType
from armctl.errors import ConfigError, JointLimitError
from armctl.servo import JointMap, JointMapping

pytestmark = pytest.mark.timeout(60)


# ---- the reference, from the documented formula ------------------------------------------------
def ref_ticks(j: JointMap, q: float) -> float:
    """``ticks = z + d g (q - q0) N / (2 pi)``."""
    return j.zero_tick + j.direction * j.gear_ratio * (q - j.zero_value) * j.ticks_per_rev / (
        2 * math.pi)


def ref_joint(j: JointMap, ticks: float) -> tuple[float, bool]:
    """``q = q0 + d (ticks - z) 2 pi / (g N)``, a single-turn reading first moved by a whole
    turn onto the side of the encoder wrap nearest the joint's range (ties: the lower turn).

    Returns:
        The joint value, and whether two turns lie (within rounding) equally near the range.
    """
    t, tie = float(ticks), False
    if not j.multi_turn and math.isfinite(j.lower) and math.isfinite(j.upper):
        a, b = ref_ticks(j, j.lower), ref_ticks(j, j.upper)
        lo, hi = min(a, b), max(a, b)

        def gap(c: float) -> float:  # distance of a tick from the range, 0 inside
            return lo - c if c < lo else c - hi if c > hi else 0.0
        n = j.ticks_per_rev
        best = t - n
        for c in (t, t + n):
            if gap(c) < gap(best):
                best = c
        tie = sum(abs(gap(c) - gap(best)) < 1e-6 for c in (t - n, t, t + n)) > 1
        t = best
    return j.zero_value + j.direction * (t - j.zero_tick) * 2 * math.pi / (
        j.gear_ratio * j.ticks_per_rev), tie


def ref_goal(joints: tuple[JointMap, ...], q: list[float]) -> dict[int, int] | str:
    """Goal ticks by servo id, or the name of the first joint refused (limits before the wrap)."""
    for j, v in zip(joints, q, strict=True):
        if not j.lower - 1e-9 <= v <= j.upper + 1e-9:
            return j.name
    out = {}
    for j, v in zip(joints, q, strict=True):
        t = round(ref_ticks(j, v))  # half to even, as Python rounds
        if not j.multi_turn and not 0 <= t < j.ticks_per_rev:
            return j.name
        out[j.servo_id] = t
    return out


# ---- the joints checked ------------------------------------------------------------------------
def variants(j: JointMap, rng: np.random.Generator) -> list[JointMap]:
    """The joint reversed, multi-turn or single-turn, with its wrap in its travel, unbounded."""
    n = j.ticks_per_rev
    out = [j, replace(j, direction=-j.direction), replace(j, multi_turn=not j.multi_turn)]
    if math.isfinite(j.lower) and math.isfinite(j.upper):
        span = abs(ref_ticks(j, j.upper) - ref_ticks(j, j.lower))
        if span < n - 2:  # a zero tick that puts the encoder wrap inside the travel
            out.append(replace(j, zero_tick=float(rng.uniform(0.0, 0.5 * span)),
                               zero_value=j.lower + 0.3 * (j.upper - j.lower), multi_turn=False))
            out.append(replace(j, zero_tick=n - 1 - float(rng.uniform(0.0, 0.5 * span)),
                               direction=-j.direction, multi_turn=False))
        else:  # a single-turn joint whose range is a turn or more (the general rule)
            out.append(replace(j, multi_turn=False))
    else:
        out.append(replace(j, lower=-1.0, upper=1.5, multi_turn=False))
    out.append(replace(j, gear_ratio=j.gear_ratio * 2.5, zero_tick=j.zero_tick + 0.25,
                       zero_value=j.zero_value - 0.1))
    out.append(replace(j, lower=-math.inf, upper=math.inf))  # unbounded: never unwrapped
    return out


def arm_mappings(arm: str) -> list[JointMapping]:
    """The arm's mapping and mappings made of variants of each of its joints."""
    rng = np.random.default_rng(zlib.crc32(arm.encode()))
    base = JointMapping.from_spec(load_spec(arm))
    per_joint = [variants(j, rng) for j in base.joints]
    out = [base]
    for k in range(max(len(v) for v in per_joint)):
        out.append(JointMapping([v[k % len(v)] for v in per_joint]))
    return out


def readings(j: JointMap, rng: np.random.Generator, count: int) -> list[float]:
    """Readings around and beyond one turn, integers and fractions, and the tie points."""
    n = j.ticks_per_rev
    got = list(rng.integers(-n, 2 * n, count).astype(float)) + list(rng.uniform(-n, 2 * n, 20))
    if not j.multi_turn and math.isfinite(j.lower) and math.isfinite(j.upper):
        a, b = ref_ticks(j, j.lower), ref_ticks(j, j.upper)
        lo, hi = min(a, b), max(a, b)
        for mid in ((hi + lo + n) / 2, (hi - n + lo) / 2, lo, hi, lo + n, hi - n):
            got += [mid, float(np.nextafter(mid, -math.inf)), float(np.nextafter(mid, math.inf))]
    return got


@pytest.mark.parametrize("arm", BUNDLED)
def test_from_ticks_equals_the_per_joint_conversion_and_the_formula(arm: str) -> None:
    rng = np.random.default_rng(11)
    kinds, ties, compared = set(), 0, 0
    for m in arm_mappings(arm):
        samples = {j.servo_id: readings(j, rng, 60) for j in m.joints}
        for k in range(len(next(iter(samples.values())))):
            ticks = {sid: s[k % len(s)] for sid, s in samples.items()}
            fast = m.from_ticks(ticks)
            slow = np.array([j.to_joint(ticks[j.servo_id]) for j in m.joints])
            assert np.array_equal(fast, slow), (arm, ticks)
            for j, got in zip(m.joints, fast, strict=True):
                ref, tie = ref_joint(j, ticks[j.servo_id])
                if tie:  # the formula leaves the turn to rounding: the exact check above holds
                    ties += 1
                    continue
                assert got == pytest.approx(ref, rel=1e-12, abs=1e-12), (arm, j, ticks)
                compared += 1
        for j in m.joints:
            kinds.add((j.direction, j.multi_turn, j.joint_type))
    assert {d for d, _, _ in kinds} == {-1, 1} and {mt for _, mt, _ in kinds} == {False, True}
    assert compared > 1000 and compared > ties


@pytest.mark.parametrize("arm", BUNDLED)
def test_goal_ticks_equal_the_per_joint_conversion_and_errors(arm: str) -> None:
    rng = np.random.default_rng(12)
    refused = accepted = 0
    for m in arm_mappings(arm):
        lower = np.where(np.isfinite(m.lower), m.lower, -7.0)
        upper = np.where(np.isfinite(m.upper), m.upper, 7.0)
        width = upper - lower
        for _ in range(150):
            q = rng.uniform(lower - 0.05 * width, upper + 0.05 * width)
            if rng.random() < 0.5:  # mostly inside, so that the wrap check is reached too
                q = np.clip(q, lower, upper)
            values = [float(v) for v in q]
            expected = ref_goal(m.joints, values)
            try:
                per_joint: dict[int, int] | str = {}
                for j, v in zip(m.joints, values, strict=True):
                    j.check(v, "servo goal")
                for j, v in zip(m.joints, values, strict=True):
                    assert isinstance(per_joint, dict)
                    per_joint[j.servo_id] = j.goal_ticks(v)
            except (JointLimitError, ConfigError) as exc:
                per_joint = f"{type(exc).__name__}: {exc}"
            if isinstance(expected, dict):
                assert m.goal_ticks(q) == expected == per_joint
                accepted += 1
            else:
                with pytest.raises((JointLimitError, ConfigError)) as info:
                    m.goal_ticks(q)
                assert f"{type(info.value).__name__}: {info.value}" == per_joint
                assert repr(expected) in str(info.value)  # the first joint refused is named
                refused += 1
    assert refused > 50 and accepted > 50


def test_not_a_number_is_refused_with_the_joint_named() -> None:
    m = JointMapping.from_spec(load_spec("so101"))
    q = [j.rest for j in m.joints]
    q[2] = math.nan
    with pytest.raises(JointLimitError, match=repr(m.joints[2].name)):
        m.goal_ticks(q)


def test_the_variants_cover_grippers_prismatic_joints_and_gear_ratios() -> None:
    joints = [j for arm in BUNDLED for m in arm_mappings(arm) for j in m.joints]
    assert any(j.joint_type is JointType.PRISMATIC for j in joints)
    assert any(j.joint_type is JointType.CONTINUOUS or not math.isfinite(j.upper)
               for j in joints)
    assert len({j.gear_ratio for j in joints}) > 4
    assert {j.ticks_per_rev for j in joints} == {4096}
