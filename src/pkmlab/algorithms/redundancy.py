"""Redundant actuation: more actuators than degrees of freedom, and how their efforts are shared.

A redundantly actuated machine (a 4-RRR: four actuated legs for the platform's three coordinates) is modelled
in its **controlled coordinates** ``x`` (the pose, :attr:`~pkmlab.model.mechanism_model.MechanismModel.pose_names`)
rather than in its actuators, which are no longer independent:

* the configuration from the pose is every leg's inverse kinematics (no forward kinematics, no branch
  following), and ``q̇ = Jqx ẋ`` (:func:`~pkmlab.algorithms.kinematics.pose_coordinate_jacobian`), the dependent
  coordinates' rates from the loop closures ``Jηq q̇ = 0``;
* the actuators' rates are ``θ̇ = W ẋ``, ``W = ∂θ/∂x`` (:func:`~pkmlab.algorithms.kinematics.actuation_jacobian`,
  ``n_a × dof``): its transpose maps the actuator efforts to the generalised forces they exert in the pose,
  ``Wᵀ τ`` — the platform wrench of the actuation;
* the dynamics are ``Mx ẍ + cx + gx = Wᵀ τ`` (:func:`pose_space_model`), with ``Mx = Jqxᵀ M Jqx``,
  ``cx = Jqxᵀ (M J̇qx ẋ + C q̇)``, ``gx = Jqxᵀ g``, from the same full-space model as every other machine's.

``Wᵀ τ = f`` has a set of solutions for given generalised forces ``f``: a particular one plus any element of the
null space of ``Wᵀ`` (dimension ``n_a - dof``), the **internal efforts**, which the actuators exert against each
other and which move nothing (on the rigid model). :func:`distribute_efforts` picks one solution by a stated rule:
the minimum 2-norm (the pseudo-inverse's), a weighted 2-norm, the minimum largest effort (a linear program), or
the minimum norm plus a given internal preload (antagonistic stiffness); each within declared effort limits,
solved exactly (the 2-norm rules with limits as a quadratic program by its active sets; the largest effort by
SciPy's HiGHS), and refused in one line naming the actuator the limits cannot hold.

The forward singularities of such a machine are where ``W`` loses rank: a platform motion no actuator feels.
:func:`~pkmlab.algorithms.kinematics.actuation_singularity_measure` is ``W``'s smallest singular value (its
orientation column divided by the platform's size, so that every column is in actuator units per metre). Adding
actuators adds rows to ``W`` and can only raise it: the measure of the redundant machine is at least that of any of
its non-redundant sub-machines, zero only where every one of them is singular.

Every function applies to any machine; for one of ``n_a = dof`` actuators ``W`` is square, the inverse of
:func:`~pkmlab.algorithms.kinematics.velocity_jacobian`, and the distribution unique.

Examples
--------
>>> import numpy as np
>>> import pkmlab
>>> model = pkmlab.load("examples/mechanisms/4rrr.toml")
>>> model.n_actuators, model.dof, model.description.actuation_redundancy
(4, 3, 1)
>>> q = pkmlab.inverse_kinematics(model, [0.26, 0.27, 0.1], mode=(1, 1, 1, 1)).q
>>> W = pkmlab.actuation_jacobian(model, q)
>>> W.shape
(4, 3)
>>> shared = pkmlab.distribute_efforts(W, [1.0, 0.0, 0.0])
>>> bool(np.allclose(W.T @ shared.tau, [1.0, 0.0, 0.0]))
True
"""

from __future__ import annotations

import itertools
from dataclasses import dataclass

import numpy as np

from .._validate import as_broadcast, as_choice, real_array
from ..errors import InvalidParameterError, SingularityError, shown
from ..model import mechanism_model as mm
from ..model.mechanism_model import MechanismModel
from .kinematics import _refuse_serial, as_model, check_loop_closure

__all__ = ["EffortDistribution", "PoseSpaceModel", "DISTRIBUTIONS", "pose_space_model", "distribute_efforts"]

#: The rules of :func:`distribute_efforts`, by name.
DISTRIBUTIONS = ("minimum_norm", "weighted", "minimum_peak", "preload")

