"""Analyses over regions of the workspace: singularity maps (paper figure 3)."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .errors import InvalidParameterError
from .geometry import Planar3RRR
from .kinematics import _mode_array, inverse_kinematics


@dataclass(frozen=True)
class SingularityMap:
    """``S`` over a grid of platform positions at a fixed orientation and working mode.

    ``S[j, i]`` is the singularity measure at ``(x[i], y[j])``; NaN where the pose is out of
    reach. ``S = 0`` marks gain-type singularities (paper figure 3).
    """

    x: np.ndarray
    y: np.ndarray
    S: np.ndarray
    alpha: float
    mode: tuple[int, int, int]

    @property
    def reachable(self) -> np.ndarray:
        return np.isfinite(self.S)


def default_extent(model: Planar3RRR) -> tuple[tuple[float, float], tuple[float, float]]:
    """A square region covering the base triangle and every leg's reach."""
    reach = float(np.max(model.active_lengths + model.passive_lengths))
    lo = model.base_points.min(axis=0) - 0.25 * reach
    hi = model.base_points.max(axis=0) + 0.25 * reach
    return (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))


def singularity_map(
    model: Planar3RRR,
    alpha: float = 0.0,
    mode=(1, 1, 1),
    x_range: tuple[float, float] | None = None,
    y_range: tuple[float, float] | None = None,
    resolution: int = 201,
) -> SingularityMap:
    """``S(φ)`` of inverse-kinematics solutions over an ``x``–``y`` grid (eq. 19, figure 3).

    >>> m = singularity_map(Planar3RRR.paper(), resolution=11)
    >>> m.S.shape
    (11, 11)
    """
    if int(resolution) < 2:
        raise InvalidParameterError(f"resolution must be at least 2, got {resolution}")
    default_x, default_y = default_extent(model)
    x_range = default_x if x_range is None else x_range
    y_range = default_y if y_range is None else y_range
    x = np.linspace(*x_range, int(resolution))
    y = np.linspace(*y_range, int(resolution))
    xx, yy = np.meshgrid(x, y)
    poses = np.stack([xx, yy, np.full_like(xx, float(alpha))], axis=-1)
    ik = inverse_kinematics(model, poses, mode=mode, on_unreachable="nan")
    return SingularityMap(x, y, ik.S, float(alpha), tuple(int(m) for m in _mode_array(mode)))
