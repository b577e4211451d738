"""The CasADi problem for one arm and one goal structure, built once and cached.

The cost is a sum of squared residuals::

    sum_goals w_g |r_g(q)|^2 + sum_soft w_c |g_c(q)|^2 + lambda |q - q_ref|^2

with position residuals divided by the arm's reach ``L`` and orientation residuals written as
``(rho / L) (R - R_target)`` (Frobenius form: smooth everywhere, zero only at the target, no
wrap-around); each goal type writes its own (:meth:`armctl.ik.goals.Goal.nlp_residual`),
subject to the joint limits and the hard constraints' rows. Without hard constraints the
Hessian handed to the solver is the Gauss-Newton one, ``2 J^T J`` (positive semi-definite, exact
at a reached goal); with them IPOPT takes CasADi's exact Hessian of the Lagrangian and its own
default options (see :func:`_solver_options`).

On an arm with ball joints the decision variables are ``q`` itself (``model.nq`` entries, a ball
joint's unit quaternion as four of them, a universal joint's two angles), and each ball joint
adds its own rows (:func:`armctl.kinematics.symbolic.ball_limit_rows`): its unit norm as an
equality, its swing cone and twist range as smooth inequalities, and ``w >= 0`` as a bound when
it has a twist limit. Those rows make the problem one with hard constraints (IPOPT, exact
Hessian); each answer is scaled to unit norm and projected into the limits
(:meth:`KinematicModel.clip`, a move no larger than the rows' own tolerance).

Everything that changes between solves (targets, weights, constraint numbers, ``q_ref``,
``lambda``) is a parameter, so a new target reuses the built solver; :func:`build_count` counts
the builds so tests can assert it.
"""

from __future__ import annotations

import weakref
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np

from armctl.config.schema import JointType
from armctl.errors import InputError
from armctl.ik.goals import Goal
from armctl.ik.nlp.constraints import AxisInCone, Constraint, Segment
from armctl.ik.nlp.options import Method, NLPOptions
from armctl.kinematics.capsules import arm_capsules
from armctl.kinematics.model import KinematicModel
from armctl.typing import Array

__all__ = ["Attempt", "Problem", "build_count", "clear_cache", "get_problem"]


_BUILDS = 0
#: Iteration cap of the warm-start instance without hard constraints: near the answer it needs
#: 3-6; beyond this the start was not near after all and a seeded restart is cheaper.
_WARM_ITERATIONS = 15
#: IPOPT's iteration cap with hard constraints, in units of ``max_iterations``.
_HARD_ITERATIONS = 5
_CACHE: weakref.WeakKeyDictionary[KinematicModel, dict[tuple[object, ...], Problem]] = (
    weakref.WeakKeyDictionary())


def build_count() -> int:
    """How many CasADi problems have been built in this process."""
    return _BUILDS


def clear_cache() -> None:
    """Forget every built problem."""
    _CACHE.clear()


def _goal_params(goal: Goal) -> Array:
    """The goal's NLP parameters (:meth:`Goal.nlp_params`) followed by its weight."""
    return np.concatenate([goal.nlp_params(), [goal.weight]])


def structure_key(model: KinematicModel, goals: Sequence[Goal],
                  constraints: Sequence[Constraint], options: NLPOptions) -> tuple[object, ...]:
    """Everything that fixes the shape of the problem; numbers are left out."""
    return (
        tuple((type(g).__name__, g.frame or model.tool) for g in goals),
        tuple(c.structure() for c in constraints),
        _method(options, constraints, model), options.max_iterations, options.orientation_scale,
    )


@dataclass(frozen=True)
class Attempt:
    """One run of the NLP solver.

    Attributes:
        q: The joint vector it ended at, clipped into the limits.
        iterations: Solver iterations.
        solver_status: The solver's own return status.
        locally_infeasible: Whether the solver found the hard constraints locally infeasible.
    """

    q: Array
    iterations: int
    solver_status: str
    locally_infeasible: bool


class _Instances(dict[bool, Any]):
    """The solver instances of a problem by ``warm``, each built on first use."""

    def __init__(self, build: Callable[[bool], Any]):
        super().__init__()
        self._build = build

    def __missing__(self, warm: bool) -> Any:
        solver = self._build(warm)
        self[warm] = solver
        return solver


