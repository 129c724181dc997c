"""Dynamics of the planar 3-RRR: the constrained Lagrangian model in the full configuration
space (paper §3.1, eqs. 20–26) and its exact reduction to the actuator space (§3.2, eq. 35).

The two are computed independently, so that each checks the other: the full-space model from
the paper's seven coordinates and its bodies written as rotating vectors
(:func:`pkmlab.paper.rrr3.bodies`, :mod:`pkmlab.numerics.lagrangian`); the actuator-space model by the
compiled core every mechanism shares (:func:`pkmlab.codegen.core.dynamics.actuator_space_model`, on the
machine's description, :meth:`~pkmlab.model.mechanism_model.MechanismModel.from_3rrr`) — the model the
simulation integrates and the computed-torque controller uses.

Configurations ``q`` must lie on the constraint manifold (from inverse kinematics, forward
kinematics or branch following): the functions of the constrained or reduced model refuse one whose
loop-closure residual exceeds ``CLOSURE_TOLERANCE`` times the machine's size, naming it, and rates or
efforts so large that the model overflows are refused too; velocities are given as actuated rates ``θ̇`` and lifted
with ``q̇ = Jqθ θ̇`` (eq. 31), except in the full-space functions that take ``q̇`` itself.
Every function broadcasts over leading dimensions.

Units: ``M`` in kg·m² (angles as coordinates), torques in N·m, ``λ`` in N.

Examples
--------
>>> import numpy as np
>>> from pkmlab.paper.geometry import Planar3RRR
>>> from pkmlab.paper.kinematics import inverse_kinematics
>>> from pkmlab.paper.dynamics import actuator_space_model
>>> model = Planar3RRR.paper()
>>> q = inverse_kinematics(model, [0.2, 0.21, 0.0], mode=(-1, 1, -1)).q
>>> m_theta, c_theta = actuator_space_model(model, q, [0.0, 0.0, 0.0])
>>> bool(np.all(np.linalg.eigvalsh(m_theta) > 0)), float(np.abs(c_theta).max())
(True, 0.0)
"""

from __future__ import annotations

import numpy as np

from .._compile_cache import njit
from .._validate import as_batch, as_broadcast, as_pair
from ..algorithms.dynamics import refuse_overflow
from ..model.mechanism_model import MechanismModel
from ..numerics import closed_chain, lagrangian
from . import rrr3
from .geometry import Planar3RRR
from .kinematics import as_paper_model, constraint_residual, coordinates_from_3rrr, require_on_closure, require_regular

__all__ = [
    "mass_matrix",
    "coriolis_matrix",
    "velocity_product",
    "kinetic_energy",
    "constrained_accelerations",
    "lagrange_multipliers",
    "actuator_space_model",
    "actuator_space_coriolis_matrix",
    "inverse_dynamics",
    "forward_dynamics",
]


# ------------------------------------------------------------------ compiled batch drivers
@njit(cache=True)
def _full_space_batch(qs, qds, P, M_out, C_out, h_out, T_out):
    for k in range(qs.shape[0]):
        J, H, bias, D = rrr3.bodies(qs[k], qds[k], P, True)
        M_out[k] = lagrangian.mass_matrix(J, D)
        C_out[k] = lagrangian.christoffel_matrix(lagrangian.mass_matrix_partials(J, H, D), qds[k])
        h_out[k] = lagrangian.velocity_product(J, D, bias)
        T_out[k] = 0.5 * (qds[k] @ (M_out[k] @ qds[k]))


@njit(cache=True)
def _constrained_batch(qs, qds, taus, P, explicit, q_ddot_out, lam_out, lam_explicit_out, ok):
    jac = np.empty((4, 7))
    gamma = np.empty(4)
    for k in range(qs.shape[0]):
        q_ddot_out[k], lam_out[k], ok[k] = rrr3.full_dynamics(qs[k], qds[k], taus[k], P, 0.0)
        if not explicit:
            continue
        rrr3.constraint_jacobian(qs[k], P, jac)
        rrr3.constraint_convective(qs[k], qds[k], P, gamma)
        J, _H, bias, D = rrr3.bodies(qs[k], qds[k], P, False)
        tau_q = np.zeros(7)
        tau_q[:3] = taus[k]
        lam_explicit_out[k], _ok = lagrangian.lagrange_multipliers(
            lagrangian.mass_matrix(J, D), lagrangian.velocity_product(J, D, bias), jac, gamma, tau_q
        )


