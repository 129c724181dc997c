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
from ..errors import InvalidParameterError
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


def _finite(name: str, *arrays) -> None:
    """Refuse a result that overflowed (rates of 1e200 squared), naming the input that was too large."""
    if not all(np.all(np.isfinite(a)) for a in arrays):
        raise InvalidParameterError(f"{name} overflows the model (values too large)")


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
    """``M(q)`` (..., 7, 7) of the seven bodies in the full coordinates (eqs. 20–23)."""
    qs, shape = as_batch("q", q, 7)
    _s, M, _C, _h, _T = _full_space(model, qs, np.zeros_like(qs))
    return M.reshape(*shape, 7, 7)


def coriolis_matrix(model: Planar3RRR, q, q_dot) -> np.ndarray:
    """``C(q, q̇)`` (..., 7, 7) from the Christoffel symbols of ``M`` (eq. 24)."""
    shape, _M, C, _h, _T = _full_space(model, q, q_dot)
    return C.reshape(*shape, 7, 7)


def velocity_product(model: Planar3RRR, q, q_dot) -> np.ndarray:
    """``C(q, q̇) q̇`` (..., 7) computed directly from the bodies' centripetal accelerations."""
    shape, _M, _C, h, _T = _full_space(model, q, q_dot)
    return h.reshape(*shape, 7)


def kinetic_energy(model: Planar3RRR, q, q_dot) -> np.ndarray:
    """``T = ½ q̇ᵀ M q̇`` (...) in joules (eq. 20)."""
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
    _finite("q_dot or tau", q_ddot, multipliers, lam_explicit)
    return shape, q_ddot, multipliers, lam_explicit


def constrained_accelerations(model: Planar3RRR, q, q_dot, tau) -> tuple[np.ndarray, np.ndarray]:
    """``(q̈, λ)`` of the full model ``M q̈ + C q̇ = τ + Jηqᵀ λ``, ``Jηq q̈ + J̇ηq q̇ = 0`` (eq. 26).

    ``tau`` (..., 3) are the actuator torques (N·m); ``λ`` (..., 4) the forces (N) that the
    loop-closing joints transmit, in the order of ``η`` (x and y at ``p2`` through loop 1, then
    at ``p3`` through loop 2).
    """
    shape, q_ddot, multipliers, _le = _constrained(model, q, q_dot, tau)
    return q_ddot.reshape(*shape, 7), multipliers.reshape(*shape, 4)


def lagrange_multipliers(model: Planar3RRR, q, q_dot, tau) -> np.ndarray:
    """``λ`` (..., 4) in newtons from the paper's explicit formula (after eq. 26)."""
    shape, _qdd, _multipliers, lam_explicit = _constrained(model, q, q_dot, tau, explicit=True)
    return lam_explicit.reshape(*shape, 4)


# ------------------------------------------------------------------ actuator space
def actuator_space_model(model: Planar3RRR, q, theta_dot) -> tuple[np.ndarray, np.ndarray]:
    """``(Mθ, Cθ θ̇)``: ``Mθ = Jqθᵀ M Jqθ`` (..., 3, 3) and ``Jqθᵀ (M J̇qθ + C Jqθ) θ̇`` (..., 3), eq. (35)."""
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
    _finite("theta_dot", c)
    return m, c  # no gravity: the paper's machine is horizontal


def actuator_space_coriolis_matrix(model: Planar3RRR, q, theta_dot) -> np.ndarray:
    """``Cθ = Jqθᵀ (M J̇qθ + C Jqθ)`` (..., 3, 3) as a matrix, with ``C`` from eq. (24)."""
    qs, theta_dots, shape = as_pair("q", q, 7, "theta_dot", theta_dot, 3)
    out = np.empty((qs.shape[0], 3, 3))
    ok = np.zeros(qs.shape[0], dtype=np.bool_)
    _on_closure(model, qs, shape)
    with np.errstate(over="ignore", invalid="ignore"):
        _coriolis_theta_batch(qs, theta_dots, as_paper_model(model).packed, out, ok)
    require_regular(ok, shape, "C_theta")
    _finite("theta_dot", out)
    return out.reshape(*shape, 3, 3)


def inverse_dynamics(model: Planar3RRR, q, theta_dot, theta_ddot) -> np.ndarray:
    """Actuator torques ``τ = Mθ θ̈ + Cθ θ̇`` (..., 3) that produce ``θ̈`` (eq. 35)."""
    qs, theta_dots, theta_ddots, shape = as_broadcast(("q", q, 7), ("theta_dot", theta_dot, 3),
                                                      ("theta_ddot", theta_ddot, 3))
    m_theta, c_theta = actuator_space_model(model, qs.reshape(*shape, 7), theta_dots.reshape(*shape, 3))
    with np.errstate(over="ignore", invalid="ignore"):
        tau = np.einsum("...ij,...j->...i", m_theta, theta_ddots.reshape(*shape, 3)) + c_theta
    _finite("theta_ddot", tau)
    return tau


def forward_dynamics(model: Planar3RRR, q, theta_dot, tau) -> np.ndarray:
    """Actuated accelerations ``θ̈ = Mθ⁻¹ (τ - Cθ θ̇)`` (..., 3) under torques ``τ`` (eq. 35)."""
    qs, theta_dots, taus, shape = as_broadcast(("q", q, 7), ("theta_dot", theta_dot, 3), ("tau", tau, 3))
    m, c = _reduced_model(model, qs, theta_dots, shape, "the forward dynamics")
    with np.errstate(over="ignore", invalid="ignore"):
        theta_ddot = np.linalg.solve(m, (taus - c)[..., None])[..., 0]
    _finite("tau", theta_ddot)
    return theta_ddot.reshape(*shape, 3)