class Problem:
    """A built CasADi NLP for one arm, goal structure and constraint structure.

    Args:
        model: The arm.
        goals: Goals (their numbers only serve as examples of the structure).
        constraints: Constraints (likewise).
        options: Method, iteration budget, scales.
    """

    def __init__(self, model: KinematicModel, goals: Sequence[Goal],
                 constraints: Sequence[Constraint], options: NLPOptions):
        import casadi as ca

        from armctl.kinematics.symbolic import SymbolicFK, ball_limit_rows, twist_bounded

        self.model = model
        self.method = method = _method(options, constraints, model)
        self.length = model.tree.max_reach
        rho = options.orientation_scale or 0.3 * self.length
        sizes = [len(_goal_params(g)) for g in goals] + [len(c.params()) + (0 if c.hard else 1)
                                                         for c in constraints]
        nq = model.nq
        self.n_params = sum(sizes) + nq + 2
        p = ca.SX.sym("p", self.n_params)
        sym = SymbolicFK(model)
        q = sym.q
        inv_len, rot_scale = 1.0 / self.length, rho / self.length
        residuals: list[Any] = []
        rows: list[Any] = []
        lbg: list[float] = []
        at = 0
        for goal, size in zip(goals, sizes[:len(goals)], strict=True):
            gp = p[at:at + size]
            at += size
            rot, pos = sym.frame(goal.frame)
            sw = ca.sqrt(gp[size - 1])
            r = goal.nlp_residual(ca, rot, pos, gp[0:size - 1], position_scale=inv_len,
                                  rotation_scale=rot_scale)
            residuals.append(sw * r)
        by_radius: dict[float | None, list[Segment]] = {}

        def segments(radius: float | None) -> list[Segment]:
            if radius not in by_radius:
                by_radius[radius] = []
                for cap in arm_capsules(model, radius):
                    a, b = np.array(cap.a), np.array(cap.b)
                    by_radius[radius].append((sym.point(cap.body, a), sym.point(cap.body, b),
                                              cap.radius, float(np.linalg.norm(b - a))))
            return by_radius[radius]

        for c, size in zip(constraints, sizes[len(goals):], strict=True):
            cp = p[at:at + size]
            at += size
            rot, pos = sym.frame(c.frame) if not c.on_links else (None, None)
            on_links = segments(getattr(c, "link_radius", None)) if c.on_links else []
            g_rows = c.rows(ca, rot, pos, on_links, cp)
            if c.hard:
                rows.append(g_rows)
                lbg += [0.0 if c.equality else -np.inf] * int(g_rows.numel())
            else:
                scale = rot_scale if isinstance(c, AxisInCone) else inv_len
                viol = g_rows if c.equality else ca.fmax(g_rows, 0)
                residuals.append(ca.sqrt(cp[size - 1]) * scale * viol)
        for row in ball_limit_rows(model, q):  # a ball joint's unit norm, cone and twist range
            rows.append(row.expr)
            lbg.append(0.0 if row.equality else -np.inf)
        q_ref = p[at:at + nq]
        lam = p[at + nq]
        damping = p[at + nq + 1]
        residuals.append(lam * (q - q_ref))  # lam: the square root of the weight (0 allowed)
        res = ca.vertcat(*residuals)
        g = ca.vertcat(*rows) if rows else ca.SX(0, 1)
        self.n_constraints = len(lbg)
        ubg = [0.0] * len(lbg)
        if method is Method.SQP:
            # One row without bounds, for a defect of CasADi's qrqp (sqpmethod's QP solver, up
            # to at least 3.8.2): its dual step lists one breakpoint per multiplier that changes
            # sign plus the step's end, up to nz + 1 integers, in a buffer of nz (nz: joints
            # plus constraint rows, the number of the QP's multipliers). When every
            # multiplier of the QP is non-zero and all change sign in one step (every joint at a
            # bound; common on an arm with narrow limits and no other constraint rows, such as
            # the 7-joint Panda) it writes one integer past its heap block, and glibc aborts
            # later ("munmap_chunk(): invalid pointer"). qrqp never activates a row without
            # bounds, so its multiplier stays zero and at most nz breakpoints remain.
            g, lbg, ubg = ca.vertcat(g, ca.SX.zeros(1, 1)), [*lbg, -np.inf], [*ubg, np.inf]
        self.lbg = np.array(lbg)
        self.ubg = np.array(ubg)
        #: IPOPT with hard constraints takes CasADi's exact Hessian (see _solver_options)
        self.exact_hessian = method is Method.IPOPT and self.n_constraints > 0
        hess_fn = None
        if not self.exact_hessian:
            jac = ca.jacobian(res, q)
            lam_f = ca.SX.sym("lam_f")
            lam_g = ca.SX.sym("lam_g", len(lbg))
            # Gauss-Newton plus Levenberg-Marquardt damping: bounded steps where the goals leave
            # directions free (redundancy, position-only goals) and the regularisation is tiny
            hess = 2 * lam_f * (jac.T @ jac + damping * ca.SX.eye(nq))
            if self.n_constraints:
                hess = hess + ca.hessian(ca.dot(lam_g, g), q)[0]
            if method is Method.IPOPT:
                hess = ca.triu(hess)
            hess_fn = ca.Function("hess_lag", [q, p, lam_f, lam_g], [hess],
                                  ["x", "p", "lam_f", "lam_g"], ["hess_gamma_x_x"])
        nlp = {"x": q, "p": p, "f": ca.sumsqr(res), "g": g}
        # two instances of the same problem: tuned for a warm start near the answer (streaming,
        # polishing), and for a cold start far from it (restarts); each built on first use
        self.solvers = _Instances(lambda warm: ca.nlpsol(
            f"armctl_ik_{'warm' if warm else 'cold'}", method.value, nlp,
            _solver_options(method, options, hess_fn, self.n_constraints, warm)))
        self._warm: tuple[Array, Any, Any] | None = None
        #: The bounds of the decision variables: the joint limits, and ``w >= 0`` for a ball
        #: joint with a twist limit (its twist rows are exact on that half of the quaternions)
        self.lbx = np.array(model.lower, dtype=float)
        self.ubx = np.array(model.upper, dtype=float)
        for i, j in enumerate(model.spec.actuated_joints):
            if j.type is JointType.BALL and twist_bounded(j.limits.lower, j.limits.upper):
                self.lbx[model.q_index(i).start] = 0.0

    def params(self, goals: Sequence[Goal], constraints: Sequence[Constraint], q_ref: Array,
               regularization: float, damping: float) -> Array:
        """The parameter vector for these goals' and constraints' numbers.

        Args:
            goals: The goals.
            constraints: The constraints.
            q_ref: Centre of the regularisation ``(nq,)``.
            regularization: Its weight.
            damping: Levenberg-Marquardt damping added to the Hessian approximation.
        """
        parts = [_goal_params(g) for g in goals]
        for c in constraints:
            parts.append(c.params() if c.hard else np.concatenate([c.params(), [c.weight]]))
        parts += [np.asarray(q_ref, dtype=float),
                  np.array([np.sqrt(regularization), damping])]
        out = np.concatenate(parts)
        if out.shape != (self.n_params,):  # pragma: no cover - guarded by the structure key
            raise InputError("goal structure does not match the built problem")
        return out

    def recentred(self, params: Array, q_ref: Array) -> Array:
        """``params`` with the regularisation centred on ``q_ref``."""
        out = params.copy()
        nq = self.model.nq
        out[-2 - nq:-2] = q_ref
        return out

    def run(self, q0: Array, params: Array, warm: bool = True) -> Attempt:
        """Solve once from ``q0``.

        Args:
            q0: Start ``(nq,)``.
            params: Parameters from :meth:`params`.
            warm: Use the instance tuned for a start near the answer (and the last multipliers
                when ``q0`` is the last answer); else the one tuned for a distant start.
        """
        model = self.model
        kw: dict[str, Any] = {"x0": q0, "p": params, "lbx": self.lbx, "ubx": self.ubx}
        if len(self.lbg):
            kw["lbg"], kw["ubg"] = self.lbg, self.ubg
        if warm and self._warm is not None and np.array_equal(self._warm[0], q0):
            kw["lam_x0"], kw["lam_g0"] = self._warm[1], self._warm[2]
        solver = self.solvers[warm]
        sol = solver(**kw)
        stats = solver.stats()
        q = _inside(model, np.array(sol["x"], dtype=float).reshape(-1), q0)
        self._warm = (q, sol["lam_x"], sol["lam_g"])
        status = str(stats.get("return_status", ""))
        infeasible = status in ("Infeasible_Problem_Detected", "Restoration_Failed",
                                "Search_Direction_Becomes_Too_Small") or (
            "infeasib" in status.lower())
        return Attempt(q, int(stats.get("iter_count", 0)), status, infeasible)