@njit(cache=True)
def _coriolis_theta_batch(qs, theta_dots, P, out, ok):
    jac = np.empty((4, 7))
    jac_rate = np.empty((4, 7))
    for k in range(qs.shape[0]):
        rrr3.constraint_jacobian(qs[k], P, jac)
        j_q_theta, ok[k] = closed_chain.actuated_jacobian(jac, 3)
        q_dot = j_q_theta @ theta_dots[k]
        rrr3.constraint_jacobian_rate(qs[k], q_dot, P, jac_rate)
        # J̇φθ = -Jηφ⁻¹ (J̇ηθ + J̇ηφ Jφθ), from d/dt (Jηφ Jφθ + Jηθ) = 0
        rhs = jac_rate[:, :3] + np.ascontiguousarray(jac_rate[:, 3:]) @ np.ascontiguousarray(j_q_theta[3:])
        x, ok_solve = closed_chain.lu_solve(jac[:, 3:], rhs)
        j_q_theta_dot = np.zeros((7, 3))
        j_q_theta_dot[3:] = -x
        J, H, _bias, D = rrr3.bodies(qs[k], q_dot, P, True)
        M = lagrangian.mass_matrix(J, D)
        C = lagrangian.christoffel_matrix(lagrangian.mass_matrix_partials(J, H, D), q_dot)
        out[k] = lagrangian.actuator_space_coriolis_matrix(M, C, j_q_theta, j_q_theta_dot)
        ok[k] = ok[k] and ok_solve


def _on_closure(model, qs, shape) -> None:
    require_on_closure(model, constraint_residual(model, qs).reshape(-1, 4), shape)


# ------------------------------------------------------------------ full configuration space
def _full_space(model, q, q_dot):
    qs, qds, shape = as_pair("q", q, 7, "q_dot", q_dot, 7)
    n = qs.shape[0]
    M = np.empty((n, 7, 7))
    C = np.empty((n, 7, 7))
    h = np.empty((n, 7))
    T = np.empty(n)
    _full_space_batch(qs, qds, as_paper_model(model).packed, M, C, h, T)
    return shape, M, C, h, T


def mass_matrix(model: Planar3RRR, q) -> np.ndarray:
    """``M(q)`` (..., 7, 7) of the seven bodies in the full coordinates (eqs. 20–23).

    Any configuration is accepted (the bodies need no loop closure).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad), on the loop closure or not.

    Returns
    -------
    ndarray, shape (..., 7, 7)
        The symmetric, positive-definite mass matrix (kg·m², the coordinates being angles).

    Raises
    ------
    InvalidParameterError
        If ``q`` does not have 7 components or ``model`` is not a Planar3RRR.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import inverse_kinematics
    >>> from pkmlab.paper.dynamics import mass_matrix
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> m = mass_matrix(model, q)
    >>> m.shape, bool(np.allclose(m, m.T) and np.all(np.linalg.eigvalsh(m) > 0))
    ((7, 7), True)
    """
    qs, shape = as_batch("q", q, 7)
    _s, M, _C, _h, _T = _full_space(model, qs, np.zeros_like(qs))
    return M.reshape(*shape, 7, 7)


