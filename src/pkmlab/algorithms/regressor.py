"""The dynamics regressor of any described mechanism, and its base parameters: what makes the model
identifiable from measured efforts.

The actuator-space inverse dynamics (eq. 35 with gravity) is linear in the bodies' *standard inertial
parameters*, each body's

* planar: ``m``, the first moments ``mx = m c_x``, ``my = m c_y`` and ``Izz``, the moment of inertia about
  the body frame's origin (4 per body);
* spatial: ``m``, ``mx``, ``my``, ``mz`` and the inertia tensor about the origin, ``Ixx, Iyy, Izz, Ixy,
  Ixz, Iyz`` (10 per body),

all in the body's own frame (whose origin is the joint at the body's start, as the description's ``tip`` and
``com`` are measured; the platform's at its reference point). The description's inertia is about the mass
centre; the origin's is ``I_c + m |c|²`` in the plane, ``I_c + m (|c|² 1 - c cᵀ)`` in space (the parallel-axis
theorem, :func:`inertial_parameters`). Then

    τ = Y(q, θ̇, θ̈) π,

with ``Y`` (n_actuators, p) the *regressor* (:func:`dynamics_regressor`). It is built from the same generated
kinematics as the model — every body's origin is its mass centre of a body whose ``com`` is zero, and its
orientation the mass centres' moves for unit ``com`` — by the Newton–Euler equations about the origin,
projected on the actuators by ``Jqθ``: for each body, with ``a = a_o - g`` the origin's acceleration less
gravity, ``h = m c`` and ``I`` about the origin (body frame, ``ω`` and ``ω̇`` in it),

    f = m a + ω̇ × h + ω × (ω × h),   n = I ω̇ + ω × I ω + h × a,   τ += Jqθᵀ (J_oᵀ R f + J_ωᵀ n).

Not every parameter moves the efforts, and some only in fixed combinations (a proximal link's mass does
nothing while its first moment about the fixed joint does; a distal link's mass adds ``m l²`` to the
proximal's inertia). The *base parameters* are the fewest combinations that determine ``τ``
(:func:`base_parameters`): found numerically, as the rank of the regressor stacked over random states, and
written as readable combinations of the physical parameters — the parameters an identification can estimate.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .._validate import as_broadcast, as_count, as_flag, as_real
from ..errors import InvalidParameterError, shown
from ..model import mechanism_model as mm
from ..model.mechanism_model import MechanismModel
from .kinematics import acceleration_bias, as_model, check_loop_closure, coordinate_jacobian

__all__ = [
    "BaseParameters",
    "inertial_parameter_names",
    "inertial_parameters",
    "drive_parameter_names",
    "dynamics_regressor",
    "random_states",
    "base_parameters",
]

#: The standard inertial parameters of one body, in their order.
PLANAR_PARAMETERS = ("m", "mx", "my", "Izz")
SPATIAL_PARAMETERS = ("m", "mx", "my", "mz", "Ixx", "Iyy", "Izz", "Ixy", "Ixz", "Iyz")
#: The parameters of one actuator's drive, in their order: its armature ``Ia`` (the drive's inertia seen at the
#: actuator, kg·m² or kg), viscous friction ``fv`` (N·m·s/rad or N·s/m) and Coulomb friction ``fc`` (N·m or N).
DRIVE_PARAMETERS = ("Ia", "fv", "fc")
#: The symmetric unit matrices of the inertia entries (xx, yy, zz, xy, xz, yz).
_INERTIA_UNITS = np.array([[[1, 0, 0], [0, 0, 0], [0, 0, 0]], [[0, 0, 0], [0, 1, 0], [0, 0, 0]],
                           [[0, 0, 0], [0, 0, 0], [0, 0, 1]], [[0, 1, 0], [1, 0, 0], [0, 0, 0]],
                           [[0, 0, 1], [0, 0, 0], [1, 0, 0]], [[0, 0, 0], [0, 0, 1], [0, 1, 0]]], dtype=float)
#: A column of the stacked regressor whose norm is below this share of the largest column's is taken as zero.
ZERO_TOL = 1e-9
#: A column whose residual after the columns kept before it is below this share of its own norm is taken as a
#: combination of them (an exact regrouping leaves round-off, about 1e-13; a real direction far more).
DEPENDENT_TOL = 1e-7


def _spatial(model: MechanismModel) -> bool:
    return bool(getattr(model.description, "spatial", False))


def _bodies(model: MechanismModel) -> list[tuple[str, object]]:
    """``(name, body)`` of every body in the kernels' order: the legs' bodies leg by leg (``body<leg>_<k>``), then
    the platform (``platform``)."""
    m = model.description
    out = [(f"body{i + 1}_{k + 1}", b) for i, leg in enumerate(m.legs) for k, b in enumerate(leg.bodies)]
    return [*out, ("platform", m.platform)]


def _body_parameters(model: MechanismModel) -> tuple[str, ...]:
    """The standard parameters of each body of ``model``: a planar point platform has a mass only."""
    if _spatial(model):
        return SPATIAL_PARAMETERS
    return PLANAR_PARAMETERS


def _counts(model: MechanismModel) -> list[int]:
    per = len(_body_parameters(model))
    point = not _spatial(model) and model.description.platform.kind == "point"
    return [per] * (len(_bodies(model)) - 1) + [1 if point else per]


def inertial_parameter_names(model) -> tuple[str, ...]:
    """The names of the standard inertial parameters (:func:`inertial_parameters`), ``"<body>.<parameter>"``.

    ``body1_2.mx`` is the first moment along x of leg 1's second body, ``platform.Izz`` the platform's inertia
    about its reference point. A planar body has ``m, mx, my, Izz`` (a point platform ``m`` only), a spatial one
    ``m, mx, my, mz, Ixx, Iyy, Izz, Ixy, Ixz, Iyz``; the legs' bodies come first, leg by leg, then the platform.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).

    Returns
    -------
    tuple of str, length p

    Raises
    ------
    InvalidParameterError
        If ``model`` is not a pkmlab model.

    Examples
    --------
    >>> import pkmlab
    >>> inertial_parameter_names(pkmlab.load("paper"))[:4]
    ('body1_1.m', 'body1_1.mx', 'body1_1.my', 'body1_1.Izz')
    """
    model = as_model(model)
    names = _body_parameters(model)
    return tuple(f"{name}.{p}" for (name, _), count in zip(_bodies(model), _counts(model), strict=True)
                 for p in names[:count])


def inertial_parameters(model) -> np.ndarray:
    """The standard inertial parameters ``π`` of ``model``'s bodies (:func:`inertial_parameter_names`).

    From the description's masses, mass centres and inertias about them (the parallel-axis theorem moves the
    inertia to the body frame's origin).

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).

    Returns
    -------
    ndarray, shape (p,)
        Masses (kg), first moments (kg·m) and inertias (kg·m²), in the names' order.

    Raises
    ------
    InvalidParameterError
        If ``model`` is not a pkmlab model.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> np.round(inertial_parameters(pkmlab.load("five_bar"))[:4], 5).tolist()
    [0.3, 0.0375, 0.0, 0.00629]
    """
    model = as_model(model)
    values = []
    for (_, body), count in zip(_bodies(model), _counts(model), strict=True):
        m, c = float(body.mass), np.asarray(body.com, dtype=float)
        if _spatial(model):
            inertia = np.asarray(body.inertia, dtype=float) + m * (c @ c * np.eye(3) - np.outer(c, c))
            values += [m, *(m * c), inertia[0, 0], inertia[1, 1], inertia[2, 2], inertia[0, 1], inertia[0, 2],
                       inertia[1, 2]]
        else:
            values += [m, *(m * c), float(body.inertia) + m * float(c @ c)][:count]
    return np.array(values)


def drive_parameter_names(model) -> tuple[str, ...]:
    """The names of the drive parameters (:data:`DRIVE_PARAMETERS`) of every actuator, ``"drive<j>.<parameter>"``.

    ``drive2.fv`` is the second actuator's viscous friction; ``Ia`` is the armature (kg·m² or kg), ``fv`` the
    viscous friction (N·m·s/rad or N·s/m), ``fc`` the Coulomb friction (N·m or N).

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).

    Returns
    -------
    tuple of str, length 3 n_actuators

    Raises
    ------
    InvalidParameterError
        If ``model`` is not a pkmlab model.

    Examples
    --------
    >>> import pkmlab
    >>> drive_parameter_names(pkmlab.load("five_bar"))
    ('drive1.Ia', 'drive1.fv', 'drive1.fc', 'drive2.Ia', 'drive2.fv', 'drive2.fc')
    """
    model = as_model(model)
    return tuple(f"drive{j + 1}.{p}" for j in range(model.n_actuators) for p in DRIVE_PARAMETERS)


def coulomb_shape(theta_dot, coulomb_rate: float = 0.0) -> np.ndarray:
    """The shape ``φ(θ̇)`` of Coulomb friction ``fc φ(θ̇)``: ``tanh(θ̇ / v_c)`` for a rate ``v_c > 0`` (the smooth
    model of :class:`~pkmlab.simulation.realism.Drives`), ``sign(θ̇)`` for ``v_c = 0`` (exact: zero at rest)."""
    theta_dot = np.asarray(theta_dot, dtype=float)
    return np.tanh(theta_dot / coulomb_rate) if coulomb_rate > 0 else np.sign(theta_dot)


def drive_regressor(theta_dot, theta_ddot, coulomb_rate: float = 0.0) -> np.ndarray:
    """The drives' columns of the regressor (..., n, 3n): each actuator's effort ``Ia θ̈ + fv θ̇ + fc φ(θ̇)``
    written linearly in its :data:`DRIVE_PARAMETERS`, ``φ`` of :func:`coulomb_shape` at ``coulomb_rate``."""
    theta_dot, theta_ddot = np.asarray(theta_dot, dtype=float), np.asarray(theta_ddot, dtype=float)
    na = theta_dot.shape[-1]
    columns = np.stack([theta_ddot, theta_dot, coulomb_shape(theta_dot, coulomb_rate)], axis=-1)  # (..., n, 3)
    out = np.zeros((*theta_dot.shape, na, len(DRIVE_PARAMETERS)))
    j = np.arange(na)
    out[..., j, j, :] = columns
    return out.reshape(*theta_dot.shape, na * len(DRIVE_PARAMETERS))


def parameter_names(model, drives: bool = False) -> tuple[str, ...]:
    """The names of the regressor's columns: :func:`inertial_parameter_names`, then with ``drives``
    :func:`drive_parameter_names`."""
    return inertial_parameter_names(model) + (drive_parameter_names(model) if drives else ())


def _com_indices(model: MechanismModel) -> np.ndarray:
    """The packed parameters' indices of every body's mass centre, (n_bodies, dim) (-1 where a body has none)."""
    names = list(model.kernels.PARAMETERS)
    dim = model.kernels.DIM
    out = np.full((len(_bodies(model)), dim), -1, dtype=np.int64)
    for b, (name, _) in enumerate(_bodies(model)):
        for d, axis in enumerate("xyz"[:dim]):
            key = f"{name}_com_{axis}"
            if key in names:
                out[b, d] = names.index(key)
    return out


def _with_com(model: MechanismModel, com) -> np.ndarray:
    """The packed parameters with every body's mass centre at ``com`` (its frame): the kinematics of the bodies'
    origins (``com = 0``) or of a point at a unit distance along an axis."""
    P = model.P.copy()
    index = _com_indices(model)
    for d in range(index.shape[1]):
        P[index[:, d][index[:, d] >= 0]] = com[d]
    P.setflags(write=False)  # as every model's: the kernels are compiled for read-only parameters only
    return P


def _frames(model: MechanismModel, qs: np.ndarray, q_dots: np.ndarray):
    """Every body's origin at configurations ``qs`` and rates ``q_dots`` (K, n): its Jacobian ``J`` (K, n_bodies,
    rows, n) and bias ``J̇ q̇`` (K, n_bodies, rows) (rows: the origin's velocity, then the angular velocity — the
    angle's rate in the plane, ``ω`` in the body's frame in space), and its orientation (the angle (K, n_bodies),
    or ``R`` (K, n_bodies, 3, 3), world from body)."""
    k = model.kernels
    spatial = _spatial(model)
    rows = 6 if spatial else 3
    P0 = _with_com(model, np.zeros(k.DIM))
    units = [_with_com(model, e) for e in np.eye(3)] if spatial else []
    count = len(qs)
    J = np.empty((count, k.N_BODIES, rows, k.N_COORDINATES))
    bias = np.empty((count, k.N_BODIES, rows))
    pose = np.empty((count, 1 + len(units), k.N_BODIES, 3))
    for i in range(count):
        q = np.ascontiguousarray(qs[i])
        sc = mm.trig_table(model, q)
        k.body_jacobians(q, sc, P0, J[i])
        k.body_bias(q, sc, np.ascontiguousarray(q_dots[i]), P0, bias[i])
        for j, P in enumerate([P0, *units]):
            k.body_poses(q, sc, P, pose[i, j])
    if not spatial:
        return J, bias, pose[:, 0, :, 2]
    return J, bias, np.stack([pose[:, 1 + d] - pose[:, 0] for d in range(3)], axis=-1)


def _planar_columns(J, bias, angle, q_dots, q_ddots, gravity) -> np.ndarray:
    """The full-space regressor (K, n_bodies, 4, n) of planar bodies: the columns of ``m``, ``mx``, ``my``,
    ``Izz``."""
    jo, jphi = J[:, :, :2], J[:, :, 2]
    a = np.einsum("kbrn,kn->kbr", jo, q_ddots) + bias[:, :, :2] - gravity
    omega = np.einsum("kbn,kn->kb", jphi, q_dots)
    omega_dot = np.einsum("kbn,kn->kb", jphi, q_ddots) + bias[:, :, 2]
    c, s = np.cos(angle), np.sin(angle)
    columns = [np.einsum("kbrn,kbr->kbn", jo, a)]
    for ux, uy in ((c, s), (-s, c)):  # the body's x and y axes: a unit first moment along each
        force = np.stack([-omega_dot * uy - omega**2 * ux, omega_dot * ux - omega**2 * uy], axis=-1)
        columns.append(np.einsum("kbrn,kbr->kbn", jo, force) + jphi * (ux * a[..., 1] - uy * a[..., 0])[..., None])
    columns.append(jphi * omega_dot[..., None])
    return np.stack(columns, axis=2)


def _spatial_columns(J, bias, R, q_dots, q_ddots, gravity) -> np.ndarray:
    """The full-space regressor (K, n_bodies, 10, n) of spatial bodies: the columns of ``m``, ``mx..mz``,
    ``Ixx..Iyz``."""
    jo, jw = J[:, :, :3], J[:, :, 3:]
    a_world = np.einsum("kbrn,kn->kbr", jo, q_ddots) + bias[:, :, :3] - gravity
    a = np.einsum("kbji,kbj->kbi", R, a_world)  # in the body's frame
    omega = np.einsum("kbrn,kn->kbr", jw, q_dots)
    omega_dot = np.einsum("kbrn,kn->kbr", jw, q_ddots) + bias[:, :, 3:]
    columns = [np.einsum("kbrn,kbr->kbn", jo, a_world)]
    for e in np.eye(3):  # a unit first moment along each of the body's axes
        force = np.cross(omega_dot, e) + np.cross(omega, np.cross(omega, e))
        columns.append(np.einsum("kbrn,kbr->kbn", jo, np.einsum("kbij,kbj->kbi", R, force))
                       + np.einsum("kbrn,kbr->kbn", jw, np.cross(e, a)))
    for unit in _INERTIA_UNITS:
        moment = omega_dot @ unit + np.cross(omega, omega @ unit)  # (unit is symmetric)
        columns.append(np.einsum("kbrn,kbr->kbn", jw, moment))
    return np.stack(columns, axis=2)


def dynamics_regressor(model, q, theta_dot, theta_ddot, *, drives: bool = False,
                       coulomb_rate: float = 0.0) -> np.ndarray:
    """The regressor ``Y`` of the actuator-space inverse dynamics: ``τ = Y π``.

    ``π`` are the standard inertial parameters (:func:`inertial_parameters`), at configurations ``q`` on the loop
    closures, actuator rates ``theta_dot`` and accelerations ``theta_ddot`` (eq. 35 written linearly in the
    inertial parameters); with ``drives``, followed by the drives' columns (:func:`drive_regressor`), for
    efforts measured at the motors.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations on the loop closures (rad or m per entry; a configuration off them is refused, naming
        its residual).
    theta_dot, theta_ddot : array_like, shape (..., n_actuators)
        The actuators' rates (rad/s or m/s) and accelerations (rad/s² or m/s²), broadcast against ``q``.
    drives : bool
        Append the drives' columns (armature, viscous and Coulomb friction of every actuator).
    coulomb_rate : float
        The drives' Coulomb friction model (:func:`coulomb_shape`): ``tanh(θ̇ / coulomb_rate)``, or ``sign(θ̇)``
        for 0 (default); rad/s or m/s. Identify with the model the controller will compensate with.

    Returns
    -------
    ndarray, shape (..., n_actuators, p)
        One column per parameter of :func:`parameter_names`, in the actuators' units (N·m or N) per unit of
        the parameter.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closures, the shapes do not broadcast, an option is refused, or the rates or
        accelerations overflow the regressor.
    SingularityError
        At a gain-type singularity.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> q = pkmlab.inverse_kinematics(model, [0.0, 0.35], mode=(1, -1)).q
    >>> Y = dynamics_regressor(model, q, [0.5, -0.2], [1.0, 2.0])
    >>> tau = pkmlab.inverse_dynamics(model, q, [0.5, -0.2], [1.0, 2.0])
    >>> bool(np.allclose(Y @ inertial_parameters(model), tau))
    True
    """
    model = as_model(model)
    drives = as_flag("drives", drives)
    coulomb_rate = as_real("coulomb_rate", coulomb_rate, "non-negative")
    n, na = len(model.coordinates), model.n_actuators
    qs, theta_dots, theta_ddots, shape = as_broadcast(("q", q, n), ("theta_dot", theta_dot, na),
                                                      ("theta_ddot", theta_ddot, na))
    if len(qs) == 0:
        return np.zeros((*shape, na, len(parameter_names(model, drives))))
    check_loop_closure(model, qs, shape)
    Z = coordinate_jacobian(model, qs)
    q_dots = np.einsum("kij,kj->ki", Z, theta_dots)
    q_ddots = np.einsum("kij,kj->ki", Z, theta_ddots) + acceleration_bias(model, qs, theta_dots)
    gravity = np.asarray(model.description.gravity, dtype=float)
    with np.errstate(over="ignore", invalid="ignore"):
        J, bias, orientation = _frames(model, qs, q_dots)
        full = (_spatial_columns if _spatial(model) else _planar_columns)(J, bias, orientation, q_dots, q_ddots,
                                                                          gravity)
        full = full.reshape(len(qs), -1, full.shape[-1])[:, :sum(_counts(model))]  # a point platform has a mass only
        Y = np.einsum("kna,kpn->kap", Z, full)
    if not np.all(np.isfinite(Y)):
        raise InvalidParameterError("theta_dot or theta_ddot overflows the regressor (values too large)")
    if drives:
        Y = np.concatenate([Y, drive_regressor(theta_dots, theta_ddots, coulomb_rate)], axis=-1)
    return Y.reshape(*shape, na, Y.shape[-1])


#: The most states :func:`random_states` draws in one call.
MAX_STATES = 100_000


def random_states(model, count: int = 64, *, seed: int = 0, mode=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``count`` random states ``(q, θ̇, θ̈)`` of ``model``, away from its singularities.

    A random walk of the actuators from a well-conditioned configuration of working mode ``mode``, each step
    followed on its assembly mode (steps that near a singularity are drawn again), with rates and accelerations
    drawn from a standard normal distribution (rad/s or m/s, and per second). Reproducible from ``seed``.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    count : int
        How many states, 1 to :data:`MAX_STATES` (default 64).
    seed : int
        The random generator's seed, a non-negative integer.
    mode : sequence of signs or "auto", optional
        One sign per two-branch leg; the first working mode when omitted or ``"auto"``.

    Returns
    -------
    q : ndarray, shape (count, n)
        Configurations on the loop closures (rad or m per entry).
    theta_dot, theta_ddot : ndarray, shape (count, n_actuators)
        Actuator rates (rad/s or m/s) and accelerations (rad/s² or m/s²).

    Raises
    ------
    InvalidParameterError
        If an argument is refused, or fewer than ``count`` states away from the singularities are found.

    Examples
    --------
    >>> import pkmlab
    >>> q, theta_dot, theta_ddot = pkmlab.random_states(pkmlab.load("five_bar"), 8, seed=1)
    >>> q.shape, theta_dot.shape, theta_ddot.shape
    ((8, 6), (8, 2), (8, 2))
    """
    from ..errors import BranchFollowingError
    from .kinematics import as_working_mode, branch_following, length_scale, singularity_measure

    model = as_model(model)
    count = as_count("count", count, 1, MAX_STATES)
    rng = np.random.default_rng(as_count("seed", seed, 0))
    mode = "auto" if mode is None else as_working_mode(model, mode, "mode")
    mode = mm.working_modes(model)[0] if mode == "auto" else mode
    q = mm.well_conditioned_configuration(model, mode)
    s_home = abs(float(singularity_measure(model, q)))
    prismatic = np.array([kind == "P" for kind in model.description.actuator_kinds])
    scale = np.where(prismatic, 0.05 * length_scale(model), 0.15)
    out = []
    for _ in range(50 * count):
        if len(out) == count:
            break
        theta = q[:model.n_actuators] + scale * rng.uniform(-1.0, 1.0, model.n_actuators)
        try:
            step = branch_following(model, q, theta, singularity_guard=0.2 * s_home)
        except BranchFollowingError:
            q = out[rng.integers(len(out))] if out else q  # back to a state already drawn
            continue
        q = step
        out.append(q)
    if len(out) < count:
        raise InvalidParameterError(f"{model.description.name}: found only {len(out)} of {count} states away from "
                                    "its singularities")
    na = model.n_actuators
    return np.array(out), rng.standard_normal((count, na)), rng.standard_normal((count, na))


