"""The canonical subproblems against solutions constructed first (random, fixed seeds)."""

from __future__ import annotations

import math

import numpy as np

from armctl.ik.analytic._subproblems import (
    circle2,
    lin_trig,
    lin_trig_cs,
    rot,
    rot_cs_into,
    sp1,
    sp1_cs,
    trig2,
    wrap,
)


def _unit(rng: np.random.Generator) -> np.ndarray:
    v = rng.normal(size=3)
    return v / np.linalg.norm(v)


def _angdiff(a: float, b: float) -> float:
    return abs(wrap(a - b))


def test_sp1_recovers_the_angle_and_flags_vectors_on_the_axis() -> None:
    rng = np.random.default_rng(1)
    for _ in range(200):
        k, p, t = _unit(rng), rng.normal(size=3), rng.uniform(-np.pi, np.pi)
        got, deg = sp1(k, p, rot(k, t) @ p, 1e-9)
        assert not deg and _angdiff(got, t) < 1e-12
    k = np.array([0.0, 0.0, 1.0])
    _, deg = sp1(k, np.array([0.0, 0.0, 2.0]), np.array([0.0, 0.0, 2.0]), 1e-9)
    assert deg


def test_lin_trig_two_one_none_and_continuum() -> None:
    rng = np.random.default_rng(2)
    out = np.empty(2)
    for _ in range(200):
        a, b, t = rng.normal(), rng.normal(), rng.uniform(-np.pi, np.pi)
        e = a * math.cos(t) + b * math.sin(t)
        n = lin_trig(a, b, e, 1.0, out)
        assert n in (1, 2)
        assert min(_angdiff(out[i], t) for i in range(n)) < 1e-9
        for i in range(n):
            assert abs(a * math.cos(out[i]) + b * math.sin(out[i]) - e) < 1e-12
    assert lin_trig(3.0, 4.0, 5.0, 1.0, out) == 1 and _angdiff(out[0], math.atan2(4, 3)) < 1e-12
    assert lin_trig(3.0, 4.0, 5.1, 1.0, out) == 0
    assert lin_trig(0.0, 0.0, 0.0, 1.0, out) == -1
    assert lin_trig(0.0, 0.0, 1.0, 1.0, out) == 0


def test_the_cosine_and_sine_variants_match_the_trigonometry_of_their_angles() -> None:
    # sp1_cs, lin_trig_cs and rot_cs_into give the same angles as sp1 and lin_trig, with the
    # cosines and sines that math.cos / math.sin of those angles give (and the same rotation)
    rng = np.random.default_rng(3)
    out, out_cs, cs = np.empty(2), np.empty(2), np.empty((2, 2))
    r = np.empty((3, 3))
    for _ in range(300):
        k, p, t = _unit(rng), rng.normal(size=3), rng.uniform(-np.pi, np.pi)
        q = rot(k, t) @ p
        got, c, s, deg = sp1_cs(k, p, q, 1e-9)
        assert not deg and got == sp1(k, p, q, 1e-9)[0]
        assert abs(c - math.cos(got)) < 1e-14 and abs(s - math.sin(got)) < 1e-14
        rot_cs_into(k, c, s, r)
        np.testing.assert_allclose(r, rot(k, got), atol=1e-14)
        a, b = rng.normal(size=2)
        e = a * math.cos(t) + b * math.sin(t) * rng.choice([1.0, 1.0 + 1e-7])
        n = lin_trig(a, b, e, 1.0, out)
        assert lin_trig_cs(a, b, e, 1.0, out_cs, cs) == n
        for i in range(n):
            assert out_cs[i] == out[i]
            assert abs(cs[i, 0] - math.cos(out[i])) < 1e-12
            assert abs(cs[i, 1] - math.sin(out[i])) < 1e-12
    z = np.array([0.0, 0.0, 1.0])
    assert sp1_cs(z, np.array([0.0, 0.0, 2.0]), np.array([1.0, 0.0, 0.0]), 1e-9)[3]
    assert lin_trig_cs(3.0, 4.0, 5.0, 1.0, out, cs) == 1
    assert abs(cs[0, 0] - 0.6) < 1e-15 and abs(cs[0, 1] - 0.8) < 1e-15
    assert lin_trig_cs(3.0, 4.0, 5.1, 1.0, out, cs) == 0
    assert lin_trig_cs(0.0, 0.0, 0.0, 1.0, out, cs) == -1


