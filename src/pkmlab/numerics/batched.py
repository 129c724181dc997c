"""Linear algebra on stacks of small matrices (K, m, m), in NumPy: a path's Jacobians at once."""

from __future__ import annotations

import numpy as np

#: A matrix whose condition number (1-norm) reaches this is treated as singular.
CONDITION_LIMIT = 1e12


def first_singular(a: np.ndarray, limit: float = CONDITION_LIMIT) -> int:
    """The index of the first singular matrix of a stack of square matrices ``a`` (K, m, m), or -1 if none is.

    A matrix is singular when its condition number in the 1-norm, ``‖A‖₁ ‖A⁻¹‖₁``, is not below ``limit`` (an
    exactly singular one's is infinite): NumPy computes it from the inverse, for a stack of 6×6 matrices half the
    cost of the SVDs of the 2-norm's. The two condition numbers of an ``m × m`` matrix differ by a factor of at
    most ``m``: a matrix within that factor of the limit may be judged either way by the two.
    """
    singular = ~(np.linalg.cond(a, 1) < limit)
    return int(np.argmax(singular)) if singular.any() else -1
