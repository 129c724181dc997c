"""A physically consistent estimate: standard inertial parameters that real bodies can have, as close to the
identified base parameters as their uncertainty says, and a machine built from them.

The least-squares estimate of the base parameters (:func:`~pkmlab.algorithms.identification.identify`) is
unconstrained: with noise, or a motion that excites a combination poorly, it can imply a negative mass or an
inertia no mass distribution has, and a controller computing with it can be unstable. Real bodies are those
whose *pseudo-inertia* ``J = ∫ [p; 1][p; 1]ᵀ dm`` is positive semidefinite (Wensing, Kim and Slotine, "Linear
matrix inequalities for physically consistent inertial parameter identification", 2017):

- a spatial body: ``J = [[½ tr(I) 1 - I, h], [hᵀ, m]] ⪰ 0``, ``I`` its inertia about its frame's origin and
  ``h = m c`` its first moment — positive mass and the triangle inequalities of the principal moments;
- a planar body (its inertia about z only): ``[[Izz, mx, my], [mx, m, 0], [my, 0, m]] ⪰ 0``, i.e. ``m ≥ 0`` and
  an inertia about the mass centre ``Izz - (mx² + my²)/m ≥ 0``;
- a drive: armature and friction non-negative.

:func:`physically_consistent` solves two semidefinite programs over the standard parameters ``π``, each
subject to every body's ``J ⪰ 0`` (kept a little inside, so that every body of the model rotates with some
inertia) and ``m ≥ m_min``: first the least Mahalanobis distance ``d² = ‖Σ^(-1/2) (C π - π̂_b)‖²`` of the base
parameters ``C π`` to the estimate ``π̂_b`` with its covariance ``Σ`` (zero when the estimate is consistent
already); then, among the ``π`` within ``slack`` of that least ``d²``, the one nearest a prior ``π₀`` (the
model's own description, by default) in units of each parameter's natural scale — what fixes the combinations
the data cannot see. Done in that order (lexicographically) rather than as one weighted sum, neither goal's
numbers swamp the other's whatever the noise. Both are convex, so their solutions are the global ones: solved by
CVXPY (``pip install 'pkmlab[identify]'``) with the Clarabel interior-point solver — maintained, open-source,
accurate on small semidefinite programs — falling back to SCS; an answer is kept only if every body's
pseudo-inertia checks positive semidefinite.
"""

from __future__ import annotations

from dataclasses import dataclass, replace

import numpy as np

from .._validate import as_batch, as_real, shape_of
from ..errors import InvalidParameterError, PkmlabError, shown
from ..model.mechanism_model import MechanismModel
from .identification import Identification
from .kinematics import as_model, length_scale
from .regressor import _bodies, _counts, _spatial, inertial_parameters, parameter_names

__all__ = ["ConsistentEstimate", "physically_consistent", "identified_model"]

#: By default the estimate may be this share farther (in distance squared) from the data than the least it can
#: be, to come nearer the prior where the data do not decide.
SLACK = 1e-2
#: Every body's pseudo-inertia is kept this share of its inertia scale (its mass times the machine's size
#: squared) inside the consistent set, so that the model it gives has rotating bodies with some inertia.
MIN_INERTIA = 1e-6


@dataclass(frozen=True)
class ConsistentEstimate:
    """A physically consistent estimate (:func:`physically_consistent`).

    Attributes
    ----------
    parameters : ndarray, shape (p,)
        The standard parameters (:func:`~pkmlab.algorithms.regressor.parameter_names`), every body's pseudo-inertia
        positive semidefinite.
    names : tuple of str
        Their names.
    base : ndarray, shape (r,)
        The base parameters they give (``C π``), to compare with the least-squares estimate.
    distance : float
        The Mahalanobis distance ``‖Σ^(-1/2) (C π - π̂_b)‖`` to the least-squares estimate (0 when it was
        consistent already; about ``√r`` or more when a constraint bound).
    margin : ndarray, shape (n_bodies,)
        The smallest eigenvalue of each body's pseudo-inertia (kg m²; a point platform's mass).
    """

    parameters: np.ndarray
    names: tuple[str, ...]
    base: np.ndarray
    distance: float
    margin: np.ndarray

    def value(self, name: str) -> float:
        """The parameter called ``name`` (e.g. ``"body1_2.m"``, ``"drive1.fv"``)."""
        if name not in self.names:
            raise InvalidParameterError(f"no parameter {name!r}: the names are those of pkmlab.parameter_names")
        return float(self.parameters[self.names.index(name)])