#: Active sets a limited 2-norm distribution may try (:func:`_bounded_least_norm`): beyond, it is refused.
MAX_ACTIVE_SETS = 100_000


@dataclass(frozen=True)
class PoseSpaceModel:
    """The dynamics in the controlled coordinates, ``Mx ẍ + cx + gx = Wᵀ τ`` (:func:`pose_space_model`).

    Attributes
    ----------
    M : ndarray, shape (..., dof, dof)
        ``Mx = Jqxᵀ M Jqx`` (kg, kg·m, kg·m² by the pose's units), symmetric positive definite.
    c : ndarray, shape (..., dof)
        ``cx = Jqxᵀ (M J̇qx ẋ + C q̇)``: the Coriolis and centrifugal forces (N, N·m).
    g : ndarray, shape (..., dof)
        ``gx = Jqxᵀ g``: the forces that hold the machine still against gravity (N, N·m).
    W : ndarray, shape (..., n_actuators, dof)
        ``W = ∂θ/∂x`` (:func:`~pkmlab.algorithms.kinematics.actuation_jacobian`): ``Wᵀ τ`` is the actuation's
        generalised force.
    """

    M: np.ndarray
    c: np.ndarray
    g: np.ndarray
    W: np.ndarray


@dataclass(frozen=True)
class EffortDistribution:
    """Actuator efforts that exert given generalised forces (:func:`distribute_efforts`).

    Attributes
    ----------
    tau : ndarray, shape (n_actuators,)
        The efforts (N·m or N per actuator): ``Wᵀ tau`` is the requested force to round-off.
    internal : ndarray, shape (n_actuators,)
        The part of ``tau`` in the null space of ``Wᵀ``: what the actuators exert against each other.
    null_space : ndarray, shape (n_actuators, n_actuators - dof)
        An orthonormal basis of that null space (empty columns for a non-redundant machine).
    method : str
        The rule that chose ``tau`` (:data:`DISTRIBUTIONS`).
    """

    tau: np.ndarray
    internal: np.ndarray
    null_space: np.ndarray
    method: str

    @property
    def peak(self) -> float:
        """The largest effort's magnitude, ``max |tau|``."""
        return float(np.abs(self.tau).max())


def pose_space_model(model: MechanismModel, q, pose_dot) -> PoseSpaceModel:
    """The dynamics in the controlled coordinates, ``Mx ẍ + cx + gx = Wᵀ τ``, with ``W``.

    The full-space model (:func:`~pkmlab.algorithms.dynamics.full_space_model`) reduced by ``Jqx``
    (:func:`~pkmlab.algorithms.kinematics.pose_coordinate_jacobian`) as the actuator-space model is by ``Jqθ``:
    exact, and defined at the forward singularities of any sub-machine as long as ``W`` keeps its rank.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations on the loop closure.
    pose_dot : array_like, shape (..., dof)
        The controlled coordinates' rates (m/s, rad/s; broadcast against ``q``).

    Returns
    -------
    PoseSpaceModel
        ``M`` (..., dof, dof), ``c`` and ``g`` (..., dof), ``W`` (..., n_actuators, dof).

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure or the shapes do not broadcast.
    SingularityError
        At a serial singularity of a leg.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("examples/mechanisms/4rrr.toml")
    >>> q = pkmlab.inverse_kinematics(model, [0.26, 0.27, 0.1], mode=(1, 1, 1, 1)).q
    >>> pose_model = pkmlab.pose_space_model(model, q, [0.1, 0.0, 0.5])
    >>> bool(np.allclose(pose_model.M, pose_model.M.T)), bool(np.all(np.linalg.eigvalsh(pose_model.M) > 0))
    (True, True)
    """
    model = as_model(model)
    n, dof = len(model.coordinates), model.dof
    qs, xds, shape = as_broadcast(("q", q, n), ("pose_dot", pose_dot, dof))
    check_loop_closure(model, qs, shape)
    k_ = model.kernels
    j_eta = np.empty((len(qs), k_.N_CONSTRAINTS, n))
    k_.constraint_jacobians(qs, model.P, j_eta)
    jq, singular = mm.pose_jacobians(model, qs, j_eta)
    _refuse_serial(singular, shape)
    q_dots = np.einsum("kij,kj->ki", jq, xds)
    gamma = np.empty((len(qs), k_.N_CONSTRAINTS))
    k_.constraint_biases(qs, q_dots, model.P, gamma)
    # J̇qx ẋ: the coordinates' accelerations at ẍ = 0, from Jηq q̈ + J̇ηq q̇ = 0
    drift = np.zeros((len(qs), n))
    solved, _singular = mm.pose_solve(model, j_eta, gamma[..., None])  # (its singular ones refused above)
    drift[:, mm.dependent_columns(model)] = solved[..., 0]
    M, c, g = np.empty((len(qs), dof, dof)), np.empty((len(qs), dof)), np.empty((len(qs), dof))
    for k in range(len(qs)):
        full_m, full_c, full_g = mm.full_space_model(model, qs[k], q_dots[k])
        M[k] = jq[k].T @ full_m @ jq[k]
        c[k] = jq[k].T @ (full_m @ drift[k] + full_c)
        g[k] = jq[k].T @ full_g
    na = model.n_actuators
    return PoseSpaceModel(M.reshape(*shape, dof, dof), c.reshape(*shape, dof), g.reshape(*shape, dof),
                          jq[:, :na, :].reshape(*shape, na, dof))  # W: the actuators' rows, θ = q[..., :n_a]