def _inside(model: KinematicModel, x: Array, q0: Array) -> Array:
    """The solver's ``x`` as a joint vector inside the limits (``q0`` when it is not finite).

    1-DOF entries are clipped; a ball joint's quaternion is scaled to unit norm and projected
    into its cone and twist range.
    """
    q = np.clip(x, model.lower, model.upper)
    if not np.all(np.isfinite(q)):
        return np.array(q0, dtype=float)
    if model.nq == model.nv:
        return q
    for i, j in enumerate(model.spec.actuated_joints):
        sl = model.q_index(i)
        if j.type is JointType.BALL and not float(np.linalg.norm(q[sl])) > 1e-9:
            return np.array(q0, dtype=float)
    return model.clip(model.normalize(q))


def _max_iter(options: NLPOptions, warm: bool, n_constraints: int) -> int:
    """Iteration cap: short for a warm start on goals alone, the full budget otherwise."""
    if warm and not n_constraints:
        return min(options.max_iterations, _WARM_ITERATIONS)
    return options.max_iterations


def _method(options: NLPOptions, constraints: Sequence[Constraint],
            model: KinematicModel) -> Method:
    """The solver: a ball joint's rows (its unit norm at least) count as hard constraints."""
    balls = any(t is JointType.BALL for t in model.joint_types)
    return options.method.resolve(balls or any(c.hard for c in constraints))