def _pseudo_inertia(cp, x, spatial: bool):
    """The pseudo-inertia (an affine expression of a body's parameters ``x``) whose semidefiniteness is
    consistency: 4×4 for a spatial body (``m, mx, my, mz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz``), 3×3 for a planar one
    (``m, mx, my, Izz``)."""
    if spatial:
        m, hx, hy, hz, ixx, iyy, izz, ixy, ixz, iyz = (x[i] for i in range(10))
        half = (ixx + iyy + izz) / 2
        return cp.bmat([[half - ixx, -ixy, -ixz, hx], [-ixy, half - iyy, -iyz, hy], [-ixz, -iyz, half - izz, hz],
                        [hx, hy, hz, m]])
    m, hx, hy, izz = (x[i] for i in range(4))
    return cp.bmat([[izz, hx, hy], [hx, m, 0], [hy, 0, m]])


def _numeric_pseudo_inertia(x: np.ndarray, spatial: bool) -> np.ndarray:
    if spatial:
        m, hx, hy, hz, ixx, iyy, izz, ixy, ixz, iyz = x
        half = (ixx + iyy + izz) / 2
        return np.array([[half - ixx, -ixy, -ixz, hx], [-ixy, half - iyy, -iyz, hy], [-ixz, -iyz, half - izz, hz],
                         [hx, hy, hz, m]])
    m, hx, hy, izz = x
    return np.array([[izz, hx, hy], [hx, m, 0.0], [hy, 0.0, m]])


def _scales(model: MechanismModel, prior: np.ndarray, drives: bool) -> np.ndarray:
    """Each standard parameter's natural scale: the body's mass, times the machine's size per power of length."""
    size = length_scale(model)
    powers = {"m": 0, "mx": 1, "my": 1, "mz": 1}
    out, start = [], 0
    for count in _counts(model):
        mass = max(abs(prior[start]), 1e-3 * max(abs(prior[0]), 1e-9))
        names = parameter_names(model)[start:start + count]
        out += [mass * size ** powers.get(n.split(".")[1], 2) for n in names]
        start += count
    if drives:
        out += [1.0] * (len(parameter_names(model, True)) - start)
    return np.array(out)