# ------------------------------------------------------------------ effort distribution
def internal_efforts(W, tau) -> np.ndarray:
    """The internal part of efforts ``tau`` (..., n_a) for actuation Jacobians ``W`` (..., n_a, dof): their
    projection ``tau - W (WᵀW)⁻¹ Wᵀ tau`` on the null space of ``Wᵀ``, what the actuators exert against each other
    (:attr:`EffortDistribution.internal` of one pose)."""
    W, tau = np.asarray(W, dtype=float), np.asarray(tau, dtype=float)
    wt_tau = np.einsum("...ai,...a->...i", W, tau)
    normal = np.einsum("...ai,...aj->...ij", W, W)
    return tau - np.einsum("...ai,...i->...a", W, np.linalg.solve(normal, wt_tau[..., None])[..., 0])


def _null_space(W: np.ndarray) -> np.ndarray:
    """An orthonormal basis (n_a, n_a - rank) of the null space of ``Wᵀ``; refuses a rank-deficient ``W``."""
    u, s, _vt = np.linalg.svd(W)
    dof = W.shape[1]
    if s[-1] <= 1e-12 * max(s[0], 1.0):
        raise SingularityError(f"the actuation Jacobian W has rank below {dof} (smallest singular value "
                               f"{s[-1]:.3g}): a forward singularity, where no efforts exert every force")
    return u[:, dof:]


def _limits(limits, na: int) -> tuple[np.ndarray, np.ndarray] | None:
    """``(lower, upper)`` of one bound for all (``|τ_i| <= limit``), one per actuator, or ``(lower, upper)`` pairs."""
    if limits is None:
        return None
    arr = real_array("limits", limits)
    if arr.ndim == 0:
        arr = np.full(na, float(arr))
    if arr.shape == (na,):
        lower, upper = -arr, arr
    elif arr.shape == (na, 2):
        lower, upper = arr[:, 0].copy(), arr[:, 1].copy()
    else:
        raise InvalidParameterError(f"limits must be one bound, {na} bounds (|tau_i| <= limit_i) or {na} pairs "
                                    f"(lower, upper), got shape {arr.shape}")
    for i in range(na):
        if np.isnan(lower[i]) or np.isnan(upper[i]) or not lower[i] < upper[i] or lower[i] == np.inf \
                or upper[i] == -np.inf:
            raise InvalidParameterError(f"limits of actuator a{i + 1}: the lower {lower[i]:g} must be below the "
                                        f"upper {upper[i]:g}")
    return lower, upper


