"""Type aliases shared by the armctl modules (a leaf: it imports only NumPy).

``Array`` is the float array of every joint vector, pose and Jacobian in armctl; its shape and
unit are given where it is used, e.g. ``q: Array`` ``(dof,)`` [rad]/[m].
"""

from __future__ import annotations

import numpy as np
import numpy.typing as npt

__all__ = ["Array"]

#: A float64 NumPy array of any shape.
Array = npt.NDArray[np.float64]
