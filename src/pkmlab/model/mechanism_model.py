"""Any described mechanism bound to its generated kernels, and its dynamics — written once.

A :class:`MechanismModel` is the immutable pair (description, packed parameters) plus the
compiled kernels generated for its structure (:mod:`pkmlab.codegen.planar`), which carry the
compiled core of :mod:`pkmlab.codegen.core`: the same role as :class:`~pkmlab.paper.geometry.Planar3RRR`
plays for the paper's 3-RRR, for every mechanism. The functions below are the paper's formulation
applied to it:

* the constrained Lagrangian model in the full coordinates ``q`` (eqs. 20–26) with gravity,
  ``M(q) q̈ + C(q, q̇) q̇ + g(q) = τ + Jηqᵀ λ``, through the mechanism-agnostic algebra of
  :mod:`pkmlab.numerics.lagrangian` — the independent cross-check;
* its exact reduction to the actuator space (eq. 35, with gravity), ``Mθ θ̈ + cθ + gθ = τθ``,
  ``Mθ = Jqθᵀ M Jqθ``, ``cθ = Jqθᵀ (M J̇qθ θ̇ + C q̇)``, ``gθ = Jqθᵀ g = ∂V/∂θ``, computed body by body
  by the compiled core (what the simulation evaluates);
* inverse kinematics in every working mode, forward kinematics with every assembly mode, branch
  following, the singularity measure, and the kinematics of a path.

Coordinates are those of the generated kernels: ``q = (actuators, passive joints, pose)``.
"""

from __future__ import annotations

import functools
import importlib
from dataclasses import dataclass, field
from types import ModuleType

import numpy as np

from ..codegen import planar
from ..description.mechanism import Mechanism, leg_columns
from ..description.presets import preset
from ..errors import InvalidParameterError, SingularityError
from ..numerics import lagrangian
from ..numerics.batched import factor_blocks, solve_factored_blocks
from .reach import attachment_points_of, check_assembly, leg_solver, platform_turns_of


@dataclass(frozen=True)
class MechanismModel:
    """A described mechanism with its packed parameters and generated kernels.

    The immutable pair (description, packed parameters ``P``) bound to the compiled kernels of its structure:
    what :func:`load` returns and every function of pkmlab takes first. Machines of one structure share one
    compiled module and differ only in ``P``.

    Attributes
    ----------
    description : Mechanism or SpatialMechanism
        The machine as data: legs, platform, bodies, gravity, name.
    P : ndarray, shape (p,)
        The packed parameters the kernels read (read-only).
    kernels : module
        The generated kernels of the structure.

    Examples
    --------
    >>> model = MechanismModel.from_preset("five_bar")
    >>> model.coordinates
    ('a1', 'a2', 'q1_2', 'q2_2', 'x', 'y')
    >>> model.n_actuators, model.dof, model.pose_names
    (2, 2, ('x', 'y'))
    """

    description: Mechanism
    P: np.ndarray = field(compare=False, repr=False)
    kernels: ModuleType = field(compare=False, repr=False)

    @classmethod
    def from_description(cls, description: Mechanism) -> MechanismModel:
        """The model of a description.

        Parameters
        ----------
        description : Mechanism or SpatialMechanism
            The machine as data.

        Returns
        -------
        MechanismModel

        Raises
        ------
        InvalidParameterError
            If ``description`` is not a description, or the platform cannot be assembled on its legs.
        """
        from ..description.spatial import SpatialMechanism

        if not isinstance(description, Mechanism | SpatialMechanism):
            raise InvalidParameterError(f"description must be a Mechanism or a SpatialMechanism, got "
                                        f"{type(description).__name__}")
        check_assembly(description)  # before the kernels: a refused machine's structure is not derived here
        return bind(description)

    @classmethod
    def from_preset(cls, name: str) -> MechanismModel:
        """The model of a preset (``"paper"``, ``"five_bar"``, ``"3rpr"``, ``"3prr"``, ``"delta"``, ``"stewart"``).

        Parameters
        ----------
        name : str
            The preset's name.

        Returns
        -------
        MechanismModel
        """
        return cls.from_description(preset(name))

    @classmethod
    def from_3rrr(cls, model) -> MechanismModel:
        """The generic model of a :class:`~pkmlab.paper.geometry.Planar3RRR`, from its
        :meth:`~pkmlab.paper.geometry.Planar3RRR.to_mechanism`: what runs its simulations. Cached: a study builds it
        once per machine."""
        return _from_3rrr(model)

    @property
    def coordinates(self) -> tuple[str, ...]:
        """The names of the coordinates ``q``, in order: actuators ``a1 …``, passive joints ``q<leg>_<joint>``, pose."""
        return self.kernels.COORDINATES

    @property
    def n_actuators(self) -> int:
        """The number of actuators ``n_a`` (one per leg, more on a leg of two actuators: a kinematically redundant
        leg's, an ``R*R*R`` leg's)."""
        return len(self.description.actuators)

    @property
    def name(self) -> str:
        """The machine's name (the description's)."""
        return self.description.name

    @property
    def pose_names(self) -> tuple[str, ...]:
        """The controlled coordinates, e.g. ``('x', 'y', 'alpha')``: the platform's pose (the last entries of ``q``),
        then the actuators that move a kinematically redundant leg's base (``q``'s first)."""
        return tuple(self.description.pose_names)

    @property
    def pose_columns(self) -> tuple[int, ...]:
        """The columns of ``q`` that hold the controlled coordinates (:attr:`pose_names`), in their order."""
        return tuple(self.coordinates.index(c) for c in self.pose_names)

    @property
    def dof(self) -> int:
        """The number of pose coordinates ``dof`` (``len(pose_names)``)."""
        return self.description.dof

    @property
    def body_weights(self) -> np.ndarray:
        """``D`` (n_bodies, 3): ``(m, m, I)`` of every body (legs' bodies, then the platform)."""
        rows = [(b.mass, b.mass, b.inertia) for leg in self.description.legs for b in leg.bodies]
        platform = self.description.platform
        return np.array([*rows, (platform.mass, platform.mass, platform.inertia)], dtype=float)