def _infeasible(W: np.ndarray, f: np.ndarray, lower: np.ndarray, upper: np.ndarray, where: str) -> str:
    """The one line that says which actuator's limits no distribution of ``f`` respects: the one farthest beyond its
    limits when the farthest is brought as near as it can be — the linear program ``min s`` subject to
    ``Wᵀ τ = f`` and ``lower - s w <= τ <= upper + s w``, ``w`` an actuator's half-range (its limit's size where it
    has one side only), so that the violations compare as fractions of each actuator's own range."""
    from scipy.optimize import linprog

    na, dof = W.shape
    scale = max(float(np.abs(np.linalg.pinv(W.T) @ f).max()), 1e-300)  # of a limit at zero
    two = np.isfinite(lower) & np.isfinite(upper) & (upper - lower < np.inf)
    one_side = np.where(np.isfinite(upper), np.abs(upper), np.abs(lower))
    w = np.where(two, (upper - lower) / 2, np.where(one_side > 0, one_side, scale))
    rows, bounds = [], []
    for i in range(na):
        if np.isfinite(upper[i]):
            rows.append(np.r_[np.eye(na)[i], -w[i]])
            bounds.append(upper[i])
        if np.isfinite(lower[i]):
            rows.append(np.r_[-np.eye(na)[i], -w[i]])
            bounds.append(-lower[i])
    cost = np.r_[np.zeros(na), 1.0]
    result = linprog(cost, A_ub=np.array(rows), b_ub=np.array(bounds), A_eq=np.hstack([W.T, np.zeros((dof, 1))]),
                     b_eq=f, bounds=[(None, None)] * na + [(0, None)], method="highs")
    if result.status != 0:
        return f"{where}the effort limits cannot be held by any efforts that exert the requested forces"
    tau = result.x[:na]
    beyond = np.maximum(tau - upper, lower - tau) / w
    worst = float(beyond.max())
    named = [i for i in range(na) if beyond[i] >= worst - 1e-9 * max(abs(worst), 1.0)]
    i = named[0]
    side, bound, least = ("upper", upper[i], "at least") if tau[i] > upper[i] else ("lower", lower[i], "at most")
    others = f" (as far beyond theirs: {', '.join(f'a{k + 1}' for k in named[1:])})" if len(named) > 1 else ""
    return (f"{where}the effort limits cannot be held: actuator a{i + 1} needs {least} {tau[i]:.6g} against its "
            f"{side} limit {bound:g}{others} for the requested forces")


def _bounded_least_norm(W, f, weights, lower, upper, where):
    """The minimum weighted 2-norm ``τ`` with ``Wᵀ τ = f`` and ``lower <= τ <= upper``, or None where no efforts
    respect the bounds: a strictly convex quadratic program, solved exactly by its active sets (the optimum is the
    equality-constrained optimum of the face it lies on, which at most ``n_a - dof`` bounds define: of the
    candidates that respect every bound, the least norm)."""
    na, dof = W.shape
    free = _weighted_least_norm(W, f, weights, np.zeros(na), np.zeros(na, dtype=bool))
    if np.all(free >= lower - 1e-12 * (1 + np.abs(lower))) and np.all(free <= upper + 1e-12 * (1 + np.abs(upper))):
        return free
    bounds = [(i, side) for i in range(na) for side in (0, 1) if np.isfinite((lower, upper)[side][i])]
    best, best_cost = None, np.inf
    tried = 0
    for size in range(1, na - dof + 1):
        for active in itertools.combinations(bounds, size):
            if len({i for i, _ in active}) < size:
                continue
            tried += 1
            if tried > MAX_ACTIVE_SETS:
                raise InvalidParameterError(f"{where}too many actuators beyond the degrees of freedom for a "
                                            "limited 2-norm distribution; use method='minimum_peak'")
            fixed_value, fixed = np.zeros(na), np.zeros(na, dtype=bool)
            for i, side in active:
                fixed[i], fixed_value[i] = True, (lower, upper)[side][i]
            tau = _weighted_least_norm(W, f, weights, fixed_value, fixed)
            if tau is None:
                continue
            tolerance = 1e-12 * (1 + np.abs(tau))
            if np.all(tau >= lower - tolerance) and np.all(tau <= upper + tolerance):
                cost = float(tau @ (weights * tau))
                if cost < best_cost:
                    best, best_cost = tau, cost
    return best  # None: no efforts within the limits


