"""Soak test: thousands of NLP solves of every method on several arms, in a child process.

A memory error inside the solvers' C++ code (such as the overrun of CasADi's qrqp that
``armctl.ik.nlp.problem`` guards against) kills the whole process instead of failing a test, so
the solves run in a child process (``tools/soak_nlp.py``). Where the C library is glibc, the
child runs under glibc's malloc checks: they abort at the first free of a block that was written
past its end, not at some later, unrelated allocation.
"""

from __future__ import annotations

import ctypes.util
import json
import os
import subprocess
import sys

import numpy as np
from armctl_testpaths import DATA, REPO

from armctl import load_arm
from armctl.ik import PositionGoal
from armctl.ik.nlp import Method, NLPOptions, OnPlane
from armctl.ik.nlp.problem import get_problem

#: Bundled arms, and a URDF Panda ending at panda_link8: 7 joints, all with narrow limits, so
#: every joint can sit at a bound at once (the case that overran qrqp's working memory).
ARMS = ("panda", "ur5e", "so101", "tests/data/urdf/panda.urdf:panda_link8")
#: Solves per arm: many of the SQP-based methods (cheap, and the ones that use qrqp), fewer of
#: IPOPT (several times slower per solve).
SOLVES = {Method.AUTO: 1000, Method.SQP: 1000, Method.IPOPT: 250}
#: Output of a process killed by heap corruption (glibc) or by a fatal error (Python).
CRASH_MARKERS = ("invalid pointer", "corrupt", "double free", "Fatal Python error", "Traceback",
                 "Segmentation fault")


def _env() -> dict[str, str]:
    """The environment of the child: glibc's malloc checks switched on where available."""
    env = dict(os.environ)
    env["MALLOC_CHECK_"] = "3"  # glibc before 2.34
    debug = ctypes.util.find_library("c_malloc_debug")  # glibc 2.34 and later
    if debug:
        env["LD_PRELOAD"] = " ".join(p for p in (env.get("LD_PRELOAD"), debug) if p)
        env["GLIBC_TUNABLES"] = ":".join(
            t for t in (env.get("GLIBC_TUNABLES"), "glibc.malloc.check=3") if t)
    return env


def test_thousands_of_nlp_solves_exit_cleanly_with_true_answers() -> None:
    assert set(SOLVES) == set(Method)  # every method, AUTO included
    methods = [f"{m.value}:{n}" for m, n in SOLVES.items()]
    proc = subprocess.run(
        [sys.executable, str(REPO / "tools" / "soak_nlp.py"), "--json", "--seed", "0",
         "--arms", *ARMS, "--methods", *methods],
        capture_output=True, text=True, env=_env(), cwd=REPO, timeout=280, check=False)
    rows = [json.loads(line) for line in proc.stdout.splitlines() if line.startswith("{")]
    done = [(r["arm"], r["method"]) for r in rows]
    assert proc.returncode == 0, (
        f"the soak ended with code {proc.returncode} after {done}:\n{proc.stderr[-3000:]}")
    for marker in CRASH_MARKERS:
        assert marker not in proc.stderr, proc.stderr[-3000:]
    assert done == [(a, m.value) for a in ARMS for m in SOLVES]
    assert sum(r["solves"] for r in rows) == len(ARMS) * sum(SOLVES.values())
    for r in rows:
        # every reported success was checked by FK, the limits and the plane in the child
        assert r["wrong"] == [], r
        # and most solves succeed: the check above is not vacuous
        assert r["success"] >= 0.97 * r["solves"], r


def test_sqp_problems_have_one_row_without_bounds_and_ipopt_none() -> None:
    """The guard against the qrqp overrun: a free row whose multiplier stays exactly zero."""
    arm = load_arm(DATA / "urdf" / "panda.urdf", "panda_link8")
    rng = np.random.default_rng(3)
    plane = OnPlane([0.4, 0.0, 0.3], [0.0, 0.0, 1.0])
    for constraints, rows in (((), 0), ((plane,), 1)):
        goal = PositionGoal(arm.fk(arm.sample(rng))[:3, 3])
        for method in (Method.SQP, Method.IPOPT):
            options = NLPOptions(method=method)
            problem = get_problem(arm, (goal,), constraints, options)
            extra = 1 if method is Method.SQP else 0
            assert problem.n_constraints == rows
            assert problem.lbg.shape == problem.ubg.shape == (rows + extra,)
            assert problem.solvers[False].size_in("lbg") == (rows + extra, 1)
            if extra:
                assert problem.lbg[-1] == -np.inf and problem.ubg[-1] == np.inf
            params = problem.params((goal,), constraints, arm.sample(rng), 1e-7, 1e-5)
            for _ in range(20):  # cold starts: many end with joints at their bounds
                sol = problem.solvers[False](x0=arm.sample(rng), p=params, lbx=arm.lower,
                                             ubx=arm.upper, lbg=problem.lbg, ubg=problem.ubg)
                lam_g = np.asarray(sol["lam_g"]).reshape(-1)
                assert lam_g.shape == (rows + extra,)
                if extra:
                    assert lam_g[-1] == 0.0