@dataclass(frozen=True)
class BaseParameters:
    """The base parameters of a model (:func:`base_parameters`).

    The fewest combinations of the standard inertial parameters that determine the efforts.

    Attributes
    ----------
    names : tuple of str
        Each base parameter as the combination it is, e.g. ``"body1_1.Izz + 0.0625 body1_2.m"``.
    parameters : tuple of str
        The standard parameters (:func:`parameter_names`: the inertial ones, then any drives').
    independent : ndarray of int, shape (r,)
        The standard parameter each base parameter is named after (its first term).
    combination : ndarray, shape (r, p)
        ``π_b = combination @ π``: 1 at the independent parameter, the regrouping coefficients at the
        dependent ones, 0 elsewhere.
    unidentifiable : tuple of str
        The standard parameters that move no effort at all.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> base = pkmlab.base_parameters(model)
    >>> q, theta_dot, theta_ddot = pkmlab.random_states(model, 8, seed=1)
    >>> Y = pkmlab.dynamics_regressor(model, q, theta_dot, theta_ddot)
    >>> pi = pkmlab.inertial_parameters(model)
    >>> bool(np.allclose(base.regressor(Y) @ base.of(pi), Y @ pi))
    True
    """

    names: tuple[str, ...]
    parameters: tuple[str, ...]
    independent: np.ndarray
    combination: np.ndarray
    unidentifiable: tuple[str, ...]

    @property
    def rank(self) -> int:
        """The number of base parameters ``r``."""
        return len(self.independent)

    def of(self, pi) -> np.ndarray:
        """The base parameters ``π_b`` of standard parameters ``pi``.

        Parameters
        ----------
        pi : array_like, shape (..., p)
            Standard parameters (kg, kg·m, kg·m², and the drives').

        Returns
        -------
        ndarray, shape (..., r)
        """
        return np.asarray(pi, dtype=float) @ self.combination.T

    def regressor(self, Y) -> np.ndarray:
        """The base regressor ``Y_b`` of a regressor ``Y``: its independent columns, so that ``Y_b π_b = Y π``.

        Parameters
        ----------
        Y : array_like, shape (..., n_actuators, p)
            A regressor (:func:`dynamics_regressor`).

        Returns
        -------
        ndarray, shape (..., n_actuators, r)
        """
        return np.asarray(Y)[..., self.independent]