def load(source) -> MechanismModel:
    """The model of a mechanism, for every function of pkmlab.

    Parameters
    ----------
    source : str, path, description or model
        A preset's name (``"paper"``, ``"five_bar"``, ``"3rpr"``, ``"3prr"``, ``"delta"``, ``"stewart"``), a
        description file (TOML with a ``[mechanism]`` table), a description
        (:class:`~pkmlab.description.mechanism.Mechanism`, :class:`~pkmlab.description.spatial.SpatialMechanism`),
        or a model (returned as it is).

    Returns
    -------
    MechanismModel
        The immutable description bound to its structure's compiled kernels.

    Raises
    ------
    InvalidParameterError
        If ``source`` is none of these, a description file has no ``[mechanism]`` table or an invalid entry, or
        the platform cannot be assembled on its legs.
    FileFormatError
        If a description file cannot be read.

    Examples
    --------
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> model.coordinates
    ('a1', 'a2', 'a3', 'q1_2', 'q2_2', 'q3_2', 'x', 'y', 'alpha')
    >>> model.n_actuators, model.dof
    (3, 3)
    >>> pkmlab.load(model) is model
    True
    """
    import os
    from pathlib import Path

    from ..description.files import load_mechanism
    from ..description.presets import PRESETS
    from ..description.spatial import SpatialMechanism
    from ..errors import shown

    if isinstance(source, MechanismModel):
        return source
    if isinstance(source, Mechanism | SpatialMechanism):
        return MechanismModel.from_description(source)
    if isinstance(source, str) and source in PRESETS:
        return MechanismModel.from_preset(source)
    if isinstance(source, str | os.PathLike) and Path(source).suffix == ".toml":
        return MechanismModel.from_description(load_mechanism(source))
    raise InvalidParameterError(f"source must be a preset ({', '.join(PRESETS)}), a .toml description file, a "
                                f"description or a model, got {shown(source, 60)}")


def derivation(description) -> ModuleType:
    """The derivation of a description: :mod:`pkmlab.codegen.spatial` for a spatial machine, else
    :mod:`pkmlab.codegen.planar`."""
    if getattr(description, "spatial", False):
        from ..codegen import spatial

        return spatial
    return planar


def bind(description: Mechanism) -> MechanismModel:
    """The model of a description whose platform is known to assemble: the description with its packed parameters
    and its structure's kernels (shipped, or generated once), without :meth:`MechanismModel.from_description`'s
    assembly check — for a description checked already (a second process given one by the first)."""
    name = kernels_name(description)
    if name.startswith(SHIPPED_KERNELS):  # (a shipped module that fails to import is an error to report, not a new one)
        kernels = importlib.import_module(name)
        _say_if_compiling(kernels, description)
    else:
        kernels = _user_structure_kernels(description)  # (a new structure's derivation says what takes time)
    P = derivation(description).pack(description)
    P.setflags(write=False)
    return MechanismModel(description, P, kernels)


#: The shipped structures whose first compilation this process has spoken of.
_SPOKEN: set[str] = set()


def _say_if_compiling(kernels: ModuleType, description) -> None:
    """Say once per process, on stderr — terminal or not: a log, a pipe and a notebook see it too — that a shipped
    structure's kernels compile as they are first used, when none of them is in the cache yet (the first run
    after installing or upgrading pkmlab)."""
    from .._compile_cache import INTERPRETED, has_compiled
    from ..progress import notice

    if INTERPRETED or kernels.__name__ in _SPOKEN:
        return
    _SPOKEN.add(kernels.__name__)
    if not has_compiled(kernels.__name__):
        notice(f"{description.name}: compiling the numerical kernels of this machine structure as they are first "
               "used (up to a minute, once: later runs read them from the cache)")


@functools.lru_cache(maxsize=64)
def _from_3rrr(model) -> MechanismModel:
    return bind(model.to_mechanism())  # the Planar3RRR checked already that its platform can be assembled


def _user_structure_kernels(description: Mechanism) -> ModuleType:
    """The kernels of a structure pkmlab does not ship: derived and generated once (SymPy, a few seconds),
    kept in pkmlab's cache folder beside the compiled kernels, and imported from there — so a later
    process neither derives nor compiles them again. Written atomically: a concurrent process reads
    either nothing or the whole module."""
    import importlib.util
    import os
    import sys
    import tempfile

    from .._compile_cache import CACHE_DIR, cache_lock

    derived = derivation(description)
    name = kernels_name(description)
    if name in sys.modules:
        return sys.modules[name]
    folder = CACHE_DIR / "kernels"
    path = folder / f"{name}.py"
    if not path.exists():
        from .._compile_cache import INTERPRETED
        from ..progress import notice

        compiling = "" if INTERPRETED else ", then compiling them as they are first used (up to a minute)"
        notice(f"{description.name}: a machine structure new to this installation ({derived.structure(description)}): "
               f"deriving its kernels (seconds){compiling}; once, later runs read them from the cache")
        with cache_lock(f"{name}.py"):  # a process deriving it already (a second one compiling ahead): its module
            if not path.exists():
                source = derived.generate_source(description)
                folder.mkdir(parents=True, exist_ok=True)
                fd, tmp = tempfile.mkstemp(dir=folder, prefix=f".{name}-", suffix=".tmp")
                with os.fdopen(fd, "w") as f:
                    f.write(source)
                os.replace(tmp, path)
    spec = importlib.util.spec_from_file_location(name, path)
    module = importlib.util.module_from_spec(spec)
    sys.modules[name] = module
    spec.loader.exec_module(module)
    return module


