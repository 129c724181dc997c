"""Dynamics of any described mechanism: the constrained Lagrangian model in the full coordinates with its
loop-closure multipliers (the paper's eqs. 20–26), and its exact reduction to the actuator space (eq. 35),
with gravity — batched over leading axes like :mod:`pkmlab.algorithms.kinematics`.

The full model, ``M(q) q̈ + C(q, q̇) q̇ + g(q) = Q(τ) + Jηqᵀ λ`` with ``Jηq q̈ + J̇ηq q̇ = 0``, is that of
the unconstrained bodies (its mass matrix is singular on its own for a closed chain); the actuator-space model
``Mθ θ̈ + cθ + gθ = τ`` is what a computed-torque controller computes with and the simulations integrate.
They agree: ``Mθ = Jqθᵀ M Jqθ``, ``cθ = Jqθᵀ (M J̇qθ θ̇ + C q̇)``, ``gθ = Jqθᵀ g``.

Examples
--------
>>> import numpy as np
>>> import pkmlab
>>> model = pkmlab.load("five_bar")
>>> q = pkmlab.inverse_kinematics(model, [0.0, 0.35], mode=(1, -1)).q
>>> model_theta = pkmlab.actuator_space_model(model, q, [0.5, -0.2])
>>> model_theta.M.shape, bool(np.allclose(model_theta.M, model_theta.M.T))
((2, 2), True)
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import as_broadcast, index_text
from ..errors import InvalidParameterError, SingularityError
from ..model import mechanism_model as mm
from ..model.mechanism_model import MechanismModel
from ..numerics import lagrangian
from .kinematics import SINGULAR_S, as_model, check_loop_closure, refuse_actuation_redundancy, singularity_measure

__all__ = [
    "FullSpaceModel",
    "ConstrainedDynamics",
    "ActuatorSpaceModel",
    "full_space_model",
    "constrained_dynamics",
    "actuator_space_model",
    "inverse_dynamics",
    "forward_dynamics",
]


@dataclass(frozen=True)
class FullSpaceModel:
    """The unconstrained bodies' model in the full coordinates (:func:`full_space_model`).

    Attributes
    ----------
    M : ndarray, shape (..., n, n)
        The mass matrix ``M(q)`` (eq. 23; kg, kg·m, kg·m² by the coordinates' units).
    c : ndarray, shape (..., n)
        ``C(q, q̇) q̇``: the Coriolis and centrifugal forces (eq. 24; N·m or N per coordinate).
    g : ndarray, shape (..., n)
        ``g(q) = ∂V/∂q``: the generalised forces that hold the bodies still against gravity (N·m or N).

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.2, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> full = pkmlab.full_space_model(model, q, np.zeros(9))
    >>> full.M.shape, bool(np.allclose(full.M, full.M.T)), bool(np.all(full.c == 0.0))
    ((9, 9), True, True)
    """

    M: np.ndarray
    c: np.ndarray
    g: np.ndarray


@dataclass(frozen=True)
class ConstrainedDynamics:
    """The motion of the closed chain under actuator efforts (:func:`constrained_dynamics`).

    Attributes
    ----------
    q_ddot : ndarray, shape (..., n)
        The coordinates' accelerations (rad/s² or m/s² per coordinate).
    multipliers : ndarray, shape (..., n_constraints)
        The loop-closure multipliers ``λ`` of eq. (26): the forces (N, one per constraint row, in the
        constraints' order) with which each leg holds its attachment point on the platform.

    Examples
    --------
    From rest, an effort on the first actuator accelerates the machine along its loop closures
    (``Jηq q̈ = 0``), its actuators as :func:`forward_dynamics` says:

    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.2, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> motion = pkmlab.constrained_dynamics(model, q, np.zeros(9), [0.1, 0.0, 0.0])
    >>> bool(np.abs(pkmlab.constraint_jacobian(model, q) @ motion.q_ddot).max() < 1e-12)
    True
    >>> bool(np.allclose(motion.q_ddot[:3], pkmlab.forward_dynamics(model, q, np.zeros(3), [0.1, 0.0, 0.0])))
    True
    >>> motion.multipliers.shape
    (6,)
    """

    q_ddot: np.ndarray
    multipliers: np.ndarray


@dataclass(frozen=True)
class ActuatorSpaceModel:
    """The actuator-space model, ``M θ̈ + c + g = τ`` (eq. 35; :func:`actuator_space_model`).

    Attributes
    ----------
    M : ndarray, shape (..., n_actuators, n_actuators)
        ``Mθ = Jqθᵀ M Jqθ`` (kg·m² or kg), symmetric positive definite away from singularities.
    c : ndarray, shape (..., n_actuators)
        ``cθ = Cθ θ̇``: the Coriolis and centrifugal efforts (N·m or N).
    g : ndarray, shape (..., n_actuators)
        ``gθ = ∂V/∂θ``: the efforts that hold the machine still against gravity (N·m or N).

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> five_bar = pkmlab.load("five_bar")
    >>> q = pkmlab.inverse_kinematics(five_bar, [0.0, 0.35], mode=(1, -1)).q
    >>> actuator = pkmlab.actuator_space_model(five_bar, q, [0.1, 0.0])
    >>> bool(np.allclose(actuator.M, actuator.M.T)), bool(np.all(np.linalg.eigvalsh(actuator.M) > 0))
    (True, True)
    >>> bool(np.allclose(actuator.M[0, 0], actuator.M[1, 1]))  # the symmetric machine on its axis of symmetry
    True
    """

    M: np.ndarray
    c: np.ndarray
    g: np.ndarray


def refuse_overflow(name: str, *arrays) -> None:
    """Refuse a result that overflowed (rates of 1e200 squared), naming the input ``name`` that was too large."""
    if not all(np.all(np.isfinite(a)) for a in arrays):
        raise InvalidParameterError(f"{name} overflows the model (values too large)")


#: What the computations below run under: an overflow is refused after them (:func:`refuse_overflow`, naming the input),
#: so NumPy's own warnings of it would only come first with the wrong words.
_QUIET = {"over": "ignore", "invalid": "ignore", "divide": "ignore"}


def full_space_model(model: MechanismModel, q, q_dot) -> FullSpaceModel:
    """The unconstrained bodies' model ``(M, C q̇, g)`` in the full coordinates (eqs. 23–24, with gravity).

    The Newton–Euler equations of every body in the coordinates ``q``; the loop closures are not applied
    (:func:`constrained_dynamics` applies them).

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations (rad or m per entry).
    q_dot : array_like, shape (..., n)
        The coordinates' rates (rad/s or m/s; broadcast against ``q``).

    Returns
    -------
    FullSpaceModel
        ``M`` (..., n, n), ``c`` (..., n), ``g`` (..., n).

    Raises
    ------
    InvalidParameterError
        If the shapes do not broadcast, or ``q_dot`` overflows the model.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> q = pkmlab.inverse_kinematics(model, [0.0, 0.35], mode=(1, -1)).q
    >>> q_dot = pkmlab.coordinate_rates(model, q, [0.5, -0.2])
    >>> full = pkmlab.full_space_model(model, q, q_dot)
    >>> full.M.shape, full.c.shape
    ((6, 6), (6,))
    """
    model = as_model(model)
    n = len(model.coordinates)
    qs, qds, shape = as_broadcast(("q", q, n), ("q_dot", q_dot, n))
    M, c, g = np.empty((len(qs), n, n)), np.empty((len(qs), n)), np.empty((len(qs), n))
    with np.errstate(**_QUIET):
        for k in range(len(qs)):
            M[k], c[k], g[k] = mm.full_space_model(model, qs[k], qds[k])
    refuse_overflow("q_dot", c)
    return FullSpaceModel(M.reshape(*shape, n, n), c.reshape(*shape, n), g.reshape(*shape, n))


def constrained_dynamics(model: MechanismModel, q, q_dot, tau) -> ConstrainedDynamics:
    """The accelerations and loop-closure multipliers of the full model under actuator efforts ``tau`` (eq. 26).

    ``M q̈ + C q̇ + g = Q(τ) + Jηqᵀ λ``, ``Jηq q̈ + J̇ηq q̇ = 0``, where ``Q`` applies ``τ`` to the actuated
    coordinates.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations on the loop closure (rad or m per entry).
    q_dot : array_like, shape (..., n)
        Rates tangent to it (rad/s or m/s; :func:`~pkmlab.coordinate_rates`).
    tau : array_like, shape (..., n_actuators)
        Actuator efforts (N·m or N); all three broadcast.

    Returns
    -------
    ConstrainedDynamics
        ``q_ddot`` (..., n) and ``multipliers`` (..., n_constraints; N).

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure, the shapes do not broadcast, or ``q_dot`` or ``tau`` overflows.
    SingularityError
        Where the constrained model is singular (a gain-type singularity).

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> q = pkmlab.inverse_kinematics(model, [0.0, 0.35], mode=(1, -1)).q
    >>> q_dot = pkmlab.coordinate_rates(model, q, [0.5, -0.2])
    >>> tau = pkmlab.inverse_dynamics(model, q, [0.5, -0.2], [1.0, 2.0])
    >>> np.round(pkmlab.constrained_dynamics(model, q, q_dot, tau).q_ddot, 4).tolist()
    [1.0, 2.0, 1.3877, 0.5058, -0.402, 0.1321]
    """
    model = as_model(model)
    n, na = len(model.coordinates), model.n_actuators
    qs, qds, taus, shape = as_broadcast(("q", q, n), ("q_dot", q_dot, n), ("tau", tau, na))
    check_loop_closure(model, qs, shape)
    k_ = model.kernels
    j_eta = np.empty((len(qs), k_.N_CONSTRAINTS, n))
    gamma = np.empty((len(qs), k_.N_CONSTRAINTS))
    k_.constraint_jacobians(qs, model.P, j_eta)
    k_.constraint_biases(qs, qds, model.P, gamma)
    q_ddot, multipliers = np.empty((len(qs), n)), np.empty((len(qs), k_.N_CONSTRAINTS))
    for k in range(len(qs)):
        with np.errstate(**_QUIET):
            M, c, g = mm.full_space_model(model, qs[k], qds[k])
            Q = np.zeros(n)
            Q[:na] = taus[k]
            q_ddot[k], multipliers[k], ok = lagrangian.constrained_accelerations(M, c + g, j_eta[k], gamma[k], Q)
        if not ok:
            raise SingularityError(f"q{index_text(k, shape)}: the constrained model is singular there "
                                   "(a gain-type singularity)")
    refuse_overflow("q_dot or tau", q_ddot, multipliers)
    return ConstrainedDynamics(q_ddot.reshape(*shape, n), multipliers.reshape(*shape, k_.N_CONSTRAINTS))


def _regular(model: MechanismModel, qs: np.ndarray, shape) -> None:
    """Refuse configurations at a gain-type singularity (``|S| < SINGULAR_S``): the actuator-space model does not
    exist there."""
    s = singularity_measure(model, qs)
    bad = np.flatnonzero(~(np.abs(s) >= SINGULAR_S))
    if bad.size:
        k = int(bad[0])
        raise SingularityError(f"q{index_text(k, shape)} is at a gain-type singularity (|S| = {abs(s[k]):.3g} < "
                               f"{SINGULAR_S:g}): the actuator-space model does not exist there")


def actuator_space_model(model: MechanismModel, q, theta_dot) -> ActuatorSpaceModel:
    """The actuator-space model ``(Mθ, cθ, gθ)`` of ``Mθ θ̈ + cθ + gθ = τ`` (eq. 35, with gravity).

    The compiled core's own numbers, those a simulation integrates.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations on the loop closure (rad or m per entry).
    theta_dot : array_like, shape (..., n_actuators)
        The actuator rates (rad/s or m/s; broadcast against ``q``).

    Returns
    -------
    ActuatorSpaceModel
        ``M`` (..., n_actuators, n_actuators), ``c`` and ``g`` (..., n_actuators).

    Raises
    ------
    SingularityError
        At a gain-type singularity (``|S| < 1e-6``, :data:`~pkmlab.SINGULAR_S`).
    InvalidParameterError
        If ``q`` is off the loop closure, the shapes do not broadcast, or ``theta_dot`` overflows the model.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> q = pkmlab.inverse_kinematics(model, [0.0, 0.35], mode=(1, -1)).q
    >>> asm = pkmlab.actuator_space_model(model, q, [0.5, -0.2])
    >>> np.round(asm.M, 4)
    array([[ 0.0331, -0.0091],
           [-0.0091,  0.0331]])
    >>> np.round(asm.c, 4).tolist(), asm.g.tolist()
    ([0.0056, -0.0085], [0.0, 0.0])
    """
    model = as_model(model)
    refuse_actuation_redundancy(model, "the actuator-space model")
    n, na = len(model.coordinates), model.n_actuators
    qs, theta_dots, shape = as_broadcast(("q", q, n), ("theta_dot", theta_dot, na))
    check_loop_closure(model, qs, shape)
    _regular(model, qs, shape)
    M, c, g = np.empty((len(qs), na, na)), np.empty((len(qs), na)), np.empty((len(qs), na))
    with np.errstate(**_QUIET):
        failed = model.kernels.actuator_space_models(qs, theta_dots, model.P, M, c, g)
    if failed >= 0:
        raise SingularityError(f"q{index_text(int(failed), shape)} is at a gain-type singularity")
    refuse_overflow("theta_dot", c)
    return ActuatorSpaceModel(M.reshape(*shape, na, na), c.reshape(*shape, na), g.reshape(*shape, na))


def inverse_dynamics(model: MechanismModel, q, theta_dot, theta_ddot) -> np.ndarray:
    """The actuator efforts ``τ = Mθ θ̈ + cθ + gθ`` that give the actuators the accelerations ``theta_ddot`` (eq. 35).

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations on the loop closure (rad or m per entry).
    theta_dot : array_like, shape (..., n_actuators)
        The actuator rates (rad/s or m/s).
    theta_ddot : array_like, shape (..., n_actuators)
        The actuator accelerations (rad/s² or m/s²); all three broadcast.

    Returns
    -------
    ndarray, shape (..., n_actuators)
        The efforts ``τ`` (N·m for a revolute actuator, N for a prismatic one).

    Raises
    ------
    SingularityError
        At a gain-type singularity (``|S| < 1e-6``).
    InvalidParameterError
        If ``q`` is off the loop closure, the shapes do not broadcast, or the values overflow.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> q = pkmlab.inverse_kinematics(model, [0.0, 0.35], mode=(1, -1)).q
    >>> np.round(pkmlab.inverse_dynamics(model, q, [0.5, -0.2], [1.0, 2.0]), 4).tolist()
    [0.0204, 0.0486]
    """
    model = as_model(model)
    refuse_actuation_redundancy(model, "the actuator-space model")
    n, na = len(model.coordinates), model.n_actuators
    qs, theta_dots, theta_ddots, shape = as_broadcast(("q", q, n), ("theta_dot", theta_dot, na),
                                                      ("theta_ddot", theta_ddot, na))
    r = actuator_space_model(model, qs, theta_dots)
    with np.errstate(**_QUIET):
        tau = np.einsum("kij,kj->ki", r.M, theta_ddots) + r.c + r.g
    refuse_overflow("theta_ddot", tau)
    return tau.reshape(*shape, na)


def forward_dynamics(model: MechanismModel, q, theta_dot, tau) -> np.ndarray:
    """The actuator accelerations ``θ̈ = Mθ⁻¹ (τ - cθ - gθ)`` under efforts ``tau`` (eq. 35).

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations on the loop closure (rad or m per entry).
    theta_dot : array_like, shape (..., n_actuators)
        The actuator rates (rad/s or m/s).
    tau : array_like, shape (..., n_actuators)
        The actuator efforts (N·m or N); all three broadcast.

    Returns
    -------
    ndarray, shape (..., n_actuators)
        The actuator accelerations ``θ̈`` (rad/s² or m/s²).

    Raises
    ------
    SingularityError
        At a gain-type singularity (``|S| < 1e-6``).
    InvalidParameterError
        If ``q`` is off the loop closure, the shapes do not broadcast, or the values overflow.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> q = pkmlab.inverse_kinematics(model, [0.0, 0.35], mode=(1, -1)).q
    >>> tau = pkmlab.inverse_dynamics(model, q, [0.5, -0.2], [1.0, 2.0])
    >>> np.round(pkmlab.forward_dynamics(model, q, [0.5, -0.2], tau), 6).tolist()
    [1.0, 2.0]
    """
    model = as_model(model)
    refuse_actuation_redundancy(model, "the actuator-space model")
    n, na = len(model.coordinates), model.n_actuators
    qs, theta_dots, taus, shape = as_broadcast(("q", q, n), ("theta_dot", theta_dot, na), ("tau", tau, na))
    r = actuator_space_model(model, qs, theta_dots)
    with np.errstate(**_QUIET):
        theta_ddot = np.linalg.solve(r.M, (taus - r.c - r.g)[..., None])[..., 0]
    refuse_overflow("tau", theta_ddot)
    return theta_ddot.reshape(*shape, na)