def _combination_name(parameters, row, lead) -> str:
    terms = [parameters[lead]]
    for j in np.flatnonzero(row):
        if j == lead:
            continue
        coefficient = row[j]
        sign = "-" if coefficient < 0 else "+"
        size = abs(coefficient)
        terms.append(f"{sign} {parameters[j]}" if np.isclose(size, 1.0, rtol=1e-9) else
                     f"{sign} {size:.6g} {parameters[j]}")
    return " ".join(terms)


def _priority(model: MechanismModel, names: tuple[str, ...]) -> list[int]:
    """The order in which :func:`base_parameters` keeps columns: the platform's parameters first, then the legs'
    bodies from the base, each body's inertias before its first moments before its mass — so that a body's mass
    is regrouped onto the body it rides on, and what a leg carries at the platform onto the platform, as a
    designer reads them."""
    bodies = [name for name, _ in _bodies(model)]
    body_rank = {name: rank for rank, name in enumerate([bodies[-1], *bodies[:-1]])}

    def key(j):
        body, parameter = names[j].split(".")
        if body not in body_rank:  # a drive's parameters come last: an armature regroups onto the link it turns
            return len(body_rank), DRIVE_PARAMETERS.index(parameter), j
        kind = 2 if parameter == "m" else 1 if parameter.startswith("m") else 0
        return body_rank[body], kind, j

    return sorted(range(len(names)), key=key)