#: The package of the kernel modules pkmlab ships (:func:`kernels_name`).
SHIPPED_KERNELS = "pkmlab.kernels."


def kernels_name(description) -> str:
    """The name of the kernel module of ``description``'s structure: ``pkmlab.kernels.<structure>`` for one pkmlab
    ships (its module's file is in the package), ``pkmlab_kernels_<structure>`` for one derived on first use and
    kept in the cache folder. What :func:`bind` imports, and what :mod:`pkmlab.simulation.ahead` looks up before it
    compiles a run's loop ahead: one decision of which structures are shipped."""
    path = derivation(description).generated_path(description)
    return f"{SHIPPED_KERNELS}{path.stem}" if path.exists() else f"pkmlab_kernels_{path.stem}"


def trig_table(model: MechanismModel, q: np.ndarray) -> np.ndarray:
    """The trig table of ``q`` that every generated kernel reads: ``(cos q_k, sin q_k)`` (n_coordinates, 2)
    for the angles (zeros elsewhere)."""
    sc = np.zeros((len(model.coordinates), 2))
    model.kernels.trig(q, sc)
    return sc


def joint_positions(model: MechanismModel, q) -> np.ndarray:
    """Every joint's position at configurations ``q`` (..., n_coordinates): (..., legs, joints per leg, 2 or 3),
    each leg's base joint first — from the structure's generated ``joint_points``; what every drawing of a
    machine draws."""
    q = np.ascontiguousarray(q, dtype=float)
    k = model.kernels
    flat = q.reshape(-1, q.shape[-1])
    out = np.empty((len(flat), len(model.description.legs), k.JOINTS_PER_LEG, k.DIM))
    for i, qi in enumerate(flat):
        k.joint_points(qi, trig_table(model, qi), model.P, out[i])
    return out.reshape(*q.shape[:-1], *out.shape[1:])


def tracked_point(model: MechanismModel, q) -> np.ndarray:
    """The platform's tracked point (x, y[, z]) of configurations ``q`` (..., n_coordinates), (..., 2 or 3): from
    ``q``'s coordinates of those names, which are not all controlled on a platform of lower mobility."""
    columns = [model.coordinates.index(c) for c in ("x", "y", "z") if c in model.coordinates]
    return np.asarray(q, dtype=float)[..., columns]


def leg_joint_values(model: MechanismModel, q) -> list[list[float]]:
    """Each leg's joint coordinates, in the order of its joints (a universal joint's two), from the configuration
    ``q`` (n_coordinates,): what :func:`~pkmlab.description.spatial.leg_frames` and MuJoCo's joints read."""
    return [[float(q[c]) for c in columns] for columns in leg_columns(model.description)]


def pose_of(model: MechanismModel, q) -> np.ndarray:
    """The controlled coordinates (:attr:`MechanismModel.pose_names`) of configurations ``q`` (..., n_coordinates),
    (..., dof): the platform's pose, and a kinematically redundant machine's base actuators — a view of ``q`` where
    they are consecutive (every machine of one actuator per leg), else a copy."""
    return np.asarray(q, dtype=float)[..., _run_or_list(list(model.pose_columns))]


def platform_joint_names(description) -> tuple[str, ...]:
    """The names of the angles of the universal joints that carry the platform (a 3-UPU's), as
    :func:`platform_joint_angles` gives them: ``q<leg>_<joint>a``, ``…b``; empty for other machines."""
    if not getattr(description, "spatial", False):
        return ()
    return tuple(f"q{i + 1}_{len(leg.joints)}{c}" for i, leg in enumerate(description.legs)
                 if leg.joints[-1].kind == "U" for c in "ab")


def platform_joint_angles(model: MechanismModel, q) -> np.ndarray:
    """The angles of the universal joints that carry the platform (:func:`platform_joint_names`) at
    configurations ``q`` (..., n_coordinates), (..., 2 per such leg): not coordinates of ``q``, they follow from
    each leg's last body and the platform's orientation
    (:func:`~pkmlab.description.spatial.platform_joint_angles`)."""
    from ..description.spatial import full_poses, leg_frames, orientation
    from ..description.spatial import platform_joint_angles as angles_of

    m = model.description
    names = platform_joint_names(m)
    q = np.asarray(q, dtype=float)
    flat = q.reshape(-1, q.shape[-1])
    out = np.empty((len(flat), len(names)))
    if not names:
        return out.reshape(*q.shape[:-1], 0)
    n_pose = len(m.platform.q_pose_names)
    for r, qr in enumerate(flat):
        column = 0
        platform = orientation(*full_poses(m, qr[len(qr) - n_pose:])[3:]) if m.platform.kind == "rigid" else None
        for leg, values in zip(m.legs, leg_joint_values(model, qr), strict=True):
            if leg.joints[-1].kind == "U":
                out[r, column:column + 2] = angles_of(leg, leg_frames(leg, values)[-1][1], platform)[:2]
                column += 2
    return out.reshape(*q.shape[:-1], len(names))


def set_aside_residual(model: MechanismModel, q) -> np.ndarray:
    """The loop-closure rows an overconstrained machine's model sets aside (:mod:`pkmlab.description.mobility`) at
    configuration ``q`` (n_coordinates,): zero on the machine's own configurations, not on the others of its kept
    rows (a spherical wrist's platform moved off its centre); empty where none are set aside."""
    m = model.description
    if not getattr(m, "spatial", False) or m.platform.kind != "rigid":
        return np.zeros(0)
    from ..description import mobility

    # every point row is kept: the rows set aside are orientation rows
    n_point, kept = 3 * len(m.legs), mobility.kept_rows(m)
    aside = [r for r in range(len(mobility.all_orientation_rows(m))) if n_point + r not in kept]
    if not aside:
        return np.zeros(0)
    x = _description_coordinates(model, np.asarray(q, dtype=float))
    return mobility.orientation_residuals(m, x[None])[0, aside]