def coriolis_matrix(model: Planar3RRR, q, q_dot) -> np.ndarray:
    """``C(q, q̇)`` (..., 7, 7) from the Christoffel symbols of ``M`` (eq. 24).

    Any configuration and rates are accepted (the full-space model needs no loop closure).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad), on the loop closure or not.
    q_dot : array_like, shape (..., 7)
        Their rates (rad/s), broadcast against ``q``.

    Returns
    -------
    ndarray, shape (..., 7, 7)
        ``C`` (kg·m²/s): ``C q̇`` is the centripetal and Coriolis torques (N·m).

    Raises
    ------
    InvalidParameterError
        If an argument does not have 7 components or ``model`` is not a Planar3RRR.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import coordinate_rates, inverse_kinematics
    >>> from pkmlab.paper.dynamics import coriolis_matrix, velocity_product
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> q_dot = coordinate_rates(model, q, [0.1, -0.2, 0.3])
    >>> bool(np.allclose(coriolis_matrix(model, q, q_dot) @ q_dot, velocity_product(model, q, q_dot)))
    True
    """
    shape, _M, C, _h, _T = _full_space(model, q, q_dot)
    return C.reshape(*shape, 7, 7)


def velocity_product(model: Planar3RRR, q, q_dot) -> np.ndarray:
    """``C(q, q̇) q̇`` (..., 7) computed directly from the bodies' centripetal accelerations.

    Any configuration and rates are accepted (the full-space model needs no loop closure).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad), on the loop closure or not.
    q_dot : array_like, shape (..., 7)
        Their rates (rad/s), broadcast against ``q``.

    Returns
    -------
    ndarray, shape (..., 7)
        The centripetal and Coriolis torques (N·m), one per coordinate.

    Raises
    ------
    InvalidParameterError
        If an argument does not have 7 components or ``model`` is not a Planar3RRR.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.dynamics import velocity_product
    >>> model = Planar3RRR.paper()
    >>> h = velocity_product(model, np.zeros(7), np.full(7, 0.5))  # any q: the bodies alone
    >>> h.shape, bool(np.allclose(velocity_product(model, np.zeros(7), np.zeros(7)), 0.0))  # zero at rest
    ((7,), True)
    """
    shape, _M, _C, h, _T = _full_space(model, q, q_dot)
    return h.reshape(*shape, 7)


def kinetic_energy(model: Planar3RRR, q, q_dot) -> np.ndarray:
    """``T = ½ q̇ᵀ M q̇`` (...) in joules (eq. 20).

    Any configuration and rates are accepted (the full-space model needs no loop closure).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad), on the loop closure or not.
    q_dot : array_like, shape (..., 7)
        Their rates (rad/s), broadcast against ``q``.

    Returns
    -------
    ndarray, shape (...)
        The kinetic energy of the seven bodies (J).

    Raises
    ------
    InvalidParameterError
        If an argument does not have 7 components or ``model`` is not a Planar3RRR.

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import coordinate_rates, inverse_kinematics
    >>> from pkmlab.paper.dynamics import kinetic_energy, mass_matrix
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> q_dot = coordinate_rates(model, q, [0.1, -0.2, 0.3])
    >>> energy = float(kinetic_energy(model, q, q_dot))
    >>> round(energy, 6), bool(np.isclose(energy, 0.5 * q_dot @ mass_matrix(model, q) @ q_dot))
    (0.004651, True)
    """
    shape, _M, _C, _h, T = _full_space(model, q, q_dot)
    return T.reshape(shape)


def _constrained(model, q, q_dot, tau, explicit=False):
    qs, qds, taus, shape = as_broadcast(("q", q, 7), ("q_dot", q_dot, 7), ("tau", tau, 3))
    n = qs.shape[0]
    q_ddot = np.empty((n, 7))
    multipliers = np.empty((n, 4))
    lam_explicit = np.empty((n, 4))
    ok = np.zeros(n, dtype=np.bool_)
    _on_closure(model, qs, shape)
    with np.errstate(over="ignore", invalid="ignore"):
        _constrained_batch(qs, qds, taus, as_paper_model(model).packed, explicit, q_ddot, multipliers, lam_explicit,
                           ok)
    require_regular(ok, shape, "the constrained dynamics")
    refuse_overflow("q_dot or tau", q_ddot, multipliers, lam_explicit)
    return shape, q_ddot, multipliers, lam_explicit