def test_trig2_finds_every_root_of_a_product_of_two_sinusoids() -> None:
    # (cos t - cos r1) (cos t - cos r2) has the four roots +-r1, +-r2
    rng = np.random.default_rng(3)
    out = np.empty(4)
    for _ in range(200):
        r1, r2 = rng.uniform(0.05, np.pi - 0.05, 2)
        if abs(r1 - r2) < 1e-3:
            continue
        c1, c2 = math.cos(r1), math.cos(r2)
        # cos^2 t = (1 + cos 2t) / 2
        a0, a1, a2 = 0.5 + c1 * c2, -(c1 + c2), 0.5
        shift = rng.uniform(-np.pi, np.pi)  # rotate t -> t - shift: mixes in the sine terms
        cs, ss = math.cos(shift), math.sin(shift)
        c2s, s2s = math.cos(2 * shift), math.sin(2 * shift)
        n = trig2(a0, a1 * cs, a1 * ss, a2 * c2s, a2 * s2s, out)
        assert n == 4
        want = sorted(wrap(s * r + shift) for r in (r1, r2) for s in (1, -1))
        got = sorted(out[:n])
        assert max(_angdiff(g, w) for g, w in zip(got, want, strict=True)) < 1e-9


def test_trig2_degenerate_cases() -> None:
    out = np.empty(4)
    assert trig2(0.0, 0.0, 0.0, 0.0, 0.0, out) == -1
    assert trig2(1.0, 0.0, 0.0, 0.0, 0.0, out) == 0
    n = trig2(0.0, 1.0, 0.0, 0.0, 0.0, out)  # cos t = 0
    assert n == 2 and sorted(abs(out[:2])) == [math.pi / 2, math.pi / 2]


def test_circle2_generic_and_decoupled_systems() -> None:
    rng = np.random.default_rng(4)
    t1, t2 = np.empty(4), np.empty(4)
    for case in range(300):
        x, y = rng.uniform(-np.pi, np.pi, 2)
        a, b = rng.normal(size=(2, 2)), rng.normal(size=(2, 2))
        if case % 3 == 1:  # both blocks rank one, the equations decouple
            a[1] = 0.0
            b[0] = 0.0
        d = a @ [math.cos(x), math.sin(x)] + b @ [math.cos(y), math.sin(y)]
        n, cont = circle2(a, b, d, 0.0, 0.0, t1, t2)
        assert not cont and 1 <= n <= 4
        for i in range(n):  # every pair solves the system
            r = a @ [math.cos(t1[i]), math.sin(t1[i])] + b @ [math.cos(t2[i]), math.sin(t2[i])]
            assert np.abs(r - d).max() < 1e-7
        assert min(max(_angdiff(t1[i], x), _angdiff(t2[i], y)) for i in range(n)) < 1e-6


def test_circle2_continuum_returns_the_representative() -> None:
    a = np.array([[1.0, 0.0], [2.0, 0.0]])
    b = np.array([[0.0, 1.0], [0.0, 2.0]])
    t1, t2 = np.empty(4), np.empty(4)
    n, cont = circle2(a, b, np.array([1.0, 2.0]), 0.3, 0.0, t1, t2)  # cos t1 + sin t2 = 1
    assert cont and n >= 1
    assert _angdiff(t1[0], 0.3) < 1e-12
    assert abs(math.cos(t1[0]) + math.sin(t2[0]) - 1.0) < 1e-12
