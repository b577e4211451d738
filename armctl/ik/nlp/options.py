"""Options of the NLP solver: the shared IK budgets plus the NLP's own settings."""

from __future__ import annotations

from dataclasses import dataclass
from enum import Enum

import numpy as np
import numpy.typing as npt

from armctl.errors import InputError
from armctl.ik.options import IKOptions

__all__ = ["Method", "NLPOptions"]


class Method(Enum):
    """The CasADi NLP solver used for each attempt."""

    AUTO = "auto"  # IPOPT when there are hard constraints, else SQP (measured: docs/nlp.md)
    IPOPT = "ipopt"  # interior point; robust with many inequality constraints
    SQP = "sqpmethod"  # CasADi's SQP with the qrqp QP solver; light per-call overhead

    def resolve(self, has_hard_constraints: bool) -> Method:
        """The concrete solver for a problem with or without hard constraints."""
        if self is not Method.AUTO:
            return self
        return Method.IPOPT if has_hard_constraints else Method.SQP


@dataclass(frozen=True)
class NLPOptions(IKOptions):
    """Options of ``solver="nlp"`` (pass as ``options=`` to :meth:`armctl.arm.Arm.ik`).

    Attributes:
        max_iterations: Solver iterations per attempt from a distant start (one that
            converges needs fewer than 20; a restart is cheaper than a long crawl).
        method: The NLP solver. ``AUTO`` uses IPOPT for problems with hard constraints (it
            solved more of them) and CasADi's ``sqpmethod`` otherwise (several times faster per
            attempt on goals and weighted terms, and as reliable).
        regularization: Weight of ``|q - q_ref|^2`` in the cost, relative to the goal terms
            (which are normalised by the arm's reach) [1/rad^2]; small, so it only chooses among
            equally good solutions. With hard constraints it applies only when ``preferred`` is
            given (IPOPT from the start ends at a nearby answer anyway, and the term slowed it).
        damping: Levenberg-Marquardt damping added to the Gauss-Newton Hessian (not to the
            cost, so it does not move the answer): bounds the steps in directions the goals
            leave free. Problems with hard constraints use IPOPT's exact Hessian instead.
        preferred: Preferred posture ``q_ref`` ``(nq,)`` [rad]/[m] (a ball joint's unit
            quaternion in place); the start (the previous solution when streaming) when ``None``.
        orientation_scale: Length that converts orientation errors into position errors
            [m/rad]; ``None`` for 0.3 times the arm's reach.
        seed_solver: Registered solver whose answer seeds the first restart (``""``: none);
            used only when registered.
    """

    max_iterations: int = 30
    method: Method = Method.AUTO
    regularization: float = 1e-7
    damping: float = 1e-5
    preferred: tuple[float, ...] | None = None
    orientation_scale: float | None = None
    seed_solver: str = "dls"

    def __post_init__(self) -> None:
        super().__post_init__()
        if not self.damping >= 0:
            raise InputError(f"damping must not be negative, got {self.damping}")
        if not self.regularization >= 0:
            raise InputError(f"regularization must not be negative, got {self.regularization}")
        if self.orientation_scale is not None and not self.orientation_scale > 0:
            raise InputError(f"orientation_scale must be positive [m/rad], got "
                             f"{self.orientation_scale}")
        if self.preferred is not None:
            pref = np.asarray(self.preferred, dtype=float).reshape(-1)
            if not np.all(np.isfinite(pref)):
                raise InputError("the preferred posture contains a NaN or infinite value")
            object.__setattr__(self, "preferred", tuple(float(v) for v in pref))

    @classmethod
    def from_options(cls, options: IKOptions | None) -> NLPOptions:
        """NLP options from the shared ones: the time budget, restarts, seed and checker are kept.

        ``max_iterations`` of plain :class:`IKOptions` counts the cheap steps of the numerical
        solvers; an NLP iteration does far more, so it is capped at the NLP default.
        """
        if isinstance(options, NLPOptions):
            return options
        if options is None:
            return cls()
        return cls(max_iterations=min(options.max_iterations, cls.max_iterations),
                   time_limit=options.time_limit, restarts=options.restarts, seed=options.seed,
                   avoid=options.avoid)

    def preferred_array(self, nq: int) -> npt.NDArray[np.float64] | None:
        """The preferred posture as an array, checked against the length of the arm's ``q``."""
        if self.preferred is None:
            return None
        if len(self.preferred) != nq:
            raise InputError(f"the preferred posture has {len(self.preferred)} values; the "
                             f"arm's joint vector q has {nq}")
        return np.array(self.preferred)