def _evaluate(model: MechanismModel, fn, shape, q, *args) -> np.ndarray:
    """``fn``'s output (``shape``) at configuration ``q``; ``args`` between the trig table and ``P``."""
    out = np.empty(shape)
    fn(q, trig_table(model, q), *args, model.P, out)
    return out


def _q(model: MechanismModel, q) -> np.ndarray:
    q = np.asarray(q, dtype=float)
    if q.shape != (len(model.coordinates),):
        raise InvalidParameterError(f"q must be the {len(model.coordinates)} coordinates "
                                    f"({', '.join(model.coordinates)}), got shape {q.shape}")
    return q


def constraint_residual(model: MechanismModel, q) -> np.ndarray:
    """``η(q)``: for each leg, the end of its chain minus its platform attachment point."""
    k = model.kernels
    return _evaluate(model, k.constraints, (k.N_CONSTRAINTS,), _q(model, q))


def constraint_jacobian(model: MechanismModel, q) -> np.ndarray:
    """``Jηq = ∂η/∂q`` (n_constraints, n_coordinates)."""
    k = model.kernels
    return _evaluate(model, k.constraint_jacobian, (k.N_CONSTRAINTS, k.N_COORDINATES), _q(model, q))


def _bodies(model: MechanismModel, q, q_dot):
    k = model.kernels
    J = _evaluate(model, k.body_jacobians, (k.N_BODIES, 3, k.N_COORDINATES), q)
    bias = _evaluate(model, k.body_bias, (k.N_BODIES, 3), q, q_dot)
    return J, bias


def gravity_vector(model: MechanismModel, q) -> np.ndarray:
    """``g(q) = ∂V/∂q``: the generalised forces that hold the machine still against gravity."""
    q = _q(model, q)
    if getattr(model.description, "spatial", False):
        return _spatial_full_space_model(model, q, np.zeros_like(q))[2]
    k = model.kernels
    return _gravity(model, _evaluate(model, k.body_jacobians, (k.N_BODIES, 3, k.N_COORDINATES), q))


def _gravity(model: MechanismModel, J: np.ndarray) -> np.ndarray:
    """``g = -Σ_b m_b J_b,linᵀ gravity`` from the bodies' Jacobians ``J`` (n_bodies, 3, n)."""
    weights = model.body_weights[:, 0]
    gx, gy = model.description.gravity
    return -(weights[:, None] * (gx * J[:, 0, :] + gy * J[:, 1, :])).sum(axis=0)