def _weighted_least_norm(W, f, weights, fixed_value, fixed):
    """The minimum of ``τᵀ diag(weights) τ`` with ``Wᵀ τ = f`` and the ``fixed`` entries at ``fixed_value``; None
    where the fixed entries leave the forces unreachable."""
    free = ~fixed
    wf = W[free]  # (k, dof)
    rhs = f - W[fixed].T @ fixed_value[fixed]
    inverse = 1.0 / weights[free]
    gram = wf.T @ (inverse[:, None] * wf)
    if np.linalg.matrix_rank(gram) < W.shape[1]:
        return None
    tau = fixed_value.copy()
    tau[free] = inverse * (wf @ np.linalg.solve(gram, rhs))
    return tau


def _minimum_peak(W, f, bounds, where):
    """The ``τ`` of least ``max |τ_i|`` with ``Wᵀ τ = f`` (within ``bounds``): the linear program
    ``min t`` subject to ``-t <= τ_i <= t``, solved by SciPy's HiGHS."""
    from scipy.optimize import linprog

    na, dof = W.shape
    cost = np.zeros(na + 1)
    cost[-1] = 1.0
    a_ub = np.vstack([np.hstack([np.eye(na), -np.ones((na, 1))]), np.hstack([-np.eye(na), -np.ones((na, 1))])])
    variable_bounds = [(None, None)] * na if bounds is None else [
        (lo if np.isfinite(lo) else None, hi if np.isfinite(hi) else None) for lo, hi in zip(*bounds, strict=True)]
    result = linprog(cost, A_ub=a_ub, b_ub=np.zeros(2 * na), A_eq=np.hstack([W.T, np.zeros((dof, 1))]), b_eq=f,
                     bounds=[*variable_bounds, (0, None)], method="highs")
    if result.status == 2:
        raise InvalidParameterError(_infeasible(W, f, *bounds, where))
    if result.status != 0:
        raise InvalidParameterError(f"{where}the minimum-peak distribution failed: {result.message}")
    tau = result.x[:na]
    # HiGHS meets the equality to its own tolerance: project back onto Wᵀτ = f exactly (a change of round-off size)
    return tau + W @ np.linalg.solve(W.T @ W, f - W.T @ tau)