def constrained_accelerations(model: Planar3RRR, q, q_dot, tau) -> tuple[np.ndarray, np.ndarray]:
    """``(q̈, λ)`` of the full model ``M q̈ + C q̇ = τ + Jηqᵀ λ``, ``Jηq q̈ + J̇ηq q̇ = 0`` (eq. 26).

    ``tau`` (..., 3) are the actuator torques (N·m); ``λ`` (..., 4) the forces (N) that the
    loop-closing joints transmit, in the order of ``η`` (x and y at ``p2`` through loop 1, then
    at ``p3`` through loop 2).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).
    q_dot : array_like, shape (..., 7)
        Their rates (rad/s); a motion of the machine has ``Jηq q̇ = 0`` (e.g. from
        :func:`~pkmlab.paper.kinematics.coordinate_rates`).
    tau : array_like, shape (..., 3)
        The actuator torques (N·m); the three arguments are broadcast together.

    Returns
    -------
    q_ddot : ndarray, shape (..., 7)
        The coordinates' accelerations (rad/s²).
    multipliers : ndarray, shape (..., 4)
        The loop-closing joints' forces ``λ`` (N).

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), ``q_dot`` or ``tau`` is so large that the model
        overflows, or an argument has the wrong shape.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import constraint_jacobian, coordinate_rates, inverse_kinematics
    >>> from pkmlab.paper.dynamics import constrained_accelerations, mass_matrix, velocity_product
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> q_dot, tau = coordinate_rates(model, q, [0.1, -0.2, 0.3]), np.array([0.1, 0.0, -0.1])
    >>> q_ddot, lam = constrained_accelerations(model, q, q_dot, tau)
    >>> np.round(lam, 4).tolist()
    [0.0517, 0.0316, -0.0931, 0.0491]
    >>> lhs = mass_matrix(model, q) @ q_ddot + velocity_product(model, q, q_dot)
    >>> bool(np.allclose(lhs, np.r_[tau, 0, 0, 0, 0] + constraint_jacobian(model, q).T @ lam))  # eq. (26)
    True
    """
    shape, q_ddot, multipliers, _le = _constrained(model, q, q_dot, tau)
    return q_ddot.reshape(*shape, 7), multipliers.reshape(*shape, 4)


def lagrange_multipliers(model: Planar3RRR, q, q_dot, tau) -> np.ndarray:
    """``λ`` (..., 4) in newtons from the paper's explicit formula (after eq. 26).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).
    q_dot : array_like, shape (..., 7)
        Their rates (rad/s), as for :func:`constrained_accelerations`.
    tau : array_like, shape (..., 3)
        The actuator torques (N·m); the three arguments are broadcast together.

    Returns
    -------
    ndarray, shape (..., 4)
        The forces (N) that the loop-closing joints transmit, in the order of ``η``.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), ``q_dot`` or ``tau`` is so large that the model
        overflows, or an argument has the wrong shape.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import coordinate_rates, inverse_kinematics
    >>> from pkmlab.paper.dynamics import constrained_accelerations, lagrange_multipliers
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> q_dot, tau = coordinate_rates(model, q, [0.1, -0.2, 0.3]), [0.1, 0.0, -0.1]
    >>> lam = lagrange_multipliers(model, q, q_dot, tau)
    >>> bool(np.allclose(lam, constrained_accelerations(model, q, q_dot, tau)[1]))  # the solver's λ
    True
    """
    shape, _qdd, _multipliers, lam_explicit = _constrained(model, q, q_dot, tau, explicit=True)
    return lam_explicit.reshape(*shape, 4)