def base_parameters(model, states=None, *, seed: int = 0, drives: bool = False) -> BaseParameters:
    """The base parameters of ``model``: the combinations of its standard inertial parameters the efforts determine.

    They are found from the regressor stacked over many states.

    A column of the stacked regressor that is zero is unidentifiable; the others are taken in turn — the
    platform's, then the legs' bodies' from the base, each body's inertias, first moments, then mass — and a
    column that is a combination of the columns kept before it is regrouped onto them (``Y_d = Y_i β``, so
    ``π_i + β π_d`` is what the efforts see). The result
    does not depend on the states drawn, only on the machine's geometry, as long as they are generic.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    states : tuple (q, theta_dot, theta_ddot), optional
        The states to stack the regressor over, shapes (K, n), (K, n_actuators), (K, n_actuators) (default
        :func:`random_states` of 64 states from ``seed``).
    seed : int
        The random states' seed when ``states`` is not given.
    drives : bool
        Include the drives' parameters (:func:`drive_parameter_names`): an actuator's armature then regroups
        onto the link it turns where the two move together.

    Returns
    -------
    BaseParameters
        The names, the combination matrix (r, p) and the unidentifiable parameters.

    Raises
    ------
    InvalidParameterError
        If ``states`` is not ``(q, theta_dot, theta_ddot)`` or a state is refused (off the loop closures, wrong
        shape), or an option is refused.
    SingularityError
        If a state is at a gain-type singularity.

    Examples
    --------
    The five-bar moves in a horizontal plane (no gravity), so the first moments and masses of its actuated
    links move no effort; its distal links' masses regroup onto the actuated links' inertias (``0.0625 =
    0.25²`` m², the actuated link's length squared), and the loop closure ties each distal link's first moment
    to the others:

    >>> import pkmlab
    >>> base = base_parameters(pkmlab.load("five_bar"))
    >>> base.rank, base.names[0]
    (7, 'body1_1.Izz + 0.0625 body1_2.m - 0.208333 body1_2.mx')
    >>> base.unidentifiable[:3]
    ('body1_1.m', 'body1_1.mx', 'body1_1.my')
    """
    from ..errors import SingularityError

    model = as_model(model)
    drives = as_flag("drives", drives)
    if states is None:
        states = random_states(model, seed=seed)
    elif not isinstance(states, tuple | list) or len(states) != 3:
        raise InvalidParameterError(f"states must be (q, theta_dot, theta_ddot), got {shown(states, 60)}")
    try:
        Y = dynamics_regressor(model, *states, drives=drives)
    except (InvalidParameterError, SingularityError) as exc:
        raise type(exc)(f"states: {exc}") from None
    W = Y.reshape(-1, Y.shape[-1])
    norms = np.linalg.norm(W, axis=0)
    zero = norms <= ZERO_TOL * max(norms.max(), 1e-300)
    names = parameter_names(model, drives)
    kept: list[int] = []
    basis = np.zeros((W.shape[0], 0))
    for j in _priority(model, names):  # Gram–Schmidt: a column is kept if it adds a direction
        if zero[j]:
            continue
        w = W[:, j] / norms[j]
        residual = w - basis @ (basis.T @ w)
        residual -= basis @ (basis.T @ residual)  # twice is enough (Kahan)
        size = np.linalg.norm(residual)
        if size > DEPENDENT_TOL:
            kept.append(int(j))
            basis = np.column_stack([basis, residual / size])
    independent = np.array(sorted(kept), dtype=np.int64)
    beta = np.linalg.lstsq(W[:, independent], W, rcond=None)[0]  # every column as a combination of the kept ones
    beta[np.abs(beta) < 1e-10 * np.abs(beta).max(axis=0, keepdims=True).clip(1e-300)] = 0.0
    beta[:, zero] = 0.0
    beta[:, independent] = np.eye(len(independent))
    combined = tuple(_combination_name(names, row, lead) for row, lead in zip(beta, independent, strict=True))
    return BaseParameters(combined, names, independent, beta, tuple(n for n, z in zip(names, zero, strict=True) if z))