def distribute_efforts(W, force, method: str = "minimum_norm", *, weights=None, preload=None, limits=None,
                       where: str = "") -> EffortDistribution:
    """Actuator efforts ``τ`` that exert the generalised forces ``force``: ``Wᵀ τ = force``, chosen by ``method``.

    Parameters
    ----------
    W : array_like, shape (n_actuators, dof)
        The actuation Jacobian (:func:`~pkmlab.algorithms.kinematics.actuation_jacobian`), of full column rank.
    force : array_like, shape (dof,)
        The generalised forces in the controlled coordinates (N, N·m), e.g. ``Mx ẍ + cx + gx``.
    method : {"minimum_norm", "weighted", "minimum_peak", "preload"}
        ``"minimum_norm"``: least ``Σ τ_i²`` (``τ = (Wᵀ)⁺ force``, the pseudo-inverse's). ``"weighted"``: least
        ``Σ w_i τ_i²`` (``weights``). ``"minimum_peak"``: least ``max |τ_i|`` (a linear program). ``"preload"``:
        the minimum-norm efforts plus the internal efforts nearest ``preload`` (its projection on the null
        space of ``Wᵀ``): actuators that pull against each other, the antagonistic stiffness of a real machine.
    weights : array_like, shape (n_actuators,), optional
        Positive weights of ``"weighted"`` (e.g. the inverse squares of the actuators' rated efforts).
    preload : array_like, shape (n_actuators,), optional
        The internal efforts sought by ``"preload"`` (N·m or N per actuator).
    limits : float or array_like, optional
        Effort limits: one bound for every actuator (``|τ_i| <= limit``), one per actuator, or ``(lower, upper)``
        pairs. The 2-norm rules then solve their quadratic program with these bounds exactly; ``"preload"`` takes
        the efforts within them nearest (2-norm) its preloaded efforts.
    where : str, optional
        A prefix of every error's line (e.g. ``"t = 0.25 s: "``).

    Returns
    -------
    EffortDistribution
        ``tau``, its ``internal`` part, the null space's basis, the method.

    Raises
    ------
    InvalidParameterError
        An unknown method, missing or bad weights, preload or limits, or limits no efforts can respect (naming the
        actuator that cannot stay within its own).
    SingularityError
        If ``W`` has rank below ``dof`` (a forward singularity).

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> W = np.array([[1.0, 0.0], [0.0, 1.0], [1.0, 1.0]])
    >>> least = pkmlab.distribute_efforts(W, [1.0, 0.0])
    >>> np.round(least.tau, 4).tolist()
    [0.6667, -0.3333, 0.3333]
    >>> peak = pkmlab.distribute_efforts(W, [1.0, 0.0], "minimum_peak")
    >>> bool(peak.peak <= least.peak), bool(np.allclose(W.T @ peak.tau, [1.0, 0.0]))
    (True, True)
    """
    if not isinstance(where, str):
        raise InvalidParameterError(f"where must be a string (a prefix of the error lines), got {shown(where)}")
    method = as_choice("method", method, DISTRIBUTIONS)
    W = real_array("W", W, "a (n_actuators, dof) matrix of real numbers")
    f = real_array("force", force)
    if f.ndim != 1 or not np.all(np.isfinite(f)):
        raise InvalidParameterError(f"{where}force must be finite generalised forces, one per degree of freedom, got "
                                    f"{shown(force)}")
    if W.shape != (W.shape[0] if W.ndim == 2 else -1, len(f)) or W.shape[0] < len(f) or not np.all(np.isfinite(W)):
        raise InvalidParameterError(f"W must be a finite (n_actuators, {len(f)}) matrix with at least {len(f)} rows "
                                    f"(one column per component of force), got shape {W.shape}")
    na, dof = W.shape
    null = _null_space(W)
    bounds = _limits(limits, na)
    w = np.ones(na)
    if method == "weighted":
        if weights is None:
            raise InvalidParameterError("the weighted distribution needs weights, one positive value per actuator")
        w = real_array("weights", weights)
        if w.shape != (na,) or not np.all(np.isfinite(w)) or not np.all(w > 0) or not np.all(np.isfinite(1.0 / w)):
            raise InvalidParameterError(f"weights must be {na} positive numbers, got {shown(weights)}")
    elif weights is not None:
        raise InvalidParameterError(f"weights are for method='weighted', not {method!r}")
    if method == "preload":
        if preload is None:
            raise InvalidParameterError("the preload distribution needs preload, the internal efforts sought")
        p = real_array("preload", preload)
        if p.shape != (na,) or not np.all(np.isfinite(p)):
            raise InvalidParameterError(f"preload must be {na} finite efforts, got {shown(preload)}")
    elif preload is not None:
        raise InvalidParameterError(f"preload is for method='preload', not {method!r}")

    if method == "minimum_peak":
        tau = _minimum_peak(W, f, bounds, where)
    elif bounds is None:
        tau = _weighted_least_norm(W, f, w, np.zeros(na), np.zeros(na, dtype=bool))
        if method == "preload":
            tau = tau + null @ (null.T @ p)
    elif method == "preload":
        target = _weighted_least_norm(W, f, w, np.zeros(na), np.zeros(na, dtype=bool)) + null @ (null.T @ p)
        tau = _preloaded_within(W, f, target, bounds, where)
    else:
        tau = _bounded_least_norm(W, f, w, *bounds, where)
        if tau is None:
            raise InvalidParameterError(_infeasible(W, f, *bounds, where))
    return EffortDistribution(tau, null @ (null.T @ tau), null, method)


def _preloaded_within(W, f, target, bounds, where):
    """The efforts nearest ``target`` (2-norm) that exert ``f`` within ``bounds``: ``target + δ`` with
    ``Wᵀ δ = 0`` (``target`` exerts ``f`` already), the least ``δ`` within the shifted bounds."""
    lower, upper = bounds
    shift = _bounded_least_norm(W, np.zeros(W.shape[1]), np.ones(W.shape[0]), lower - target, upper - target, where)
    if shift is None:  # said of the efforts, not of their shift
        raise InvalidParameterError(_infeasible(W, f, lower, upper, where))
    return target + shift