def physically_consistent(model, identification: Identification, *, prior=None, slack: float = SLACK,
                          min_mass: float | None = None) -> ConsistentEstimate:
    """Standard parameters of ``model`` that are physically consistent and closest to ``identification``'s base
    parameters (the module's text).

    Parameters
    ----------
    model : MechanismModel
        The machine identified.
    identification : Identification
        The least-squares estimate (:func:`~pkmlab.algorithms.identification.identify`).
    prior : array_like, shape (p,), optional
        The standard parameters to fall back on where the data say nothing (default the model's own, and zero
        drive parameters).
    slack : float
        How much farther from the data (a share of the least distance squared) the estimate may be, to come
        nearer the prior where the data do not decide.
    min_mass : float, optional
        The least mass of a body (kg; default 10⁻³ of the prior's smallest, keeping the mass matrix definite).

    Returns
    -------
    ConsistentEstimate

    Raises
    ------
    PkmlabError
        When CVXPY is not installed or the solver fails.
    """
    model = as_model(model)
    if not isinstance(identification, Identification):
        raise InvalidParameterError(f"identification must be the result of pkmlab.identify, got "
                                    f"{type(identification).__name__} {shown(identification, 50)}")
    drives = identification.drives
    names = parameter_names(model, drives)
    if identification.base.parameters != names:
        raise InvalidParameterError("identification is of another machine: its parameters are not this model's")
    slack = as_real("slack", slack, "non-negative")
    nominal = np.concatenate([inertial_parameters(model), np.zeros(len(names) - len(inertial_parameters(model)))])
    if prior is None:
        prior = nominal
    else:
        prior = as_batch("prior", prior, len(names), single=True)[0][0].copy()
    masses = [prior[s] for s in np.cumsum([0, *_counts(model)[:-1]])]
    if min_mass is None:
        min_mass = 1e-3 * min(m for m in masses if m > 0) if any(m > 0 for m in masses) else 1e-9
    else:
        min_mass = as_real("min_mass", min_mass, "non-negative")
    try:
        import cvxpy as cp
    except ImportError:
        raise PkmlabError("the physically consistent estimate needs CVXPY: pip install 'pkmlab[identify]'") from None
    C, estimate = identification.base.combination, identification.estimate
    covariance = identification.covariance
    if covariance is None:
        covariance = np.diag(identification.sigma**2)
    scale = max(float(np.abs(estimate).max()), 1e-300)
    covariance = covariance + np.eye(len(estimate)) * (1e-9 * scale) ** 2  # noise-free data: a finite weight
    whiten = np.linalg.inv(np.linalg.cholesky(covariance))
    s = _scales(model, prior, drives)
    # in units of each parameter's scale about the prior, π = π₀ + s z, and the data term normalised: the
    # problem's numbers are of order one whatever the machine's units or the data's noise
    A = whiten @ C * s
    b = whiten @ (estimate - C @ prior)
    norm = max(float(np.linalg.norm(b)), 1e-9 * float(np.linalg.norm(A, 2)), 1e-300)  # the prior at distance 1
    A, b = A / norm, b / norm
    z = cp.Variable(len(names))
    pi = prior + cp.multiply(s, z)
    constraints, start, spatial, size = [], 0, _spatial(model), length_scale(model)
    blocks = []
    for count in _counts(model):
        x = pi[start:start + count]
        if count == 1:  # a point platform: its mass
            constraints.append(x[0] >= min_mass)
        else:  # strictly inside: a body of the model must rotate with some inertia
            J = _pseudo_inertia(cp, x, spatial)
            # J's entries of order one: its second moments over m L², first moments over m L, mass over m
            seconds = 3 if spatial else 1
            D = np.diag([1.0 / size] * seconds + [1.0] * (J.shape[0] - seconds)) / np.sqrt(s[start])
            inner = np.diag([1.0] * seconds + [0.0] * (J.shape[0] - seconds)) * MIN_INERTIA
            constraints += [D @ ((J + J.T) / 2) @ D - inner >> 0, x[0] >= min_mass]
        blocks.append((start, count))
        start += count
    if drives:
        constraints.append(pi[start:] >= 0)
    data = cp.sum_squares(A @ z - b)
    # lexicographic: the data term at its least, then, within a slack of it, the parameters nearest the prior
    least = _solve(cp, cp.Problem(cp.Minimize(data), constraints), z)
    bound = least * (1 + slack) + 1e-6  # the prior's data term is 1
    _solve(cp, cp.Problem(cp.Minimize(cp.sum_squares(z)), [*constraints, data <= bound]), z)
    value = prior + s * np.asarray(z.value, dtype=float)
    margin = np.array([value[b] if c == 1 else np.linalg.eigvalsh(_numeric_pseudo_inertia(value[b:b + c], spatial))[0]
                       for b, c in blocks])
    if np.any(margin < -1e-6 * s[[b for b, _c in blocks]] * size**2):
        raise PkmlabError("the physically consistent estimate failed: the solver's answer is not consistent "
                          f"(smallest pseudo-inertia eigenvalue {margin.min():.3g})")
    distance = float(np.linalg.norm(whiten @ (C @ value - estimate)))
    return ConsistentEstimate(value, names, C @ value, distance, margin)


