"""Analyses over regions of the workspace: singularity maps (paper figure 3) and the reachable
workspace of each working mode."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from ._validate import as_count, as_mode, as_real
from .errors import InvalidParameterError, shown
from .geometry import WORKING_MODES, Planar3RRR  # noqa: F401 (the examples below use it)
from .kinematics import _model, inverse_kinematics


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
    mode: tuple[int, ...]

    @property
    def reachable(self) -> np.ndarray:
        return np.isfinite(self.S)


#: Grid points per axis at most (10⁸ points: beyond, the arrays no longer fit in memory).
MAX_RESOLUTION = 10_000


def default_extent(model) -> tuple[tuple[float, float], tuple[float, float]]:
    """A region covering the base and every leg's reach (for a described mechanism: its base points, rails
    and strokes, grown by its longest leg)."""
    if _is_machine(model):
        from .mechanism_model import planar_extent

        return planar_extent(model.description)
    reach = float(np.max(model.active_lengths + model.passive_lengths))
    lo = model.base_points.min(axis=0) - 0.25 * reach
    hi = model.base_points.max(axis=0) + 0.25 * reach
    return (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))


def _planar(model, what: str):
    """Refuse a spatial machine in a planar analysis (an x-y grid at one orientation alpha)."""
    description = getattr(model, "description", None)
    if getattr(description, "spatial", False):
        raise InvalidParameterError(f"{what} is a planar machine's x-y grid at one orientation; the "
                                    f"{description.name} is spatial: use spatial_workspace (horizontal slices)")


def _is_machine(model) -> bool:
    from .mechanism_model import MechanismModel

    return isinstance(model, MechanismModel)


def _axis(name: str, bounds, default, resolution: int) -> np.ndarray:
    bounds = default if bounds is None else bounds
    try:
        lo, hi = (float(v) for v in bounds)
    except (TypeError, ValueError, OverflowError):
        raise InvalidParameterError(f"{name} must be two numbers (min, max), got {shown(bounds)}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and math.isfinite(hi - lo)) or not lo < hi:
        raise InvalidParameterError(f"{name} must be two finite numbers with min < max (and a finite span), "
                                    f"got ({lo:g}, {hi:g})")
    return np.linspace(lo, hi, resolution)


def _grid(model, alpha, x_range, y_range, resolution, progress) -> tuple[np.ndarray, np.ndarray, float]:
    """Validated grid axes ``x``, ``y`` and orientation for the maps below."""
    as_count("resolution", resolution, 2, MAX_RESOLUTION)
    alpha = as_real("alpha", alpha)
    if progress is not None and not callable(progress):
        raise InvalidParameterError(f"progress must be a function of the number of rows done, got {shown(progress)}")
    default_x, default_y = default_extent(model if _is_machine(model) else _model(model))
    x = _axis("x_range", x_range, default_x, int(resolution))
    y = _axis("y_range", y_range, default_y, int(resolution))
    return x, y, alpha


def _machine_rows(model, x, y, alpha, modes, progress):
    """``S`` (rows, columns, modes) of a described mechanism's inverse kinematics over the grid, NaN out of
    reach, a row at a time."""
    from .mechanism_model import path_inverse_kinematics

    dof = model.description.dof
    out = np.full((y.size, x.size, len(modes)), np.nan)
    for j, yj in enumerate(y):
        poses = np.column_stack([x, np.full_like(x, yj)] + ([np.full_like(x, alpha)] if dof == 3 else []))
        for k, mode in enumerate(modes):
            out[j, :, k] = path_inverse_kinematics(model, poses, mode)[1]
        if progress is not None:
            progress(1)
    return out


def _inverse_kinematics_rows(model, x, y, alpha, mode, progress, rows_per_chunk: int = 16):
    """Inverse kinematics over the grid, a block of rows at a time so that ``progress`` can report."""
    parts = []
    for start in range(0, y.size, rows_per_chunk):
        yy, xx = np.meshgrid(y[start:start + rows_per_chunk], x, indexing="ij")
        poses = np.stack([xx, yy, np.full_like(xx, alpha)], axis=-1)
        parts.append(inverse_kinematics(model, poses, mode=mode, on_unreachable="nan"))
        if progress is not None:
            progress(yy.shape[0])
    return (np.concatenate([p.S for p in parts], axis=0),
            np.concatenate([p.unreachable_legs for p in parts], axis=0))


def singularity_map(
    model,
    alpha: float = 0.0,
    mode=None,
    x_range: tuple[float, float] | None = None,
    y_range: tuple[float, float] | None = None,
    resolution: int = 201,
    progress: Callable[[int], None] | None = None,
) -> SingularityMap:
    """``S(φ)`` of inverse-kinematics solutions over an ``x``–``y`` grid (eq. 19, figure 3).

    ``model`` is the paper's :class:`~pkmlab.geometry.Planar3RRR` or any
    :class:`~pkmlab.mechanism_model.MechanismModel`; ``mode`` its working mode (default: the first,
    ``(1, 1, 1)`` for the 3-RRR); ``alpha`` is ignored by a 2-DOF machine. ``progress``, when given, is
    called with the number of grid rows just computed.

    >>> m = singularity_map(Planar3RRR.paper(), resolution=11)
    >>> m.S.shape
    (11, 11)
    """
    if _is_machine(model):
        from .simulation import _machine_mode

        mode = _machine_mode(model, "auto" if mode is None else mode)
        mode = _machine_modes(model)[0] if mode == "auto" else mode
        _planar(model, "singularity_map")
        x, y, alpha = _grid(model, alpha, x_range, y_range, resolution, progress)
        return SingularityMap(x, y, _machine_rows(model, x, y, alpha, [mode], progress)[..., 0], alpha, mode)
    mode = tuple(int(m) for m in as_mode((1, 1, 1) if mode is None else mode))
    x, y, alpha = _grid(model, alpha, x_range, y_range, resolution, progress)
    s, _unreachable = _inverse_kinematics_rows(model, x, y, alpha, mode, progress)
    return SingularityMap(x, y, s, alpha, mode)


@dataclass(frozen=True)
class Workspace:
    """The reachable region at a fixed orientation ``α``, for each working mode (8 for the 3-RRR).

    ``reachable[k, j, i]`` says whether ``(x[i], y[j], α)`` can be reached in working mode
    ``modes[k]`` (a leg reaches its platform vertex whatever its working mode, so the masks
    coincide; they are kept per mode to pair with ``S``). ``S[k]`` is the singularity measure
    of that mode, NaN out of reach; ``area[k]`` (m²) is the number of reachable grid points
    times the area of one grid cell.
    """

    x: np.ndarray
    y: np.ndarray
    alpha: float
    modes: np.ndarray
    reachable: np.ndarray
    S: np.ndarray
    area: np.ndarray

    @property
    def cell_area(self) -> float:
        """Area (m²) of one grid cell, ``Δx Δy``."""
        return float((self.x[1] - self.x[0]) * (self.y[1] - self.y[0]))


def _machine_modes(model) -> list[tuple[int, ...]]:
    from .mechanism_model import working_modes

    return working_modes(model)


def workspace(
    model,
    alpha: float = 0.0,
    resolution: int = 201,
    x_range: tuple[float, float] | None = None,
    y_range: tuple[float, float] | None = None,
    progress: Callable[[int], None] | None = None,
) -> Workspace:
    """Reachable region and ``S`` of every working mode over an ``x``–``y`` grid at orientation ``α``.

    The default region (:func:`default_extent`) covers the base and every leg's reach.
    ``progress``, when given, is called with the number of grid rows just computed.

    >>> ws = workspace(Planar3RRR.paper(), alpha=0.0, resolution=41)
    >>> ws.reachable.shape, ws.S.shape
    ((8, 41, 41), (8, 41, 41))
    >>> bool(np.all(ws.reachable == ws.reachable[0]))  # reach does not depend on the working mode
    True
    >>> round(float(ws.area[0]) * 1e4)  # cm², on this coarse grid
    1052
    """
    _planar(model, "workspace")
    x, y, alpha = _grid(model, alpha, x_range, y_range, resolution, progress)
    if _is_machine(model):
        modes = _machine_modes(model)
        s = np.moveaxis(_machine_rows(model, x, y, alpha, modes, progress), -1, 0)
        reachable = np.isfinite(s)
        area = reachable.sum(axis=(1, 2)) * float((x[1] - x[0]) * (y[1] - y[0]))
        return Workspace(x, y, alpha, np.array(modes, dtype=np.int64).reshape(len(modes), -1), reachable, s, area)
    s, unreachable = _inverse_kinematics_rows(model, x, y, alpha, None, progress)
    reachable = np.moveaxis(unreachable == 0, -1, 0)
    s = np.moveaxis(s, -1, 0)
    cell = float((x[1] - x[0]) * (y[1] - y[0]))
    area = reachable.sum(axis=(1, 2)) * cell
    return Workspace(x, y, alpha, WORKING_MODES.copy(), reachable, s, area)


# ------------------------------------------------------------------ spatial machines
@dataclass(frozen=True)
class SpatialWorkspace:
    """A spatial machine's reachable region and singularity measure in horizontal slices, in one working
    mode, at a fixed orientation (a translating platform has no other).

    ``reachable[k, j, i]`` says whether ``(x[i], y[j], z[k])`` can be reached; ``S[k]`` is the singularity
    measure there (NaN out of reach), whose zero level is where the slice meets the ``S = 0`` surface;
    ``area[k]`` (m²) is the reachable area of slice ``k`` on the grid.
    """

    x: np.ndarray
    y: np.ndarray
    z: np.ndarray
    mode: tuple[int, ...]
    orientation: tuple[float, ...]
    reachable: np.ndarray
    S: np.ndarray
    area: np.ndarray


def spatial_workspace(model, mode=None, z_levels=None, resolution: int = 121, x_range=None, y_range=None,
                      orientation=(0.0, 0.0, 0.0), slices: int = 6,
                      progress: Callable[[int], None] | None = None) -> SpatialWorkspace:
    """:class:`SpatialWorkspace` of a spatial machine: ``slices`` levels spread over the heights it reaches
    (or ``z_levels``), each on a ``resolution``² grid over ``x_range`` × ``y_range`` (default: the legs'
    reach, :func:`~pkmlab.mechanism_model.spatial_extent`); ``mode`` defaults to the first working mode;
    ``orientation`` (roll, pitch, yaw) applies to a six-degree-of-freedom platform. ``progress`` is told
    each slice done."""
    from .mechanism_model import path_inverse_kinematics, spatial_extent, working_modes

    m = model.description
    modes = working_modes(model)
    mode = modes[0] if mode is None else tuple(int(v) for v in mode)
    if mode not in modes:
        raise InvalidParameterError(f"mode must be one of {modes} for the {m.name}, got {mode}")
    resolution = as_count("resolution", resolution, 2, 2001)
    box = spatial_extent(m)
    extra = list(orientation)[:m.dof - 3]

    def poses(xs, ys, z):
        gx, gy = np.meshgrid(xs, ys)
        return np.column_stack([gx.ravel(), gy.ravel(), np.full(gx.size, z), *(np.full(gx.size, v) for v in extra)])

    if z_levels is None:  # the heights reached somewhere on a coarse grid, then levels spread over them
        coarse = [np.linspace(lo, hi, 41) for lo, hi in box]
        reached = [z for z in coarse[2]
                   if np.isfinite(path_inverse_kinematics(model, poses(coarse[0], coarse[1], z), mode)[1]).any()]
        if not reached:
            raise InvalidParameterError(f"the {m.name} reaches no point of a 41^3 grid over its legs' reach in "
                                        f"working mode {mode}")
        step = (box[2, 1] - box[2, 0]) / 40
        lo, hi = min(reached) - step / 2, max(reached) + step / 2
        z_levels = lo + (np.arange(slices) + 0.5) * (hi - lo) / slices
    z = np.asarray(z_levels, dtype=float).ravel()
    if z.size == 0 or not np.all(np.isfinite(z)):
        raise InvalidParameterError(f"z levels must be finite heights (m), got {shown(z_levels)}")
    x = _axis("x_range", x_range, tuple(box[0]), resolution)
    y = _axis("y_range", y_range, tuple(box[1]), resolution)
    s = np.empty((z.size, y.size, x.size))
    for k, level in enumerate(z):
        _q, values, _failure = path_inverse_kinematics(model, poses(x, y, level), mode)
        s[k] = values.reshape(y.size, x.size)
        if progress is not None:
            progress(1)
    reachable = np.isfinite(s)
    area = reachable.sum(axis=(1, 2)) * float((x[1] - x[0]) * (y[1] - y[0]))
    return SpatialWorkspace(x, y, z, mode, tuple(float(v) for v in extra), reachable, s, area)
