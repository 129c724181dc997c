"""Forward kinematics of the catalogue machines the other files leave to this one (the 3-RPS, the 3-PUU, the
6-RUS, the 6-PUS, the 3-UPU wrist, the Agile Eye), against a method independent of the polynomial system the
homotopy tracks: Newton's method on the generated kernels' loop closures ``η = 0`` from 10,000 random
configurations (passive angles over a turn, the platform anywhere in its reach, every orientation; an
overconstrained machine's ends kept where the rows its model sets aside hold too). The multistart may find fewer
platform poses than the homotopy, never more; every pose the homotopy gives closes the loops; the inverse
kinematics' pose is among them. At ``θ = 0`` the six-legged machines are symmetric and some paths go to
infinity: there the 6-PUS has 8 real assembly modes, of which a solve that trusted its first attempt missed one
without a word.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from test_catalogue import regular_mode

import pkmlab
from pkmlab.algorithms.assembly import assembly_modes
from pkmlab.errors import IncompleteSolutionWarning
from pkmlab.model import mechanism_model as mm
from pkmlab.model.reach import spatial_extent
from pkmlab.numerics.homotopy import batched_solve

CATALOGUE = Path(__file__).resolve().parents[1] / "examples" / "mechanisms"
STARTS = 10_000
#: file, a regular pose (as in test_catalogue)
MACHINES = {
    "3rps.toml": [0.5, 0.05, -0.03],
    "3puu.toml": [0.03, -0.02, 0.04],
    "3upu_wrist.toml": [0.1, -0.05, 0.2],
    "agile_eye.toml": [0.1, -0.05, 0.2],
    "6rus.toml": [0.0, 0.0, -0.30, 0.05, -0.03, 0.1],
    "6pus.toml": [0.0, 0.0, -0.30, 0.05, -0.03, 0.1],
    "4ruu.toml": [0.01, -0.005, -0.45, 0.03],
    "3crr.toml": [0.01, 0.02, -0.01],
}


def _wrapped(a: np.ndarray) -> np.ndarray:
    return np.angle(np.exp(1j * a))


def _pose_columns(model) -> list[int]:
    return [model.coordinates.index(c) for c in model.description.platform.q_pose_names]


def newton_starts(model, q: np.ndarray, iterations: int = 40) -> np.ndarray:
    """Damped Newton steps (at most half a unit per coordinate) on the kernels' ``η = 0`` for the passive
    coordinates of every start ``q`` (S, N) at once, the actuators held, in place; which starts converged
    (``max |η| < 1e-12``)."""
    k = model.kernels
    n, N = model.n_actuators, len(model.coordinates)
    active, converged = np.ones(len(q), dtype=bool), np.zeros(len(q), dtype=bool)
    eta = np.empty((len(q), k.N_CONSTRAINTS))
    for _ in range(iterations):
        idx = np.flatnonzero(active)
        if idx.size == 0:
            break
        residuals = np.empty((idx.size, k.N_CONSTRAINTS))
        k.constraint_residuals(np.ascontiguousarray(q[idx]), model.P, residuals)
        eta[idx] = residuals
        done = idx[np.abs(eta[idx]).max(axis=1) < 1e-12]
        converged[done], active[done] = True, False
        idx = np.flatnonzero(active)
        jac = np.empty((idx.size, k.N_CONSTRAINTS, N))
        k.constraint_jacobians(np.ascontiguousarray(q[idx]), model.P, jac)
        with np.errstate(all="ignore"):
            step = batched_solve(jac[:, :, n:], -eta[idx])  # NaN where singular
        ok = np.isfinite(step).all(axis=1)
        active[idx[~ok]] = False
        idx, step = idx[ok], step[ok]
        q[idx, n:] += step * np.minimum(1.0, 0.5 / np.abs(step).max(axis=1))[:, None]
    return converged


def _multistart_poses(model, theta, starts: int = STARTS, seed: int = 5) -> tuple[np.ndarray, int]:
    """The distinct platform poses (roll, pitch, yaw with |pitch| <= pi/2, as pkmlab gives them) of the
    configurations that damped Newton steps on ``η = 0`` reach from ``starts`` random ones at actuators
    ``theta``, all starts stepped together; and how many starts converged."""
    n, N = model.n_actuators, len(model.coordinates)
    names = model.coordinates
    box = spatial_extent(model.description)
    rng = np.random.default_rng(seed)
    q = np.empty((starts, N))
    q[:, :n] = theta
    for c in range(n, N):
        q[:, c] = rng.uniform(*box["xyz".index(names[c])], starts) if names[c] in "xyz" else \
            rng.uniform(-np.pi, np.pi, starts)
    converged = newton_starts(model, q)
    # an overconstrained machine's own configurations: its rows set aside hold too (the Agile Eye's kept rows, its
    # points', have others, where the platform leaves the centre)
    converged &= np.array([np.abs(mm.set_aside_residual(model, qk)).max(initial=0.0) < 1e-9 if ok else False
                           for qk, ok in zip(q, converged, strict=True)])
    poses = q[converged][:, _pose_columns(model)]
    pose_names = model.description.platform.q_pose_names
    if "pitch" in pose_names:  # a platform that turns (a translating one's pose is x, y, z)
        roll, pitch, yaw = (pose_names.index(c) for c in ("roll", "pitch", "yaw"))
        flip = np.cos(poses[:, pitch]) < 0
        poses[flip, roll] += np.pi
        poses[flip, pitch] = np.pi - poses[flip, pitch]
        poses[flip, yaw] += np.pi
    angular = np.array([c in ("roll", "pitch", "yaw") for c in pose_names])
    poses[:, angular] = _wrapped(poses[:, angular])
    distinct: list[np.ndarray] = []
    for p in poses:
        if all(np.abs(_wrapped(p - d)).max() > 1e-7 for d in distinct):
            distinct.append(p)
    return np.array(distinct), int(converged.sum())


def _forward_poses(model, theta) -> np.ndarray:
    with warnings.catch_warnings():
        warnings.simplefilter("error", IncompleteSolutionWarning)  # a solve unsure of itself fails the test
        found = assembly_modes(model, theta)
    for q, _s in found:
        assert np.abs(pkmlab.constraint_residual(model, q)).max() < 1e-11
    return np.array([q[_pose_columns(model)] for q, _s in found])


def _contains(poses: np.ndarray, pose: np.ndarray, tol: float = 1e-7) -> bool:
    return bool(len(poses)) and bool((np.abs(_wrapped(poses - pose)).max(axis=1) < tol).any())


@pytest.mark.parametrize("name", sorted(MACHINES))
def test_forward_kinematics_finds_every_pose_a_newton_multistart_finds(name):
    model = pkmlab.load(CATALOGUE / name)
    q = mm.inverse_kinematics(model, MACHINES[name], regular_mode(model, name))
    theta = q[:model.n_actuators]
    poses = _forward_poses(model, theta)
    assert _contains(poses, q[_pose_columns(model)], 1e-9)
    multistart, converged = _multistart_poses(model, theta)
    assert converged > STARTS // 20
    assert all(_contains(poses, p) for p in multistart), "a pose the homotopy missed"
    assert len(multistart) >= 2  # the check has teeth: it finds more than the pose it started from


@pytest.mark.parametrize("name", ["6pus.toml", "6rus.toml"])
def test_a_symmetric_six_legged_machine_keeps_every_assembly_mode_where_paths_go_to_infinity(name):
    model = pkmlab.load(CATALOGUE / name)
    theta = np.zeros(6)
    poses = _forward_poses(model, theta)
    multistart, _converged = _multistart_poses(model, theta)
    assert all(_contains(poses, p) for p in multistart), "a pose the homotopy missed"
    # mirror images in the base plane come in pairs (z -> -z with the platform turned over): an even count
    assert len(poses) == 8 and len(multistart) == 8
