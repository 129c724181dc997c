"""Analyses over regions of the workspace: singularity maps (paper figure 3) and the reachable
workspace of each working mode."""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

from .._validate import as_count, as_real
from ..errors import InvalidParameterError, shown
from ..model.mechanism_model import (
    MechanismModel,
    configuration_measures,
    inverse_kinematics_batch,
    path_inverse_kinematics,
    working_modes,
)
from ..model.reach import planar_extent


@dataclass(frozen=True)
class SingularityMap:
    """``S`` over a grid of platform positions at a fixed orientation and working mode (:func:`singularity_map`).

    ``S[j, i]`` is the singularity measure at ``(x[i], y[j])``; NaN where the pose is out of
    reach. ``S = 0`` marks gain-type singularities (paper figure 3).

    Attributes
    ----------
    x : ndarray, shape (resolution,)
        The grid's x coordinates (m).
    y : ndarray, shape (resolution,)
        The grid's y coordinates (m).
    S : ndarray, shape (resolution, resolution)
        The singularity measure, rows along ``y`` (dimensionless; NaN out of reach).
    alpha : float
        The platform's orientation (rad).
    mode : tuple of int
        The working mode.

    Examples
    --------
    >>> import pkmlab
    >>> m = pkmlab.singularity_map(pkmlab.load("paper"), resolution=11)
    >>> m.mode, int(m.reachable.sum())
    ((1, 1, 1), 20)
    """

    x: np.ndarray
    y: np.ndarray
    S: np.ndarray
    alpha: float
    mode: tuple[int, ...]

    @property
    def reachable(self) -> np.ndarray:
        """Where the pose is reachable (``S`` finite), boolean, shape (resolution, resolution)."""
        return np.isfinite(self.S)


#: Grid points per axis at most (10⁸ points: beyond, the arrays no longer fit in memory).
MAX_RESOLUTION = 10_000


def default_extent(model: MechanismModel) -> tuple[tuple[float, float], tuple[float, float]]:
    """A region covering the base and every leg's reach: the base points, rails and strokes, grown by a
    quarter of the longest leg."""
    _machine(model)
    return planar_extent(model.description)


def _machine(model) -> MechanismModel:
    if not isinstance(model, MechanismModel):
        raise InvalidParameterError(f"model must be a MechanismModel (pkmlab.load('paper'), ...), got "
                                    f"{type(model).__name__} {shown(model, 50)}")
    return model


def _planar(model, what: str):
    """Refuse a spatial machine in a planar analysis (an x-y grid at one orientation alpha)."""
    description = _machine(model).description
    if getattr(description, "spatial", False):
        raise InvalidParameterError(f"{what} is a planar machine's x-y grid at one orientation; the "
                                    f"{description.name} is spatial: use spatial_workspace (horizontal slices)")


def _axis(name: str, bounds, default, resolution: int) -> np.ndarray:
    bounds = default if bounds is None else bounds
    try:
        lo, hi = (float(v) for v in bounds)
    except (TypeError, ValueError, OverflowError):
        raise InvalidParameterError(f"{name} must be two numbers (min, max), got {shown(bounds)}") from None
    if not (math.isfinite(lo) and math.isfinite(hi) and math.isfinite(hi - lo)) or not lo < hi:
        raise InvalidParameterError(f"{name} must be two finite numbers with min < max (and a finite span), "
                                    f"got ({lo:g}, {hi:g})")
    for v in (lo, hi):
        as_real(name, v, bounded=True)  # metres beyond any machine: its map would overflow
    return np.linspace(lo, hi, resolution)


def _grid(model, alpha, x_range, y_range, resolution, progress) -> tuple[np.ndarray, np.ndarray, float]:
    """Validated grid axes ``x``, ``y`` and orientation for the maps below."""
    as_count("resolution", resolution, 2, MAX_RESOLUTION)
    alpha = as_real("alpha", alpha)
    if progress is not None and not callable(progress):
        raise InvalidParameterError(f"progress must be a function of the number of rows done, got {shown(progress)}")
    default_x, default_y = default_extent(model)
    x = _axis("x_range", x_range, default_x, int(resolution))
    y = _axis("y_range", y_range, default_y, int(resolution))
    return x, y, alpha


def _machine_rows(model, x, y, alpha, modes, progress, actuators=None):
    """``S`` (rows, columns, modes) of a described mechanism's inverse kinematics over the grid, NaN out of
    reach, a row at a time; a redundantly actuated machine's actuation measure (of ``actuators``, all by
    default) instead."""
    m = model.description
    # a kinematically redundant machine's base actuators at zero, as its assembly check tries them
    held = [np.full_like(x, alpha)] * (m.platform.kind == "rigid") + [np.zeros_like(x)] * len(m.redundancy_names)
    out = np.full((y.size, x.size, len(modes)), np.nan)
    for j, yj in enumerate(y):
        poses = np.column_stack([x, np.full_like(x, yj), *held])
        for k, mode in enumerate(modes):
            if actuators is None:
                out[j, :, k] = path_inverse_kinematics(model, poses, mode)[1]
            else:  # a subset's measure
                out[j, :, k] = configuration_measures(model, inverse_kinematics_batch(model, poses, mode)[0], actuators)
        if progress is not None:
            progress(1)
    return out


