"""Linear algebra on stacks of small matrices (K, m, m), in NumPy: a path's Jacobians at once."""

from __future__ import annotations

import numpy as np

#: A matrix whose condition number (1-norm) reaches this is treated as singular.
CONDITION_LIMIT = 1e12


def first_singular(a: np.ndarray, limit: float = CONDITION_LIMIT) -> int:
    """The index of the first singular matrix of a stack of square matrices ``a`` (K, m, m), or -1 if none is.

    A matrix is singular when its condition number in the 1-norm, ``‖A‖₁ ‖A⁻¹‖₁``, is not below ``limit``
    (or is not finite), computed from the inverse: for a stack of 6×6 matrices it costs half of the SVDs of
    the 2-norm's condition number. The two condition numbers of an ``m × m`` matrix differ by a factor of at
    most ``m``.
    """
    try:
        inverse = np.linalg.inv(a)
    except np.linalg.LinAlgError:  # exactly singular somewhere: the SVD's condition numbers find where
        singular = ~(np.linalg.cond(a) < limit)
    else:
        singular = ~(np.abs(a).sum(axis=-2).max(axis=-1) * np.abs(inverse).sum(axis=-2).max(axis=-1) < limit)
    return int(np.argmax(singular)) if singular.any() else -1