# ------------------------------------------------------------------ actuator space
def actuator_space_model(model: Planar3RRR, q, theta_dot) -> tuple[np.ndarray, np.ndarray]:
    """``(Mθ, Cθ θ̇)``: ``Mθ = Jqθᵀ M Jqθ`` (..., 3, 3) and ``Jqθᵀ (M J̇qθ + C Jqθ) θ̇`` (..., 3), eq. (35).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).
    theta_dot : array_like, shape (..., 3)
        Actuated rates (rad/s), broadcast against ``q``.

    Returns
    -------
    m_theta : ndarray, shape (..., 3, 3)
        The actuator-space mass matrix (kg·m²), symmetric and positive definite.
    c_theta_dot : ndarray, shape (..., 3)
        The actuators' centripetal and Coriolis torques ``Cθ θ̇`` (N·m).

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), ``theta_dot`` is so large that the model
        overflows, or an argument has the wrong shape.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import actuated_jacobian, inverse_kinematics
    >>> from pkmlab.paper.dynamics import actuator_space_model, mass_matrix
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> m_theta, c_theta_dot = actuator_space_model(model, q, [0.1, -0.2, 0.3])
    >>> j_q_theta = actuated_jacobian(model, q)
    >>> bool(np.allclose(m_theta, j_q_theta.T @ mass_matrix(model, q) @ j_q_theta)), c_theta_dot.shape
    (True, (3,))
    """
    qs, theta_dots, shape = as_pair("q", q, 7, "theta_dot", theta_dot, 3)
    m, c = _reduced_model(model, qs, theta_dots, shape, "the actuator-space model")
    return m.reshape(*shape, 3, 3), c.reshape(*shape, 3)


def _reduced_model(model, qs, theta_dots, shape, what):
    """``(Mθ, Cθ θ̇)`` (K, 3, 3), (K, 3) at configurations ``qs`` (K, 7): the compiled core's actuator-space model
    (:func:`pkmlab.codegen.core.dynamics.actuator_space_model`) on the machine's description, the simulation's own."""
    _on_closure(model, qs, shape)
    machine = MechanismModel.from_3rrr(as_paper_model(model))
    n = qs.shape[0]
    m, c, g = np.empty((n, 3, 3)), np.empty((n, 3)), np.empty((n, 3))
    first_singular = machine.kernels.actuator_space_models(np.ascontiguousarray(coordinates_from_3rrr(model, qs)),
                                                           np.ascontiguousarray(theta_dots), machine.P, m, c, g)
    ok = np.ones(n, dtype=np.bool_)
    if first_singular >= 0:
        ok[first_singular] = False
    require_regular(ok, shape, what)
    refuse_overflow("theta_dot", c)
    return m, c  # no gravity: the paper's machine is horizontal


def actuator_space_coriolis_matrix(model: Planar3RRR, q, theta_dot) -> np.ndarray:
    """``Cθ = Jqθᵀ (M J̇qθ + C Jqθ)`` (..., 3, 3) as a matrix, with ``C`` from eq. (24).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).
    theta_dot : array_like, shape (..., 3)
        Actuated rates (rad/s), broadcast against ``q``.

    Returns
    -------
    ndarray, shape (..., 3, 3)
        ``Cθ`` (kg·m²/s): ``Cθ θ̇`` is the actuators' centripetal and Coriolis torques (N·m).

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), ``theta_dot`` is so large that the model
        overflows, or an argument has the wrong shape.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import inverse_kinematics
    >>> from pkmlab.paper.dynamics import actuator_space_coriolis_matrix, actuator_space_model
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> theta_dot = np.array([0.1, -0.2, 0.3])
    >>> c_theta = actuator_space_coriolis_matrix(model, q, theta_dot)
    >>> bool(np.allclose(c_theta @ theta_dot, actuator_space_model(model, q, theta_dot)[1]))
    True
    """
    qs, theta_dots, shape = as_pair("q", q, 7, "theta_dot", theta_dot, 3)
    out = np.empty((qs.shape[0], 3, 3))
    ok = np.zeros(qs.shape[0], dtype=np.bool_)
    _on_closure(model, qs, shape)
    with np.errstate(over="ignore", invalid="ignore"):
        _coriolis_theta_batch(qs, theta_dots, as_paper_model(model).packed, out, ok)
    require_regular(ok, shape, "C_theta")
    refuse_overflow("theta_dot", out)
    return out.reshape(*shape, 3, 3)


