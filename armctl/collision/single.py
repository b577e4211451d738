"""The clearance of one configuration, computed without the compiler.

A process that checks a single configuration (``armctl fk``, one reading of ``armctl status``,
one picture) is done long before numba would have loaded the compiled kernels. The functions
here run the same kernels interpreted (:func:`armctl.collision._kernels.interpreted`): the same
operations in the same order, so the same result as
:meth:`~armctl.collision.model.CollisionModel.clearance`, in a few milliseconds and without
importing numba.
"""

from __future__ import annotations

import math

import numpy.typing as npt

from armctl.collision import _kernels as K
from armctl.collision.contact import Clearance, ContactKind
from armctl.collision.model import CollisionModel

__all__ = ["clearance_once"]


def clearance_once(model: CollisionModel, q: npt.ArrayLike) -> Clearance | None:
    """The checked pair with the least room at ``q``, computed by the interpreted kernel.

    Args:
        model: The collision model.
        q: Joint values ``(nq,)`` [rad]/[m] (a ball joint's unit quaternion in place).

    Returns:
        The pair whose distance exceeds its padding by the least (negative margin: in
        contact), or ``None`` when the model checks no pair.

    Raises:
        InputError: ``q`` of the wrong length or not finite.
    """
    f, i = model.packed
    _, idx, dist = K.interpreted("min_slack")(model.model.as_q(q), f, i, -math.inf)
    if idx < 0:
        return None
    a, b, kind = model.pair_names(int(idx))
    padding = model.scene.padding if kind is ContactKind.SCENE else 0.0
    return Clearance(float(dist), padding, a, b, kind)
