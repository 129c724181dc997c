"""The parasitic motions of a platform of lower mobility: the pose coordinates its legs impose, computed
from the controlled ones.

A rigid platform on fewer than six legs (a 3-PRS, a 3-RPS) moves in as many of its pose's coordinates as it
has legs; the others follow from the loop closures. Given the controlled coordinates ``c``, the
configuration solves ``η(u, c) = 0`` for ``u`` = (actuators, passive joints, parasitic coordinates) — as many
unknowns as equations, ``∂η/∂u`` regular away from singularities. pkmlab solves it by continuation: from a
known configuration (the previous pose of a batch, else the machine's home configuration, the one its
mobility computation found), ``c`` is moved along the straight line to the target in steps, each corrected by
Newton's method on ``η = 0`` (quadratic convergence, to round-off), a step halved when Newton does not
converge; so the parasitic motion found is the one continuously connected to the home configuration, a
documented choice where the closures have several (they rarely do for the machines built).
"""

from __future__ import annotations

import functools

import numpy as np

from ..description.mechanism import leg_columns
from ..errors import InvalidParameterError

#: Newton's method on η = 0: at most this many iterations per step, converged when a step is below this
#: (relative to the machine's size).
MAX_NEWTON, NEWTON_TOL = 20, 1e-13
#: The continuation's steps: at most this many halvings of the first (the whole way).
MAX_HALVINGS = 12


def configuration_of(description, x: np.ndarray) -> np.ndarray:
    """The configuration ``q`` (the generated kernels' order: actuators, passive joints leg by leg, the pose's
    parasitic then controlled coordinates) of ``x`` (legs' joint coordinates leg by leg, then the whole pose,
    as :mod:`pkmlab.description.mobility` orders them)."""
    columns = [c for leg in leg_columns(description) for c in leg]
    platform = description.platform
    q = np.empty(len(columns) + len(platform.q_pose_names))
    q[columns] = x[:len(columns)]
    pose = dict(zip(platform.full_pose_names, x[len(columns):], strict=True))
    q[len(columns):] = [pose[n] for n in platform.q_pose_names]
    return q


@functools.lru_cache(maxsize=64)
def _home(description) -> np.ndarray:
    from ..description.mobility import mobility

    q = configuration_of(description, mobility(description, check=False).configuration)
    q.setflags(write=False)
    return q


def home_configuration(model) -> np.ndarray:
    """A configuration of ``model`` on its loop closures (the one its mobility computation found): where the
    continuation of :func:`parasitic_poses` starts."""
    return _home(model.description).copy()


def _newton(model, q: np.ndarray, dof: int, size: float) -> bool:
    """Newton's method on ``η = 0`` for every coordinate of ``q`` but its last ``dof`` (in place), with the
    structure's generated kernels; True once a step is below :data:`NEWTON_TOL`."""
    k = model.kernels
    free = len(q) - dof
    sc = np.zeros((len(q), 2))
    eta, jac = np.empty(k.N_CONSTRAINTS), np.empty((k.N_CONSTRAINTS, k.N_COORDINATES))
    for _ in range(MAX_NEWTON):
        k.trig(q, sc)
        k.constraints(q, sc, model.P, eta)
        k.constraint_jacobian(q, sc, model.P, jac)
        try:
            step = np.linalg.solve(jac[:, :free], -eta)
        except np.linalg.LinAlgError:
            return False
        if not np.all(np.isfinite(step)) or np.abs(step).max() > 0.5 * max(size, 1.0):
            return False
        q[:free] += step
        if np.abs(step).max() < NEWTON_TOL * max(size, 1.0):
            return True
    return False


def _continue(model, start: np.ndarray, target: np.ndarray, size: float) -> np.ndarray | None:
    """The configuration at controlled coordinates ``target``, continued from ``start`` (see the module)."""
    dof = len(target)
    q = start.copy()
    origin = start[-dof:].copy()
    done, h = 0.0, 1.0
    halvings = 0
    while done < 1.0:
        h = min(h, 1.0 - done)
        trial = q.copy()
        trial[-dof:] = origin + (done + h) * (target - origin)
        if _newton(model, trial, dof, size):
            q, done = trial, done + h
            h *= 2.0
        else:
            h /= 2.0
            halvings += 1
            if halvings > MAX_HALVINGS and h < 2.0 ** -MAX_HALVINGS:
                return None
    return q


def parasitic_poses(model, poses: np.ndarray) -> tuple[np.ndarray, np.ndarray, tuple | None]:
    """The whole poses (K, n_pose, :attr:`~pkmlab.description.spatial.SpatialPlatform.full_pose_names`) of a
    platform of lower mobility at its controlled coordinates ``poses`` (K, dof), their configurations' failures
    (K,) and the first failure ``(k, message)`` (None when every pose was found). Each pose is continued from
    the previous one found (the first from the home configuration)."""
    from ..description.mobility import _size

    m = model.description
    platform = m.platform
    size = _size(m)
    home = _home(m)
    out = np.full((len(poses), len(platform.full_pose_names)), np.nan)
    failed = np.zeros(len(poses), dtype=bool)
    first, previous = None, None
    order = [platform.q_pose_names.index(n) for n in platform.full_pose_names]
    n_pose = len(platform.q_pose_names)
    for k, target in enumerate(np.asarray(poses, dtype=float)):
        q = None
        if previous is not None:
            q = _continue(model, previous, target, size)
        if q is None:
            q = _continue(model, np.array(home), target, size)
        if q is None:
            failed[k] = True
            if first is None:
                where = ", ".join(f"{n} = {v:.6g}" for n, v in zip(platform.pose_names, target, strict=True))
                first = (k, f"{m.name}: no configuration at {where}: the loop closures cannot be met there from the "
                            "home configuration (the pose is out of reach, or past a singularity)")
            continue
        previous = q
        out[k] = q[-n_pose:][order]
    return out, failed, first


def check_controlled(model, poses) -> None:
    poses = np.asarray(poses, dtype=float)
    if poses.ndim != 2 or poses.shape[1] != model.description.dof:
        raise InvalidParameterError(f"poses must be (K, {model.description.dof}), got shape {poses.shape}")