def inverse_dynamics(model: Planar3RRR, q, theta_dot, theta_ddot) -> np.ndarray:
    """Actuator torques ``τ = Mθ θ̈ + Cθ θ̇`` (..., 3) that produce ``θ̈`` (eq. 35).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).
    theta_dot : array_like, shape (..., 3)
        Actuated rates (rad/s).
    theta_ddot : array_like, shape (..., 3)
        Actuated accelerations (rad/s²); the three arguments are broadcast together.

    Returns
    -------
    ndarray, shape (..., 3)
        The actuator torques (N·m).

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), ``theta_dot`` or ``theta_ddot`` is so large that
        the model overflows, or an argument has the wrong shape.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import inverse_kinematics
    >>> from pkmlab.paper.dynamics import inverse_dynamics
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> np.round(inverse_dynamics(model, q, [0.1, -0.2, 0.3], [1.0, 0.0, -0.5]), 5).tolist()
    [0.08477, -0.06729, -0.00793]
    """
    qs, theta_dots, theta_ddots, shape = as_broadcast(("q", q, 7), ("theta_dot", theta_dot, 3),
                                                      ("theta_ddot", theta_ddot, 3))
    m_theta, c_theta = actuator_space_model(model, qs.reshape(*shape, 7), theta_dots.reshape(*shape, 3))
    with np.errstate(over="ignore", invalid="ignore"):
        tau = np.einsum("...ij,...j->...i", m_theta, theta_ddots.reshape(*shape, 3)) + c_theta
    refuse_overflow("theta_ddot", tau)
    return tau


def forward_dynamics(model: Planar3RRR, q, theta_dot, tau) -> np.ndarray:
    """Actuated accelerations ``θ̈ = Mθ⁻¹ (τ - Cθ θ̇)`` (..., 3) under torques ``τ`` (eq. 35).

    Parameters
    ----------
    model : Planar3RRR
        The machine (e.g. :meth:`Planar3RRR.paper() <pkmlab.paper.geometry.Planar3RRR.paper>`).
    q : array_like, shape (..., 7)
        Configurations on the loop closure, ``(θ1, θ2, θ3, φ1, φ2, φ3, α)`` (rad).
    theta_dot : array_like, shape (..., 3)
        Actuated rates (rad/s).
    tau : array_like, shape (..., 3)
        The actuator torques (N·m); the three arguments are broadcast together.

    Returns
    -------
    ndarray, shape (..., 3)
        The actuated accelerations (rad/s²).

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual), ``theta_dot`` or ``tau`` is so large that the
        model overflows, or an argument has the wrong shape.
    SingularityError
        At a gain-type singularity (``det(Jηφ) = 0``).

    Examples
    --------
    >>> import numpy as np
    >>> from pkmlab.paper.geometry import Planar3RRR
    >>> from pkmlab.paper.kinematics import coordinate_rates, inverse_kinematics
    >>> from pkmlab.paper.dynamics import constrained_accelerations, forward_dynamics, inverse_dynamics
    >>> model = Planar3RRR.paper()
    >>> q = inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> theta_dot, theta_ddot = np.array([0.1, -0.2, 0.3]), np.array([1.0, 0.0, -0.5])
    >>> tau = inverse_dynamics(model, q, theta_dot, theta_ddot)
    >>> bool(np.allclose(forward_dynamics(model, q, theta_dot, tau), theta_ddot))
    True
    >>> q_ddot, _ = constrained_accelerations(model, q, coordinate_rates(model, q, theta_dot), tau)
    >>> bool(np.allclose(q_ddot[:3], theta_ddot))  # the full-space model agrees
    True
    """
    qs, theta_dots, taus, shape = as_broadcast(("q", q, 7), ("theta_dot", theta_dot, 3), ("tau", tau, 3))
    m, c = _reduced_model(model, qs, theta_dots, shape, "the forward dynamics")
    with np.errstate(over="ignore", invalid="ignore"):
        theta_ddot = np.linalg.solve(m, (taus - c)[..., None])[..., 0]
    refuse_overflow("tau", theta_ddot)
    return theta_ddot.reshape(*shape, 3)