def _solver_options(method: Method, options: NLPOptions, hess: Any, n_constraints: int,
                    warm: bool) -> dict[str, Any]:
    if method is Method.IPOPT and hess is None:
        # hard constraints: IPOPT nearly as it comes (exact Hessian, its own scaling, default
        # tolerances), which reached more of these goals in less time than the Gauss-Newton
        # form (docs/benchmarks.md, "NLP IK"); the adaptive barrier took fewer iterations
        # there; a longer iteration budget, as the first iterations from a distant start move
        # slowly
        exact: dict[str, Any] = {
            "print_time": False, "error_on_fail": False, "calc_lam_p": False,
            "ipopt.print_level": 0,
            "ipopt.sb": "yes", "ipopt.max_iter": _HARD_ITERATIONS * options.max_iterations,
            "ipopt.mu_strategy": "adaptive",
        }
        if warm:  # a start that trusts x0 (polishing an answer)
            exact.update({"ipopt.mu_init": 1e-5, "ipopt.warm_start_init_point": "yes",
                          "ipopt.warm_start_bound_push": 1e-9,
                          "ipopt.warm_start_mult_bound_push": 1e-9})
        return exact
    if method is Method.IPOPT:
        ipopt: dict[str, Any] = {
            "hess_lag": hess, "print_time": False, "error_on_fail": False, "calc_lam_p": False,
            "ipopt.print_level": 0, "ipopt.sb": "yes",
            "ipopt.max_iter": _max_iter(options, warm, n_constraints),
            "ipopt.tol": 1e-8, "ipopt.constr_viol_tol": 1e-8,
            # stop after two iterations at the acceptable level (IPOPT's default waits 15): the
            # success check by FK decides, and an answer short of a goal is polished
            "ipopt.acceptable_tol": 1e-6, "ipopt.acceptable_iter": 2,
            "ipopt.acceptable_constr_viol_tol": 1e-8,
            "ipopt.nlp_scaling_method": "none",  # the residuals are scaled by construction
        }
        if warm:  # an adaptive barrier and a start that trusts x0: few iterations near it
            ipopt.update({"ipopt.mu_strategy": "adaptive", "ipopt.mu_init": 1e-5,
                        "ipopt.warm_start_init_point": "yes",
                        "ipopt.warm_start_bound_push": 1e-9,
                        "ipopt.warm_start_mult_bound_push": 1e-9})
        return ipopt
    out: dict[str, Any] = {
        "hess_lag": hess, "print_time": False, "error_on_fail": False, "calc_lam_p": False,
        "print_header": False, "print_iteration": False, "print_status": False,
        "max_iter": _max_iter(options, warm, n_constraints),
        "tol_pr": 1e-10, "tol_du": 1e-10,
        "qpsol": "qrqp",
        "qpsol_options": {"print_iter": False, "print_header": False, "print_info": False,
                          "error_on_fail": False},
    }
    if n_constraints:
        out["convexify_strategy"] = "regularize"
    return out


def get_problem(model: KinematicModel, goals: Sequence[Goal], constraints: Sequence[Constraint],
                options: NLPOptions) -> Problem:
    """The built problem for this structure, building it on first use.

    Args:
        model: The arm.
        goals: The goals.
        constraints: The constraints.
        options: Method, budgets and scales.

    Returns:
        The cached or newly built problem.
    """
    global _BUILDS
    per_model = _CACHE.setdefault(model, {})
    key = structure_key(model, goals, constraints, options)
    problem = per_model.get(key)
    if problem is None:
        problem = Problem(model, goals, constraints, options)
        per_model[key] = problem
        _BUILDS += 1
    return problem