def _solve(cp, problem, variable) -> float:
    """Solve ``problem`` by Clarabel (SCS if it fails); its optimal value. The solvers' own warnings are theirs:
    a solution is taken only when optimal."""
    import warnings

    for solver in ("CLARABEL", "SCS"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            try:
                problem.solve(solver=solver)
            except (cp.error.SolverError, ValueError, ArithmeticError):
                continue
        if problem.status in ("optimal", "optimal_inaccurate") and variable.value is not None:
            return float(problem.value)  # an inaccurate optimum is checked by the caller: every body's margin
    raise PkmlabError(f"the physically consistent estimate failed: the solver ended {problem.status!r}")


def _nearest_body_inertia(inertia: np.ndarray) -> np.ndarray:
    """``inertia`` (about the mass centre) with its principal moments made non-negative and obeying the
    triangle inequality: a consistent estimate is within the solver's tolerance of both, a description must be
    exactly so."""
    moments, axes = np.linalg.eigh((inertia + inertia.T) / 2)
    moments = np.maximum(moments, 0.0)
    moments[2] = min(moments[2], moments[0] + moments[1])
    out = (axes * moments) @ axes.T
    return (out + out.T) / 2


def identified_model(model, parameters) -> MechanismModel:
    """``model`` with every body's mass, mass centre and inertia from the standard parameters ``parameters``
    (p,) (a :class:`ConsistentEstimate`'s, or :func:`~pkmlab.algorithms.regressor.inertial_parameters`'s),
    the geometry unchanged: the controller's model of an identified machine (drive parameters, if given, are
    not part of a description and are left out).

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`): its geometry.
    parameters : ConsistentEstimate or array_like, shape (p,)
        The standard inertial parameters (:func:`~pkmlab.algorithms.regressor.parameter_names`), each body's mass
        (kg), first moments (kg·m) and inertias about its frame's origin (kg·m²); with the drives' parameters
        after them, or without.

    Returns
    -------
    MechanismModel
        The machine with those bodies, each inertia about its mass centre made physical (non-negative principal
        moments obeying the triangle inequality, as a consistent estimate's are to the solver's tolerance).

    Raises
    ------
    InvalidParameterError
        If ``parameters`` has neither the bodies' nor the bodies' and drives' number of entries, or gives a body a
        mass that is not positive.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> from pkmlab.algorithms.consistency import identified_model
    >>> model = pkmlab.load("five_bar")
    >>> again = identified_model(model, pkmlab.inertial_parameters(model))  # the description's own bodies
    >>> states = pkmlab.random_states(model, 5, seed=0)
    >>> bool(np.allclose(pkmlab.inverse_dynamics(again, *states), pkmlab.inverse_dynamics(model, *states)))
    True
    """
    model = as_model(model)
    if isinstance(parameters, ConsistentEstimate):
        parameters = parameters.parameters
    counts = _counts(model)
    shape = shape_of(parameters) or ()
    size = shape[0] if len(shape) == 1 else sum(counts)
    if size not in (sum(counts), len(parameter_names(model, True))):
        raise InvalidParameterError(f"parameters must be the {sum(counts)} standard inertial parameters (or "
                                    f"{len(parameter_names(model, True))} with drives), got {shown(parameters, 50)}")
    pi = as_batch("parameters", parameters, size, single=True)[0][0]
    spatial, start, new = _spatial(model), 0, []
    for (_name, body), count in zip(_bodies(model), counts, strict=True):
        x = pi[start:start + count]
        start += count
        m = float(x[0])
        if not m > 0:
            raise InvalidParameterError(f"{_name} would have the mass {m:g}: a body needs a positive mass "
                                        "(use a physically consistent estimate)")
        if count == 1:
            new.append(replace(body, mass=m))
            continue
        if spatial:
            c = x[1:4] / m
            origin = np.array([[x[4], x[7], x[8]], [x[7], x[5], x[9]], [x[8], x[9], x[6]]])
            inertia = _nearest_body_inertia(origin - m * (c @ c * np.eye(3) - np.outer(c, c)))
            new.append(replace(body, mass=m, com=tuple(c.tolist()), inertia=tuple(map(tuple, inertia.tolist()))))
        else:
            c = x[1:3] / m
            # a consistent estimate's inertia about the mass centre is ≥ 0 to the solver's tolerance
            new.append(replace(body, mass=m, com=tuple(c.tolist()), inertia=max(float(x[3] - m * c @ c), 0.0)))
    m = model.description
    legs, k = [], 0
    for leg in m.legs:
        legs.append(replace(leg, bodies=tuple(new[k:k + len(leg.bodies)])))
        k += len(leg.bodies)
    return MechanismModel.from_description(replace(m, legs=tuple(legs), platform=new[-1]))