def singularity_map(
    model,
    alpha: float = 0.0,
    mode=None,
    x_range: tuple[float, float] | None = None,
    y_range: tuple[float, float] | None = None,
    resolution: int = 201,
    progress: Callable[[int], None] | None = None,
    actuators=None,
) -> SingularityMap:
    """``S(φ)`` of inverse-kinematics solutions over an ``x``–``y`` grid (eq. 19, figure 3).

    For a redundantly actuated machine, the actuation's measure
    (:func:`~pkmlab.algorithms.kinematics.actuation_singularity_measure`, zero at forward singularities, never
    negative) of all its actuators or of some: the maps of all and of each ``dof`` of them show where the extra
    actuators remove the singularities of the machines fewer would drive.

    Parameters
    ----------
    model : MechanismModel
        Any planar machine (:func:`pkmlab.load`); a spatial one is refused.
    alpha : float
        The platform's orientation (rad, default 0); ignored by a 2-DOF machine.
    mode : sequence of signs, optional
        The working mode (default: the first, ``(1, 1, 1)`` for the paper's 3-RRR).
    x_range, y_range : (float, float), optional
        The grid's bounds (m; default: a region covering the base and every leg's reach).
    resolution : int
        Grid points per axis, 2 to :data:`MAX_RESOLUTION` (default 201).
    progress : callable, optional
        Called with the number of grid rows just computed (1, after each row).
    actuators : sequence of int, optional
        A redundantly actuated machine's: the actuators (0-based) whose measure is mapped; all by default.

    Returns
    -------
    SingularityMap
        ``x``, ``y`` (resolution,), ``S`` (resolution, resolution), ``alpha``, ``mode``.

    Raises
    ------
    InvalidParameterError
        If ``model`` is spatial or not a model, ``mode`` is not one of its working modes, a range is not two
        finite numbers with min < max, or ``resolution`` or ``progress`` is refused.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab import load
    >>> m = singularity_map(load("paper"), resolution=11)
    >>> m.S.shape
    (11, 11)
    >>> five = singularity_map(load("five_bar"), x_range=(-0.2, 0.2), y_range=(0.1, 0.4), resolution=5)
    >>> np.round(five.S[0], 3).tolist()
    [-0.57, -0.866, -1.0, -0.919, -0.315]
    """
    from .kinematics import as_actuators, as_working_mode

    _planar(model, "singularity_map")
    if actuators is not None and not _machine(model).description.actuation_redundancy:
        raise InvalidParameterError(f"actuators chooses the actuators of a redundantly actuated machine's map; the "
                                    f"{model.name} has as many as its degrees of freedom")
    mode = as_working_mode(model, "auto" if mode is None else mode, "mode")
    mode = working_modes(model)[0] if mode == "auto" else mode
    x, y, alpha = _grid(model, alpha, x_range, y_range, resolution, progress)
    if actuators is not None:  # refused before the grid's work, not after its first row
        actuators = as_actuators(model, actuators)
    return SingularityMap(x, y, _machine_rows(model, x, y, alpha, [mode], progress, actuators)[..., 0], alpha, mode)


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

    >>> from pkmlab import load
    >>> ws = workspace(load("paper"), alpha=0.0, resolution=41)
    >>> ws.reachable.shape, ws.S.shape
    ((8, 41, 41), (8, 41, 41))
    >>> bool(np.all(ws.reachable == ws.reachable[0]))  # reach does not depend on the working mode
    True
    >>> round(float(ws.area[0]) * 1e4)  # cm², on this coarse grid
    1052
    """
    _planar(model, "workspace")
    x, y, alpha = _grid(model, alpha, x_range, y_range, resolution, progress)
    modes = working_modes(model)
    s = np.moveaxis(_machine_rows(model, x, y, alpha, modes, progress), -1, 0)
    reachable = np.isfinite(s)
    area = reachable.sum(axis=(1, 2)) * float((x[1] - x[0]) * (y[1] - y[0]))
    return Workspace(x, y, alpha, np.array(modes, dtype=np.int64).reshape(len(modes), -1), reachable, s, area)


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
    reach, :func:`~pkmlab.model.reach.spatial_extent`); ``mode`` defaults to the first working mode;
    ``orientation`` (roll, pitch, yaw) applies to a six-degree-of-freedom platform. ``progress`` is told
    each slice done."""
    from ..model.reach import spatial_extent

    m = _machine(model).description
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