def full_space_model(model: MechanismModel, q, q_dot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(M, C q̇, g)`` of the unconstrained bodies in the coordinates ``q`` (eqs. 23–24, with gravity)."""
    q, q_dot = _q(model, q), _q(model, q_dot)
    if getattr(model.description, "spatial", False):
        return _spatial_full_space_model(model, q, q_dot)
    J, bias = _bodies(model, q, q_dot)
    D = model.body_weights
    return lagrangian.mass_matrix(J, D), lagrangian.velocity_product(J, D, bias), _gravity(model, J)


def _spatial_full_space_model(model: MechanismModel, q, q_dot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`full_space_model` of spatial bodies (rows: mass-centre velocity, angular velocity ``ω`` in the
    body's frame): ``M = Σ m J_vᵀ J_v + J_ωᵀ I J_ω``, ``C q̇ = Σ m J_vᵀ J̇_v q̇ + J_ωᵀ (I J̇_ω q̇ + ω × I ω)``,
    ``g = -Σ m J_vᵀ gravity`` — the Newton–Euler equations of every body in the coordinates ``q``."""
    k = model.kernels
    J = _evaluate(model, k.body_jacobians, (k.N_BODIES, 6, k.N_COORDINATES), q)
    bias = _evaluate(model, k.body_bias, (k.N_BODIES, 6), q, q_dot)
    m = model.description
    bodies = [b for leg in m.legs for b in leg.bodies] + [m.platform]
    gravity = np.array(m.gravity)
    n = len(q)
    M, h, g = np.zeros((n, n)), np.zeros(n), np.zeros(n)
    for body, jb, bb in zip(bodies, J, bias, strict=True):
        jv, jw = jb[:3], jb[3:]
        inertia = np.array(body.inertia)
        omega = jw @ q_dot
        M += body.mass * jv.T @ jv + jw.T @ inertia @ jw
        h += body.mass * jv.T @ bb[:3] + jw.T @ (inertia @ bb[3:] + np.cross(omega, inertia @ omega))
        g -= body.mass * jv.T @ gravity
    return M, h, g


def actuator_space_model(model: MechanismModel, q, theta_dot) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """``(Mθ, cθ, gθ)`` of ``Mθ θ̈ + cθ + gθ = τθ`` (eq. 35, with gravity) at a configuration ``q`` on
    the loop-closure manifold and actuator rates ``θ̇``."""
    q = _q(model, q)
    theta_dot = np.asarray(theta_dot, dtype=float)
    if theta_dot.shape != (model.n_actuators,):
        raise InvalidParameterError(f"theta_dot must be {model.n_actuators} actuator rates, got shape "
                                    f"{theta_dot.shape}")
    n = model.n_actuators
    m_theta, c_theta, g_theta = np.empty((1, n, n)), np.empty((1, n)), np.empty((1, n))
    # the compiled core's (pkmlab.codegen.core.dynamics.actuator_space_model): the simulation's own numbers
    if model.kernels.actuator_space_models(q[None, :], theta_dot[None, :], model.P, m_theta, c_theta, g_theta) >= 0:
        raise SingularityError("the configuration is at a gain-type singularity: det(J_eta_phi) = 0")
    return m_theta[0], c_theta[0], g_theta[0]


def constrained_accelerations(model: MechanismModel, q, q_dot, tau) -> tuple[np.ndarray, np.ndarray]:
    """``(q̈, λ)`` of the full model ``M q̈ + C q̇ + g = Q + Jηqᵀ λ`` with ``Jηq q̈ + J̇ηq q̇ = 0`` (eq. 26),
    where ``Q`` applies the actuator efforts ``τ`` to the actuated coordinates."""
    q, q_dot = _q(model, q), _q(model, q_dot)
    k = model.kernels
    M, h, g = full_space_model(model, q, q_dot)
    Q = np.zeros(len(q))
    Q[:model.n_actuators] = tau
    gamma = _evaluate(model, k.constraint_bias, (k.N_CONSTRAINTS,), q, q_dot)
    q_ddot, multipliers, ok = lagrangian.constrained_accelerations(M, h + g, constraint_jacobian(model, q), gamma, Q)
    if not ok:
        raise SingularityError("the constrained model is singular at this configuration")
    return q_ddot, multipliers


# ------------------------------------------------------------------ inverse kinematics
def _leg_signs(modes: tuple) -> int:
    """How many signs of a working mode a leg takes: 0 (one branch), 1 (``(1, -1)``), or the length of its
    modes' tuples (a leg of the general method with four branches: two)."""
    return 0 if not modes else len(modes[0]) if isinstance(modes[0], tuple) else 1


def working_modes(model: MechanismModel) -> list[tuple[int, ...]]:
    """Every working mode: one sign per two-branch leg (two for a leg of four branches), +1 before -1, in
    lexicographic order (``[()]`` when no leg has two branches, as for the 3-RPR)."""
    import itertools

    leg_modes = leg_solver(model.description).working_modes
    per_leg = [[m if isinstance(m, tuple) else (m,) for m in leg_modes(leg)] for leg in model.description.legs]
    return [sum(combination, ()) for combination in itertools.product(*[modes for modes in per_leg if modes])]


def inverse_kinematics(model: MechanismModel, pose, mode) -> np.ndarray:
    """The configuration ``q`` (actuators, passive joints, pose) of ``pose`` in working ``mode`` (one sign
    per two-branch leg, :func:`working_modes`), in closed form per leg type
    (:mod:`pkmlab.description.leg_types`). Raises naming the leg that cannot reach."""
    from ..errors import UnreachablePoseError

    m = model.description
    pose = np.asarray(pose, dtype=float)
    if pose.shape != (m.dof,) or not np.all(np.isfinite(pose)):
        raise InvalidParameterError(f"pose must be ({', '.join(m.pose_names)}), finite, got {pose.tolist()}")
    if getattr(m, "spatial", False):
        from ..description.spatial import check_pose

        check_pose(m, pose)
    q, _unreachable, failure = inverse_kinematics_batch(model, pose[None, :], mode)
    if failure is not None:
        _k, leg, message = failure
        raise UnreachablePoseError(message, legs=(leg + 1,))
    return q[0]


def inverse_kinematics_batch(model: MechanismModel, poses: np.ndarray, mode, follow: bool = False,
                             branches: dict | None = None, rows: slice | None = None):
    """``q`` (K, n_coordinates) of poses (K, dof) in one working mode, NaN rows where a leg cannot reach;
    the legs that cannot, a bit mask per pose (K,) (bit ``i`` for leg ``i + 1``); and the first failure
    ``(k, leg, message)`` (else None). ``follow``: the poses are a finely sampled path, along which a leg of the
    general method follows its branch by continuity
    (:func:`~pkmlab.description.general_legs.general_inverse_kinematics_batch`). ``branches``: a dict that calls
    on the same poses with the same ``follow`` in other modes share, so that each leg's branch (and a
    lower-mobility platform's whole pose, and the platform's orientation) is solved once for all the modes —
    ``2n`` leg solutions for the ``2ⁿ`` modes of ``n`` two-branch legs. ``rows``: the configurations of those poses
    only (the failures still those of all the poses), where a leg's reach alone decides them (no platform joint's
    orientation to check)."""
    branches = {} if branches is None else branches
    m = model.description
    solver = leg_solver(m)
    leg_inverse_kinematics_batch, leg_modes = solver.leg_inverse_kinematics_batch, solver.working_modes
    extra = (solver.central_axis(m), follow) if getattr(m, "spatial", False) else ()
    signs = iter(tuple(mode))
    actuators, passive, unreachable = [], [], np.zeros(len(poses), dtype=np.int64)
    first, whole_failed = None, None
    q_pose = poses
    if getattr(m, "spatial", False) and m.platform.parasitic_names:
        # a platform of lower mobility: its whole pose first (the parasitic motion does not depend on the legs'
        # working modes, which only choose among the configurations at one pose)
        from .parasitic import parasitic_poses

        if "pose" not in branches:
            branches["pose"] = parasitic_poses(model, poses)
        whole, failed, first_failure = branches["pose"]
        order = [m.platform.full_pose_names.index(c) for c in m.platform.q_pose_names]
        q_pose = whole[:, order]
        poses, whole_failed = whole, (failed, first_failure)
    if m.redundancy_names:  # the platform's pose; each kinematically redundant leg's base actuators from the rest
        q_pose, poses = poses[:, :len(m.platform.pose_names)], poses
    for i, leg in enumerate(m.legs):
        width = _leg_signs(leg_modes(leg))
        sigma = tuple(next(signs, None) for _ in range(width)) if width else (1,)
        if any(s not in (1, -1) for s in sigma):
            raise InvalidParameterError(f"mode must be one sign (+1 or -1) per two-branch leg (two per leg of four "
                                        f"branches), got {tuple(mode)}")
        sigma = sigma[0] if len(sigma) == 1 else sigma
        if (i, sigma) not in branches:
            base = (poses[:, [m.pose_names.index(f"a{m.actuators.index((i, k)) + 1}")
                              for k in leg.actuated_joints[:leg.moving_base]]],) if leg.moving_base else ()
            if "turns" not in branches:  # the platform's orientation, once for all the legs and modes
                branches["turns"] = platform_turns_of(m, poses)
            points = attachment_points_of(m, i, poses, branches["turns"])
            branches[i, sigma] = leg_inverse_kinematics_batch(leg, i, points, sigma,
                                                              *extra, *base)
        solved = branches[i, sigma]
        if solved.bad.any():
            k = int(np.argmax(solved.bad))
            if first is None or k < first[0]:
                first = (k, i, solved.why(k))
            unreachable |= solved.bad.astype(np.int64) << i
        # the actuators' columns among the leg's joint coordinates (a spatial U joint before one has two)
        columns = [sum(getattr(j, "coordinates", 1) for j in leg.joints[:k]) for k in leg.actuated_joints]
        actuators += [solved.coordinates[:, c] for c in columns]
        passive += [solved.coordinates[:, k] for k in range(solved.coordinates.shape[1]) if k not in columns]
    if next(signs, None) is not None:
        raise InvalidParameterError(f"mode has more signs than two-branch legs, got {tuple(mode)}")
    if whole_failed is not None:
        failed, first_failure = whole_failed
        failed_legs = (1 << len(m.legs)) - 1  # no pose: no leg can be placed
        unreachable[failed] = failed_legs
        if first_failure is not None and (first is None or first_failure[0] <= first[0]):
            first = (first_failure[0], 0, first_failure[1])
    # C order whatever the columns' (a lower-mobility platform's pose columns may be in Fortran order): the kernels
    # are compiled for one layout of q
    if rows is not None and not checks_platform_joints(model):  # the other poses' configurations are not needed
        q = np.ascontiguousarray(np.column_stack([column[rows] for column in (*actuators, *passive, q_pose)]))
        q[unreachable[rows] != 0] = np.nan
        return q, unreachable, first
    q = np.ascontiguousarray(np.column_stack([*actuators, *passive, q_pose]))
    missed = _platform_joint_misses(model, q, unreachable)
    if missed is not None:
        unreachable |= missed[0]
        if first is None or missed[1][0] < first[0]:
            first = missed[1]
    q[unreachable != 0] = np.nan
    return (q, unreachable, first) if rows is None else (np.ascontiguousarray(q[rows]), unreachable, first)


def checks_platform_joints(model: MechanismModel) -> bool:
    """Whether the inverse kinematics of a pose checks that a leg's platform joint can carry the platform (a leg
    ending in a universal or revolute joint under a rigid platform, :func:`_platform_joint_misses`): a path's
    configurations are then put together whole, whatever rows are asked for."""
    if not getattr(model.description, "spatial", False):
        return False
    from ..description import mobility

    return bool(mobility.all_orientation_rows(model.description))


#: Largest orientation row (rad) of a configuration inverse kinematics gives: a leg's platform joint that misses by
#: more cannot carry the platform in that working mode.
ORIENTATION_TOL = 1e-9


def _platform_joint_misses(model: MechanismModel, q: np.ndarray, unreachable: np.ndarray):
    """For a machine whose legs end in a universal or revolute joint under a rigid platform: each leg's working
    mode places its platform joint's centre, but only some turn its last body so that the joint can carry the
    platform (its orientation rows, :mod:`pkmlab.description.mobility`). Returns the legs that cannot, a bit
    mask per configuration, and the first ``(k, leg, message)``; None when every one can (or the machine has no
    such rows)."""
    m = model.description
    if not checks_platform_joints(model):
        return None
    from ..description import mobility

    orient = mobility.all_orientation_rows(m)
    placed = np.flatnonzero(unreachable == 0)
    rows = np.abs(mobility.orientation_residuals(m, _description_coordinates(model, q[placed])))
    missed, first = np.zeros(len(q), dtype=np.int64), None
    for r, (leg, _row) in enumerate(orient):
        bad = rows[:, r] > ORIENTATION_TOL
        missed[placed[bad]] |= 1 << leg
        if bad.any() and (first is None or placed[bad][0] < first[0]):
            k = int(np.argmax(bad))
            first = (int(placed[k]), leg, f"leg {leg + 1} ({m.legs[leg].notation}): its platform joint cannot carry "
                                          f"the platform in this working mode (its axes miss by {rows[k, r]:.3g} "
                                          "rad): try another")
    return None if first is None else (missed, first)


def _description_coordinates(model: MechanismModel, q: np.ndarray) -> np.ndarray:
    """``x`` of :mod:`pkmlab.description.mobility` (legs' joint coordinates leg by leg, the whole pose) of
    configurations ``q`` (..., n_coordinates)."""
    from ..description.spatial import full_poses

    m = model.description
    n_pose = len(m.platform.q_pose_names)
    columns = [c for leg in leg_columns(m) for c in leg]
    return np.concatenate([q[..., columns], full_poses(m, q[..., q.shape[-1] - n_pose:])], axis=-1)


# ------------------------------------------------------------------ singularity measure
def singularity_measure(model: MechanismModel, q) -> float:
    """The gain-type singularity measure ``S`` at ``q``: zero where the passive motion is undetermined
    (:func:`pkmlab.codegen.core.branch_following.singularity_measure`: for three legs on a rigid platform, the
    determinant of the legs' lines of action, the paper's eq. (19) for its machine; for the five-bar,
    ``sin(φ1 - φ2)``)."""
    q = _q(model, q)
    return float(model.kernels.singularity_measure(q, trig_table(model, q), model.P,
                                                    np.empty((model.n_actuators, model.kernels.LINE_WIDTH))))


# ------------------------------------------------------------------ along a path
def dependent_columns(model: MechanismModel) -> list[int]:
    """The columns of ``q`` other than the controlled coordinates' (:attr:`MechanismModel.pose_columns`): the ones
    the loop closures fix once the pose is given."""
    pose = set(model.pose_columns)
    return [i for i in range(len(model.coordinates)) if i not in pose]


#: ``∂η/∂u`` (the loop closures' Jacobian in the coordinates other than the pose's) is taken as singular beyond this
#: condition number: a leg at a serial singularity, its joint rates undetermined by the pose's.
SERIAL_CONDITION = 1e12


def pose_solve(model: MechanismModel, j_eta: np.ndarray, rhs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``-(∂η/∂u)⁻¹ rhs`` for the coordinates ``u`` other than the pose's, for each of ``K`` configurations'
    ``j_eta`` (K, m, n) and ``rhs`` (K, m, k); and which configurations are at a serial singularity (``(K,)``
    bool, their rows NaN)."""
    a = j_eta[:, :, dependent_columns(model)]
    if a.shape[1] != a.shape[2]:
        raise InvalidParameterError(f"{model.name}: its loop closures ({a.shape[1]} rows) do not fix its "
                                    f"{a.shape[2]} coordinates other than the pose")
    singular = np.linalg.cond(a) > SERIAL_CONDITION
    out = np.full(rhs.shape, np.nan)
    if (~singular).any():
        out[~singular] = -np.linalg.solve(a[~singular], rhs[~singular])
    return out, singular


def pose_jacobians(model: MechanismModel, qs: np.ndarray, j_eta: np.ndarray | None = None
                   ) -> tuple[np.ndarray, np.ndarray]:
    """``Jqx = ∂q/∂x`` (K, n, dof) of configurations ``qs`` (K, n) on the loop closure, NaN where a leg is at a
    serial singularity, and where that is (K,); from their ``Jηq`` (K, m, n) where the caller has it."""
    if j_eta is None:
        k = model.kernels
        j_eta = np.empty((len(qs), k.N_CONSTRAINTS, k.N_COORDINATES))
        k.constraint_jacobians(np.ascontiguousarray(qs, dtype=float), model.P, j_eta)
    pose = list(model.pose_columns)
    out = np.zeros((len(qs), len(model.coordinates), model.dof))
    out[:, pose, :] = np.eye(model.dof)
    out[:, dependent_columns(model), :], singular = pose_solve(model, j_eta, j_eta[:, :, pose])
    out[singular] = np.nan
    return out, singular


def actuation_measures(model: MechanismModel, qs: np.ndarray, actuators=None) -> np.ndarray:
    """The smallest singular value of ``W = ∂θ/∂x`` (``Jqx``'s actuator rows, or those of ``actuators``) of each
    configuration ``qs`` (K, n), its orientation columns divided by the platform's size (``ℓ ω`` is the speed of a
    point ``ℓ`` from the centre: every column in actuator units per metre); NaN at a leg's serial singularity."""
    rows = list(range(model.n_actuators)) if actuators is None else list(actuators)
    W = pose_jacobians(model, qs)[0][:, rows, :]  # θ = q[..., :n_a]
    scale = np.ones(model.dof)
    scale[[k for k, name in enumerate(model.pose_names) if name in ("alpha", "roll", "pitch", "yaw")]] = \
        1.0 / float(model.kernels.platform_size(model.P))
    out = np.full(len(qs), np.nan)
    finite = np.all(np.isfinite(W), axis=(1, 2))
    if finite.any():
        out[finite] = np.linalg.svd(W[finite] * scale, compute_uv=False)[:, -1]
    return out


def configuration_measures(model: MechanismModel, qs: np.ndarray, actuators=None) -> np.ndarray:
    """The singularity measure of each configuration ``qs`` (K, n), NaN for a NaN row: ``S`` of the kernels, or a
    redundantly actuated machine's actuation measure (:func:`actuation_measures`, of ``actuators`` where given)."""
    s = np.full(len(qs), np.nan)
    if not model.description.actuation_redundancy:
        model.kernels.singularity_measures(qs, model.P, s)
        return s
    reached = np.all(np.isfinite(qs), axis=1)
    if reached.any():
        s[reached] = actuation_measures(model, qs[reached], actuators)
    return s


def path_inverse_kinematics(model: MechanismModel, poses, mode, follow: bool = False,
                            branches: dict | None = None) -> tuple[np.ndarray, np.ndarray, tuple | None]:
    """Inverse kinematics of many poses ``(K, dof)`` in one working ``mode``, at once; ``follow`` when they are
    a finely sampled path, ``branches`` shared by the calls on the same poses in other modes
    (:func:`inverse_kinematics_batch`).

    Returns ``(q (K, n_coordinates), S (K,), failure)``: rows that cannot be reached are NaN, and
    ``failure`` is ``(k, error)`` for the first of them (the error names the leg), else None. A redundantly actuated
    machine's ``S`` is its actuation's measure (:func:`actuation_measures`).
    """
    q, failure = path_configurations(model, poses, mode, follow, branches)
    return q, configuration_measures(model, q), failure


def path_configurations(model: MechanismModel, poses, mode, follow: bool = False,
                        branches: dict | None = None, rows: slice | None = None) -> tuple[np.ndarray, tuple | None]:
    """:func:`path_inverse_kinematics` without the singularity measures: ``(q (K, n_coordinates), failure)``; the
    configurations of the poses ``rows`` only, if given (:func:`inverse_kinematics_batch`)."""
    from ..errors import UnreachablePoseError

    poses = np.asarray(poses, dtype=float).reshape(-1, model.description.dof)
    q, _unreachable, first = inverse_kinematics_batch(model, poses, mode, follow, branches, rows)
    failure = None if first is None else (first[0], UnreachablePoseError(first[2], legs=(first[1] + 1,)))
    return q, failure


def well_conditioned_configuration(model: MechanismModel, mode: tuple[int, ...]) -> np.ndarray:
    """A configuration far from the gain-type singularities in working mode ``mode``: the pose of largest ``|S|``
    on a grid over the machine's region (planar: the assembly check's region and 12 orientations; spatial: its
    legs' reach, level, 25 points a side — 9 where a leg has no closed form; a machine of lower mobility: the pose
    its mobility computation found; a kinematically redundant machine's base actuators at zero)."""
    from ..errors import PkmlabError
    from .reach import planar_extent, spatial_extent

    m = model.description
    spatial = getattr(m, "spatial", False)
    if spatial and m.platform.parasitic_names:
        from .parasitic import home_configuration

        return inverse_kinematics(model, home_configuration(model)[-m.dof:], mode)
    if spatial:
        from ..description.spatial_legs import has_closed_form

        # a leg without a closed form costs a homotopy per point (about a millisecond): a coarser grid
        count = 25 if all(has_closed_form(leg) for leg in m.legs) else 9
        axes = [np.linspace(lo, hi, count) for lo, hi in spatial_extent(m)]
        grid = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        poses = np.column_stack([grid, np.zeros((len(grid), m.dof - 3))])
    else:
        (x0, x1), (y0, y1) = planar_extent(m)
        turns = np.linspace(-np.pi, np.pi, 12, endpoint=False) if m.platform.kind == "rigid" else [0.0]
        gx, gy, ga = np.meshgrid(np.linspace(x0, x1, 41), np.linspace(y0, y1, 41), turns)
        poses = np.column_stack([gx.ravel(), gy.ravel(), ga.ravel()])[:, :len(m.platform.pose_names)]
        # a kinematically redundant machine's base actuators at zero, as the assembly check tries them
        poses = np.column_stack([poses, np.zeros((len(poses), len(m.redundancy_names)))])
    q, s, _failure = path_inverse_kinematics(model, poses, mode)
    if not np.isfinite(s).any():
        raise PkmlabError(f"{m.name}: no pose of the search grid can be assembled in working mode {mode}: give q")
    return q[int(np.nanargmax(np.abs(s)))]


def _run_or_list(columns: list[int]) -> slice | list[int]:
    """``columns`` as a slice where they are consecutive (indexing by it gives a view), else the list."""
    return slice(columns[0], columns[-1] + 1) if columns == list(range(columns[0], columns[-1] + 1)) else columns


#: Samples of a path whose Jacobians :func:`path_rates` holds at once.
PATH_CHUNK = 8192


def path_rates(model: MechanismModel, q, pose_dot, pose_ddot) -> tuple[np.ndarray, np.ndarray, int]:
    """Actuator rates and accelerations along configurations ``q`` (K, n_coordinates) whose pose moves
    with ``pose_dot``, ``pose_ddot`` (K, dof): differentiating ``η(q) = 0`` once and twice,

        ``A u̇ = -B ẋ``,   ``A ü = -B ẍ - J̇ηq q̇``

    with ``u`` the coordinates other than the controlled ones (the actuators and passive joints), ``A = ∂η/∂u``,
    ``B = ∂η/∂pose`` (paper eqs. 14–17, 32).
    Returns ``(θ̇, θ̈, k)``: ``k`` the first sample where ``A`` is singular (the pose at the edge of the
    workspace: an inverse-kinematic singularity; :func:`~pkmlab.numerics.batched.factor_blocks`), else -1.
    """
    k_ = model.kernels
    count, n, N = q.shape[0], model.n_actuators, k_.N_COORDINATES
    # the controlled coordinates' columns and the others': slices where they are runs (every machine of one actuator
    # per leg), so that the Jacobians' blocks are views and the numbers those of one summation order
    columns = model.pose_columns  # (a property that searches the coordinates' names: once, not once a column)
    pose = _run_or_list(list(columns))  # in the order of pose_dot's columns
    others = _run_or_list([c for c in range(N) if c not in columns])
    theta_dot, theta_ddot = np.empty((count, n)), np.empty((count, n))
    for start in range(0, count, PATH_CHUNK):  # a chunk at a time: a long path's Jacobians never all at once
        rows = slice(start, min(start + PATH_CHUNK, count))
        qc = np.ascontiguousarray(q[rows])
        j_eta, gamma = np.empty((len(qc), k_.N_CONSTRAINTS, N)), np.empty((len(qc), k_.N_CONSTRAINTS))
        k_.constraint_jacobians(qc, model.P, j_eta)
        b = j_eta[:, :, pose]
        # each leg's loop closures alone, factored once for the check and the solves (read in j_eta: no copy)
        factors = factor_blocks(j_eta, columns=others)
        a = j_eta[:, :, others] if factors.lu is None else None  # the matrices, for NumPy's solve of small ones
        if factors.singular >= 0:
            return np.empty((count, n)), np.empty((count, n)), start + factors.singular
        q_dot, q_ddot = np.empty((len(qc), N)), np.empty((len(qc), N))
        q_dot[:, pose], q_ddot[:, pose] = pose_dot[rows], pose_ddot[rows]
        q_dot[:, others] = solve_factored_blocks(factors, a, -np.einsum("kij,kj->ki", b, pose_dot[rows]))
        k_.constraint_biases(qc, q_dot, model.P, gamma)
        rhs = -np.einsum("kij,kj->ki", b, pose_ddot[rows]) - gamma
        q_ddot[:, others] = solve_factored_blocks(factors, a, rhs)
        theta_dot[rows], theta_ddot[rows] = q_dot[:, :n], q_ddot[:, :n]
    return theta_dot, theta_ddot, -1
