"""Any described mechanism bound to its generated kernels, and its dynamics — written once.

A :class:`MechanismModel` is the immutable pair (description, packed parameters) plus the
compiled kernels generated for its structure (:mod:`pkmlab.derivations.planar`), which carry the
compiled core of :mod:`pkmlab.machine_core`: the same role as :class:`~pkmlab.geometry.Planar3RRR`
plays for the paper's 3-RRR, for every mechanism. The functions below are the paper's formulation
applied to it:

* the constrained Lagrangian model in the full coordinates ``q`` (eqs. 20–26) with gravity,
  ``M(q) q̈ + C(q, q̇) q̇ + g(q) = τ + Jηqᵀ λ``, through the mechanism-agnostic algebra of
  :mod:`pkmlab.lagrangian` — the independent cross-check;
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
import math
from dataclasses import dataclass, field
from types import ModuleType

import numpy as np

from . import lagrangian
from .derivations import planar
from .errors import InvalidParameterError, SingularityError
from .mechanisms.description import Mechanism
from .mechanisms.presets import preset


@dataclass(frozen=True)
class MechanismModel:
    """A described mechanism with its packed parameters and generated kernels.

    >>> model = MechanismModel.from_preset("five_bar")
    >>> model.coordinates
    ('a1', 'a2', 'q1_2', 'q2_2', 'x', 'y')
    """

    description: Mechanism
    P: np.ndarray = field(compare=False, repr=False)
    kernels: ModuleType = field(compare=False, repr=False)

    @classmethod
    def from_description(cls, description: Mechanism) -> MechanismModel:
        from .mechanisms.spatial import SpatialMechanism

        if not isinstance(description, Mechanism | SpatialMechanism):
            raise InvalidParameterError(f"description must be a Mechanism or a SpatialMechanism, got "
                                        f"{type(description).__name__}")
        model = _bind(description)
        _check_assembly(model)
        return model

    @classmethod
    def from_preset(cls, name: str) -> MechanismModel:
        return cls.from_description(preset(name))

    @classmethod
    def from_3rrr(cls, model) -> MechanismModel:
        """The generic model of a :class:`~pkmlab.geometry.Planar3RRR`, from its
        :meth:`~pkmlab.geometry.Planar3RRR.to_mechanism`: what runs its simulations. Cached: a study builds it
        once per machine."""
        return _from_3rrr(model)

    @property
    def coordinates(self) -> tuple[str, ...]:
        return self.kernels.COORDINATES

    @property
    def n_actuators(self) -> int:
        return len(self.description.legs)

    @property
    def name(self) -> str:
        return self.description.name

    @property
    def pose_names(self) -> tuple[str, ...]:
        """The platform's pose coordinates, e.g. ``('x', 'y', 'alpha')``: the last entries of ``q``."""
        return tuple(self.description.pose_names)

    @property
    def dof(self) -> int:
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
        (:class:`~pkmlab.mechanisms.description.Mechanism`, :class:`~pkmlab.mechanisms.spatial.SpatialMechanism`),
        or a model (returned as it is).

    Returns
    -------
    MechanismModel
        The immutable description bound to its structure's compiled kernels.

    Examples
    --------
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> model.coordinates
    ('a1', 'a2', 'a3', 'q1_2', 'q2_2', 'q3_2', 'x', 'y', 'alpha')
    """
    import os
    from pathlib import Path

    from .errors import shown
    from .mechanisms.files import load_mechanism
    from .mechanisms.presets import PRESETS
    from .mechanisms.spatial import SpatialMechanism

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
    """The derivation of a description: :mod:`pkmlab.derivations.spatial` for a spatial machine, else
    :mod:`pkmlab.derivations.planar`."""
    if getattr(description, "spatial", False):
        from .derivations import spatial

        return spatial
    return planar


def _bind(description: Mechanism) -> MechanismModel:
    """The description with its packed parameters and its structure's kernels (shipped, or generated once)."""
    derived = derivation(description)
    try:
        kernels = importlib.import_module(f".mechanisms.generated.{derived.generated_path(description).stem}",
                                          __package__)
    except ModuleNotFoundError:
        kernels = _user_structure_kernels(description)
    P = derived.pack(description)
    P.setflags(write=False)
    return MechanismModel(description, P, kernels)


@functools.lru_cache(maxsize=64)
def _from_3rrr(model) -> MechanismModel:
    return _bind(model.to_mechanism())  # the Planar3RRR checked already that its platform can be assembled


def planar_extent(description) -> tuple[tuple[float, float], tuple[float, float]]:
    """A region ``((x0, x1), (y0, y1))`` covering a planar machine's base and every leg's reach: its base points
    and rails' far ends, grown by a quarter of its longest leg (the five-bar, which works above its base
    line, by the whole leg) — where its workspace, maps and assembly check look."""
    legs = description.legs
    points = [leg.base for leg in legs]
    for leg in legs:  # a rail's far end
        if leg.joints[0].kind == "P" and leg.stroke is not None:
            a = leg.joints[0].axis
            points.append((leg.base[0] + leg.stroke[1] * math.cos(a), leg.base[1] + leg.stroke[1] * math.sin(a)))
    reach = max(sum(math.hypot(*b.tip) for b in leg.bodies) + (leg.stroke[1] if leg.stroke else 0.0)
                for leg in legs)
    lo, hi = np.min(points, axis=0) - 0.25 * reach, np.max(points, axis=0) + 0.25 * reach
    if len(legs) == 2:  # the five-bar works above its base line: reach all around it
        lo, hi = np.min(points, axis=0) - reach, np.max(points, axis=0) + reach
    return (float(lo[0]), float(hi[0])), (float(lo[1]), float(hi[1]))


#: Grids of the assembly check: positions per axis over the machine's region, and orientations; the
#: finer one is searched only when the coarse one finds no pose (a machine with a small workspace).
ASSEMBLY_GRIDS = ((81, 24), (241, 72))


def _check_assembly(model: MechanismModel) -> None:
    """Refuse a machine whose platform can be assembled nowhere: no pose on a grid over its region
    (:func:`planar_extent`, every orientation) where every leg reaches its attachment
    point in some working mode, within its stroke. Names the first leg that cannot join the others."""
    from .mechanisms.description import attachment_points
    from .mechanisms.leg_types import leg_inverse_kinematics_batch
    from .mechanisms.leg_types import working_modes as leg_modes

    m = model.description
    if getattr(m, "spatial", False):
        _check_spatial_assembly(model)
        return
    (x0, x1), (y0, y1) = planar_extent(m)
    furthest = 0  # the most legs joined at one pose, over the orientations tried
    for count, turns in ASSEMBLY_GRIDS:
        x, y = (a.ravel() for a in np.meshgrid(np.linspace(x0, x1, count), np.linspace(y0, y1, count)))
        # one orientation at a time: a machine that can be assembled is found so in the first one, usually
        for alpha in (np.linspace(-np.pi, np.pi, turns, endpoint=False) if m.dof == 3 else (0.0,)):
            poses = np.column_stack([x, y, np.full(x.size, alpha)])[:, :m.dof]
            together = np.ones(x.size, dtype=bool)
            for i, leg in enumerate(m.legs):
                points = attachment_points(m, i, poses)
                reached = np.zeros(x.size, dtype=bool)
                for sigma in leg_modes(leg) or (1,):
                    reached |= ~leg_inverse_kinematics_batch(leg, i, points, sigma).bad
                together &= reached
                if not together.any():
                    furthest = max(furthest, i)
                    break
            else:
                return
    count, turns = ASSEMBLY_GRIDS[-1]
    others = f" together with legs 1..{furthest}" if furthest > 0 else ""
    grid = f"{count} x {count} positions" + (f" x {turns} orientations" if m.dof == 3 else "")
    raise InvalidParameterError(
        f"{m.name}: the platform can be assembled nowhere: leg {furthest + 1} reaches its attachment point{others} "
        f"at no pose of a {grid} grid over x in [{x0:.3g}, {x1:.3g}] m, y in [{y0:.3g}, {y1:.3g}] m "
        "(check the legs' lengths, strokes, bases and attachment points)")


#: Positions per axis of the spatial assembly check's grids (the platform level, over the legs' reach): the
#: coarse grid first, a subset of the fine one (41 = 5·8 + 1), so a machine that assembles is accepted after a
#: few hundred poses (a plant drawn in an uncertainty study is checked in milliseconds) and the refusal of one
#: that assembles nowhere is the fine grid's.
SPATIAL_ASSEMBLY_GRIDS = (9, 41)


def spatial_extent(description) -> np.ndarray:
    """The box (3, 2) a spatial machine's platform point can reach at most: around the legs' bases, as far
    as the longest leg reaches (its bodies' tips, its slide's upper stroke) plus the platform's size."""
    bases = np.array([leg.base for leg in description.legs])
    reach = max(sum(float(np.linalg.norm(b.tip)) for b in leg.bodies)
                + (max(abs(v) for v in leg.stroke) if leg.stroke and leg.joints[leg.actuated].kind == "P" else 0.0)
                for leg in description.legs)
    size = max(float(np.linalg.norm(a)) for a in description.platform.attachments)
    return np.column_stack([bases.min(0) - reach - size, bases.max(0) + reach + size])


def _check_spatial_assembly(model: MechanismModel) -> None:
    """:func:`_check_assembly` for a spatial machine: some platform position of a grid over
    :func:`spatial_extent` (the platform level) where every leg reaches its attachment point."""
    from .mechanisms import spatial_legs

    m = model.description
    box = spatial_extent(m)
    for count in SPATIAL_ASSEMBLY_GRIDS:
        axes = [np.linspace(lo, hi, count) for lo, hi in box]
        points = np.stack(np.meshgrid(*axes, indexing="ij"), axis=-1).reshape(-1, 3)
        poses = np.column_stack([points, np.zeros((len(points), m.dof - 3))])
        together = np.ones(len(poses), dtype=bool)
        for i, leg in enumerate(m.legs):
            reached = np.zeros(len(poses), dtype=bool)
            for sigma in spatial_legs.working_modes(leg) or (1,):
                reached |= ~spatial_legs.leg_inverse_kinematics_batch(
                    leg, i, _attachment_points(m, i, poses), sigma, spatial_legs.central_axis(m)).bad
            together &= reached
            if not together.any():
                break
        else:
            return
    others = f" together with legs 1..{i}" if i > 0 else ""
    raise InvalidParameterError(
        f"{m.name}: the platform can be assembled nowhere: leg {i + 1} reaches its attachment point{others} "
        f"at no position of a {count}^3 grid over "
        + ", ".join(f"{c} in [{lo:.3g}, {hi:.3g}] m" for c, (lo, hi) in zip("xyz", box, strict=True))
        + (" (level platform)" if m.dof == 6 else "") + " (check the legs' lengths, strokes, bases and "
        "attachment points)")


def _user_structure_kernels(description: Mechanism) -> ModuleType:
    """The kernels of a structure pkmlab does not ship: derived and generated once (SymPy, a few seconds),
    kept in pkmlab's cache folder beside the compiled kernels, and imported from there — so a later
    process neither derives nor compiles them again. Written atomically: a concurrent process reads
    either nothing or the whole module."""
    import importlib.util
    import os
    import sys
    import tempfile

    from ._compile_cache import CACHE_DIR

    derived = derivation(description)
    name = f"pkmlab_kernels_{derived.generated_path(description).stem}"
    if name in sys.modules:
        return sys.modules[name]
    folder = CACHE_DIR / "kernels"
    path = folder / f"{name}.py"
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
    # the compiled core's (pkmlab.machine_core.actuator_space_model): the simulation's own numbers
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
    q_ddot, lam, ok = lagrangian.constrained_accelerations(M, h + g, constraint_jacobian(model, q), gamma, Q)
    if not ok:
        raise SingularityError("the constrained model is singular at this configuration")
    return q_ddot, lam


# ------------------------------------------------------------------ inverse kinematics
def working_modes(model: MechanismModel) -> list[tuple[int, ...]]:
    """Every working mode: one sign per two-branch leg, +1 before -1, in lexicographic order
    (``[()]`` when no leg has two branches, as for the 3-RPR)."""
    import itertools

    leg_modes = _leg_solver(model.description).working_modes
    return list(itertools.product(*[leg_modes(leg) for leg in model.description.legs if leg_modes(leg)]))


def _leg_solver(description) -> ModuleType:
    """The module of closed-form leg inverse kinematics for the description's kind (planar or spatial)."""
    if getattr(description, "spatial", False):
        from .mechanisms import spatial_legs

        return spatial_legs
    from .mechanisms import leg_types

    return leg_types


def _attachment_points(description, leg: int, poses: np.ndarray) -> np.ndarray:
    if getattr(description, "spatial", False):
        from .mechanisms.spatial import attachment_points

        return attachment_points(description, leg, poses)
    from .mechanisms.description import attachment_points

    return attachment_points(description, leg, poses)


def inverse_kinematics(model: MechanismModel, pose, mode) -> np.ndarray:
    """The configuration ``q`` (actuators, passive joints, pose) of ``pose`` in working ``mode`` (one sign
    per two-branch leg, :func:`working_modes`), in closed form per leg type
    (:mod:`pkmlab.mechanisms.leg_types`). Raises naming the leg that cannot reach."""
    from .errors import UnreachablePoseError

    m = model.description
    pose = np.asarray(pose, dtype=float)
    if pose.shape != (m.dof,) or not np.all(np.isfinite(pose)):
        raise InvalidParameterError(f"pose must be ({', '.join(m.pose_names)}), finite, got {pose.tolist()}")
    if getattr(m, "spatial", False):
        from .mechanisms.spatial import check_pose

        check_pose(m, pose)
    q, _unreachable, failure = inverse_kinematics_batch(model, pose[None, :], mode)
    if failure is not None:
        _k, leg, message = failure
        raise UnreachablePoseError(message, legs=(leg + 1,))
    return q[0]


def inverse_kinematics_batch(model: MechanismModel, poses: np.ndarray, mode):
    """``q`` (K, n_coordinates) of poses (K, dof) in one working mode, NaN rows where a leg cannot reach;
    the legs that cannot, a bit mask per pose (K,) (bit ``i`` for leg ``i + 1``); and the first failure
    ``(k, leg, message)`` (else None)."""
    m = model.description
    solver = _leg_solver(m)
    leg_inverse_kinematics_batch, leg_modes = solver.leg_inverse_kinematics_batch, solver.working_modes
    extra = (solver.central_axis(m),) if getattr(m, "spatial", False) else ()
    signs = iter(tuple(mode))
    actuators, passive, unreachable = [], [], np.zeros(len(poses), dtype=np.int64)
    first = None
    for i, leg in enumerate(m.legs):
        sigma = next(signs, None) if leg_modes(leg) else 1
        if sigma not in (1, -1):
            raise InvalidParameterError(f"mode must be one sign (+1 or -1) per two-branch leg, got {tuple(mode)}")
        solved = leg_inverse_kinematics_batch(leg, i, _attachment_points(m, i, poses), sigma, *extra)
        if solved.bad.any():
            k = int(np.argmax(solved.bad))
            if first is None or k < first[0]:
                first = (k, i, solved.why(k))
            unreachable |= solved.bad.astype(np.int64) << i
        # the actuator's column among the leg's joint coordinates (a spatial U joint before it has two)
        column = sum(getattr(j, "coordinates", 1) for j in leg.joints[:leg.actuated])
        actuators.append(solved.coordinates[:, column])
        passive += [solved.coordinates[:, k] for k in range(solved.coordinates.shape[1]) if k != column]
    if next(signs, None) is not None:
        raise InvalidParameterError(f"mode has more signs than two-branch legs, got {tuple(mode)}")
    q = np.column_stack([*actuators, *passive, poses])
    q[unreachable != 0] = np.nan
    return q, unreachable, first


# ------------------------------------------------------------------ singularity measure
def singularity_measure(model: MechanismModel, q) -> float:
    """The gain-type singularity measure ``S`` at ``q``: zero where the passive motion is undetermined
    (:func:`pkmlab.machine_core.singularity_measure`: for three legs on a rigid platform, the
    determinant of the legs' lines of action, the paper's eq. (19) for its machine; for the five-bar,
    ``sin(φ1 - φ2)``)."""
    q = _q(model, q)
    return float(model.kernels.singularity_measure(q, trig_table(model, q), model.P,
                                                    np.empty((model.n_actuators, model.kernels.LINE_WIDTH))))


# ------------------------------------------------------------------ forward kinematics
def _newton_passive(model: MechanismModel, q: np.ndarray, tol: float, iterations: int = 30) -> bool:
    """Newton's method on ``η = 0`` for the passive coordinates of ``q`` (in place); True once
    ``max |η| < tol``, False when ``iterations`` steps were not enough."""
    na = model.n_actuators
    for _ in range(iterations):
        eta = constraint_residual(model, q)
        if np.max(np.abs(eta)) < tol:
            return True
        q[na:] -= np.linalg.lstsq(constraint_jacobian(model, q)[:, na:], eta, rcond=None)[0]
    return False


def branch_following(model: MechanismModel, q_previous, theta, *, min_abs_S: float = 1e-3,
                     max_step: float = 0.05) -> np.ndarray:
    """The configuration at ``actuators`` continuously connected to ``q_previous`` (paper §3.2): the compiled
    core's :func:`~pkmlab.machine_core.follow_branch_in_steps`, the simulation's own branch following, in
    sub-steps of at most ``max_step`` in the actuators (halved where one fails; an actuator angle moves the
    shorter way round, by at most π). Raises
    :class:`~pkmlab.errors.BranchFollowingError` where the way nears a gain-type singularity
    (``|S| < min_abs_S``) or the passive coordinates cannot be found (out of reach).
    """
    from .errors import BranchFollowingError

    q = _q(model, q_previous)
    target = np.asarray(theta, dtype=float)
    na = model.n_actuators
    if target.shape != (na,) or not np.all(np.isfinite(target)):
        raise InvalidParameterError(f"theta must be {na} finite values, got {np.asarray(theta).tolist()}")
    for name, value, low in (("max_step", max_step, 0.0), ("min_abs_S", min_abs_S, -1.0)):
        if not (isinstance(value, (int, float)) and not isinstance(value, bool) and math.isfinite(value)
                and value > low):
            raise InvalidParameterError(f"{name} must be a finite number {'above 0' if low == 0 else 'of 0 or more'}, "
                                        f"got {value!r}")
    k = model.kernels
    out, status = np.empty((1, q.size)), np.zeros(1, dtype=np.int64)
    k.branch_following_batch(q[None, :], target[None, :], model.P, float(min_abs_S), float(max_step), out, status)
    if status[0] != k.OK:
        why = ("a gain-type singularity on the way" if status[0] == k.SINGULAR else
               "the passive coordinates cannot be found on the way: out of reach, or at a gain-type singularity")
        s_reached = abs(singularity_measure(model, out[0]))
        reached = f"|S| = {s_reached:.3g} at actuators {np.round(out[0, :na], 6).tolist()}"
        raise BranchFollowingError(f"cannot follow the assembly mode to actuators {np.round(target, 6).tolist()}: "
                                   f"{why} ({reached}, the last configuration reached; limit |S| >= {min_abs_S:g})")
    return out[0]


def forward_kinematics_five_bar(model: MechanismModel, theta) -> list[np.ndarray]:
    """Both assembly modes of a point platform on two legs (the five-bar's two R*RR legs, or any leg
    types of :mod:`~pkmlab.mechanisms.leg_types`): the end point is where the two legs' circles
    (:func:`~pkmlab.mechanisms.leg_types.leg_circle`, about the elbows ``E_i`` for the five-bar)
    meet — none, one or two configurations."""
    from .mechanisms.leg_types import leg_circle, leg_coordinates

    m = model.description
    if m.platform.kind != "point" or len(m.legs) != 2:
        raise InvalidParameterError(f"{m.notation} is not a point platform on two legs")
    theta = np.asarray(theta, dtype=float)
    circles = [leg_circle(leg, t) for leg, t in zip(m.legs, theta, strict=True)]
    elbows = [np.array(c) for c, _r in circles]
    radii = [r for _c, r in circles]
    d = elbows[1] - elbows[0]
    dist = float(np.hypot(*d))
    if dist == 0 and radii[0] == radii[1]:
        raise SingularityError(f"actuators {theta.tolist()}: both elbows coincide and the links are equal: "
                               "a continuum of assembly modes")
    if dist == 0 or dist > radii[0] + radii[1] or dist < abs(radii[0] - radii[1]):
        return []
    along = (radii[0] ** 2 - radii[1] ** 2 + dist**2) / (2 * dist)
    across = math.sqrt(max(radii[0] ** 2 - along**2, 0.0))
    ex, n = d / dist, np.array([-d[1], d[0]]) / dist
    out = []
    for sign in ((1.0, -1.0) if across > 0 else (1.0,)):
        point = elbows[0] + along * ex + sign * across * n
        passive = [leg_coordinates(leg, t, point)[1] for leg, t in zip(m.legs, theta, strict=True)]
        out.append(np.array([*theta, *passive, *point]))
    return out


def forward_kinematics(model: MechanismModel, theta) -> list[tuple[np.ndarray, float]]:
    """Every assembly mode ``[(q, S), ...]`` (sorted by the platform's angle) at ``actuators``.

    A rigid platform on three legs each holding its attachment point on a circle
    (:func:`~pkmlab.mechanisms.leg_types.leg_circle`: the leg types with a closed form): the roots of
    one degree-6 polynomial (:func:`~pkmlab.mechanisms.rrr3.three_circles`, the paper's eq. 12 in
    Gosselin's general form), each polished by Newton's method on ``η = 0``; a five-bar: two circles.
    Any other machine: the general method of :func:`forward_kinematics_general`, which warns
    (:class:`~pkmlab.errors.IncompleteSolutionWarning`) where it cannot guarantee that it found every
    assembly mode.
    """
    from .mechanisms.leg_types import SOLVERS

    theta = _actuator_values(model, theta)
    if getattr(model.description, "spatial", False):
        return _spatial_forward_kinematics(model, theta)
    if any(leg.notation not in SOLVERS for leg in model.description.legs):
        solutions, doubt = forward_kinematics_general(model, theta)
        if doubt:
            import warnings

            from .errors import IncompleteSolutionWarning

            warnings.warn(f"forward kinematics at actuators {np.round(np.asarray(theta, float), 6).tolist()}: "
                          f"{doubt}: an assembly mode there may be missing", IncompleteSolutionWarning, stacklevel=2)
        return solutions
    from .mechanisms import rrr3
    from .mechanisms.description import attachment_point
    from .mechanisms.leg_types import leg_circle, leg_coordinates

    m = model.description
    if m.platform.kind == "point":
        return [(q, singularity_measure(model, q)) for q in forward_kinematics_five_bar(model, theta)]
    circles = [leg_circle(leg, t) for leg, t in zip(m.legs, theta, strict=True)]
    centres = np.array([c for c, _r in circles])
    radii = np.array([r for _c, r in circles])
    a = np.array(m.platform.attachments)
    vertices = np.array([*(a[1] - a[0]), *(a[2] - a[0])])
    alphas, p1 = np.empty(6), np.empty((6, 2))
    count, status = rrr3.three_circles(centres, radii, vertices, alphas, p1)
    if status != rrr3.OK:
        raise SingularityError(f"actuators {theta.tolist()}: the forward-kinematics polynomial vanishes "
                               "identically (a continuum of assembly modes)")
    configurations = []
    for j in range(count):
        alpha = alphas[j]
        c, s = math.cos(alpha), math.sin(alpha)
        x, y = p1[j] - (c * a[0, 0] - s * a[0, 1], s * a[0, 0] + c * a[0, 1])
        pose = np.array([x, y, alpha])
        passive = []
        for i, leg in enumerate(m.legs):
            coords = leg_coordinates(leg, theta[i], attachment_point(m, i, pose))
            passive += [v for k, v in enumerate(coords) if k != leg.actuated]
        configurations.append(np.array([*theta, *passive, *pose]))
    return _assembly_modes(model, configurations)


def _spatial_forward_kinematics(model: MechanismModel, theta: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """Every assembly mode of a spatial machine: for a translating platform on three R*US legs (the Delta)
    the two points where three spheres meet (:func:`~pkmlab.mechanisms.spatial_legs.delta_forward_kinematics`),
    the forearms' universal-joint angles from them, each polished by Newton's method on ``η = 0``."""
    from .mechanisms.spatial_legs import delta_forward_kinematics, forearm_angles

    m = model.description
    if m.platform.kind == "rigid" and all(leg.notation == "UP*S" for leg in m.legs):
        return _stewart_forward_kinematics(model, theta)
    if m.platform.kind != "translating" or any(leg.notation != "R*US" for leg in m.legs):
        raise InvalidParameterError(f"{m.name} ({m.notation}, {m.platform.kind} platform): pkmlab's forward "
                                    "kinematics of every assembly mode is for a translating platform on three R*US "
                                    "legs (the Delta) and a platform on six UP*S legs (the Stewart-Gough platform); "
                                    "follow a branch from a known configuration instead (branch_following)")
    configurations = []
    for point in delta_forward_kinematics(m, theta):
        passive = []
        for i, leg in enumerate(m.legs):
            target = point + np.array(m.platform.attachments[i])
            q1, q2, _ = forearm_angles(leg, theta[i:i + 1], target[None, :])
            passive += [q1[0], q2[0]]
        configurations.append(np.array([*theta, *passive, *point]))
    return _assembly_modes(model, configurations)


def _stewart_forward_kinematics(model: MechanismModel, theta: np.ndarray) -> list[tuple[np.ndarray, float]]:
    """Every real assembly mode of a platform on six UP*S legs (the general Stewart–Gough platform, up to 40):
    each leg's slide gives the distance from its universal joint's centre to its spherical joint, and
    :func:`~pkmlab.mechanisms.stewart_fk.assembly_modes` (polynomial homotopy continuation) returns every
    real pose at those six distances; each becomes a configuration by the legs' inverse kinematics (the
    universal joints' angles), polished by Newton's method on ``η = 0``. Sorted by the pose's last
    coordinate (yaw)."""
    from .mechanisms.spatial import orientations
    from .mechanisms.stewart_fk import assembly_modes

    m = model.description
    lengths = []
    for leg, s in zip(m.legs, theta, strict=True):
        offset = np.array(leg.bodies[0].tip) + np.array(leg.bodies[1].tip)
        lengths.append(float(np.linalg.norm(offset + s * np.array(leg.joints[1].axes[0]))))
    configurations = []
    poses = assembly_modes(np.array([leg.base for leg in m.legs]), np.array(m.platform.attachments),
                           np.array(lengths))
    for rot, p in poses:
        # roll, pitch, yaw of R = Rz(yaw) Ry(pitch) Rx(roll)
        pitch = -math.asin(max(-1.0, min(1.0, rot[2, 0])))
        roll, yaw = math.atan2(rot[2, 1], rot[2, 2]), math.atan2(rot[1, 0], rot[0, 0])
        pose = np.array([*p, roll, pitch, yaw])
        if not np.allclose(orientations(pose[None, 3:])[0], rot, atol=1e-9):
            continue  # at gimbal lock: no roll, pitch, yaw (said below, with the poses lost)
        q, _unreachable, failure = inverse_kinematics_batch(model, pose[None, :], ())
        if failure is None:
            q = q[0]
            q[:len(m.legs)] = theta
            configurations.append(q)
    found = _assembly_modes(model, configurations)
    if len(found) < len(poses):
        import warnings

        from .errors import IncompleteSolutionWarning

        warnings.warn(f"forward kinematics at actuators {np.round(theta, 6).tolist()}: {len(poses) - len(found)} of "
                      f"the {len(poses)} poses could not be given coordinates (a universal joint at its own "
                      "singularity, a leg along its first axis; or pitch = ±pi/2, gimbal lock)",
                      IncompleteSolutionWarning, stacklevel=3)
    return found


def _actuator_values(model: MechanismModel, theta) -> np.ndarray:
    """The actuator values of a forward-kinematics request: one finite value per leg, within its stroke."""
    m = model.description
    theta = np.asarray(theta, dtype=float)
    if theta.shape != (model.n_actuators,) or not np.all(np.isfinite(theta)):
        raise InvalidParameterError(f"theta must be {model.n_actuators} finite values, got "
                                    f"{np.asarray(theta).tolist()}")
    for i, (leg, t) in enumerate(zip(m.legs, theta, strict=True)):
        if leg.stroke is not None and leg.joints[leg.actuated].kind == "P" and not leg.stroke[0] <= t <= leg.stroke[1]:
            raise InvalidParameterError(f"leg {i + 1}: actuator value {t:g} m is outside its stroke "
                                        f"[{leg.stroke[0]:g}, {leg.stroke[1]:g}] m")
    return theta


def _assembly_modes(model: MechanismModel, configurations) -> list[tuple[np.ndarray, float]]:
    """The distinct assembly modes ``[(q, S), ...]`` among approximate ``configurations``: each polished by
    Newton's method on ``η = 0`` (dropped if that fails), its passive angles wrapped to (-π, π], sorted by
    the pose's last coordinate."""
    na, solutions = model.n_actuators, []
    angular = np.array(model.kernels.ANGLES)
    angular[:na] = False  # the actuators stay as given
    for q in configurations:
        q = q.copy()
        _newton_passive(model, q, 1e-15)  # polish
        if np.max(np.abs(constraint_residual(model, q))) > 1e-12:
            continue
        q[angular] = np.angle(np.exp(1j * q[angular]))
        # a double root (at a singularity) is found only to about sqrt(eps): closer than 1e-6 is one mode
        if all(np.max(np.abs(np.angle(np.exp(1j * (q - other))))) > 1e-6 for other, _s in solutions):
            solutions.append((q, singularity_measure(model, q)))
    return sorted(solutions, key=lambda sol: sol[0][-1])


#: The general forward kinematics samples the platform's orientation at this many points in a turn.
FK_SAMPLES = 2881


def _intersections(first, second, touching: float = 0.0):
    """Points (..., 2 branches, 2) common to two loci given as ``(kind, A (..., 2), B (..., 2))`` (a circle of
    centre ``A`` and radius ``|B|``, or the line through ``A`` along ``B``); NaN where there is none. The
    branches keep their identity as the loci move (the sign of the square root). Loci that miss each other
    by less than ``touching`` (m) are taken as tangent: one point, on both branches."""
    kind1, a1, b1 = first
    kind2, a2, b2 = second
    if kind1 == "line" and kind2 == "circle":
        return _intersections(second, first, touching)

    def root(square, scale):  # √square, with a round-off's worth below zero read as zero
        return np.sqrt(np.where((square < 0) & (square > -touching * scale), 0.0, square))
    with np.errstate(invalid="ignore", divide="ignore"):
        if kind1 == "circle" and kind2 == "circle":
            r1, r2 = np.hypot(*np.moveaxis(b1, -1, 0)), np.hypot(*np.moveaxis(b2, -1, 0))
            d = a2 - a1
            dist = np.hypot(d[..., 0], d[..., 1])
            along = (r1 * r1 - r2 * r2 + dist * dist) / (2 * dist)
            across = root(r1 * r1 - along * along, 2 * np.maximum(r1, 1e-300))
            e = d / dist[..., None]
            n = np.stack([-e[..., 1], e[..., 0]], axis=-1)
            base = a1 + along[..., None] * e
            return np.stack([base + across[..., None] * n, base - across[..., None] * n], axis=-2)
        if kind1 == "circle":  # the line a2 + t b2 on the circle (a1, |b1|)
            w = a2 - a1
            uu = (b2 * b2).sum(axis=-1)
            half = (b2 * w).sum(axis=-1)
            disc = root(half * half - uu * ((w * w).sum(axis=-1) - (b1 * b1).sum(axis=-1)),
                        2 * uu * np.hypot(*np.moveaxis(b1, -1, 0)))
            return np.stack([a2 + ((-half + disc) / uu)[..., None] * b2, a2 + ((-half - disc) / uu)[..., None] * b2],
                            axis=-2)
        cross = b1[..., 0] * b2[..., 1] - b1[..., 1] * b2[..., 0]  # two lines: one point, or none if parallel
        w = a2 - a1
        t = (w[..., 0] * b2[..., 1] - w[..., 1] * b2[..., 0]) / cross
        point = np.where(np.abs(cross)[..., None] > 0, a1 + t[..., None] * b1, np.nan)
        return np.stack([point, np.full_like(point, np.nan)], axis=-2)


def forward_kinematics_general(model: MechanismModel, theta) -> tuple[list[tuple[np.ndarray, float]], str]:
    """Every assembly mode of any machine whose legs hold their ends on circles or lines
    (:class:`~pkmlab.mechanisms.leg_types.Locus`), and a doubt: ``""`` when the method guarantees that it
    found all of them, else where it cannot.

    A point platform on two legs: the intersections of their two loci (complete). A rigid platform on three
    legs: for each orientation ``α`` of a fine grid over a turn, the attachment point ``p1`` is where leg 1's
    locus meets leg 2's moved by ``-R(α)(a2 - a1)`` (at most two branches), and ``f(α)``, how far
    ``p1 + R(α)(a3 - a1)`` is off leg 3's locus, vanishes at the assembly modes: every sign change of ``f``
    along a branch is refined by bisection in ``α``; every dip of ``|f|`` between samples of one sign is
    searched for its bottom, which holds two roots closer than the grid's step or a double root (a
    singularity: one assembly mode); a root between a branch's last sample and its end (two loci tangent)
    is bisected there. Each is polished by Newton's method on ``η = 0``. What remains unsure is said: ``f``
    nearly zero exactly where a branch ends.
    """
    from .mechanisms.description import attachment_points
    from .mechanisms.leg_types import Locus

    m = model.description
    theta = _actuator_values(model, theta)
    loci = [Locus(leg, i) for i, leg in enumerate(m.legs)]
    shapes = [(locus.kind, *locus.at(t)) for locus, t in zip(loci, theta, strict=True)]
    doubt, candidates = "", []
    if m.platform.kind == "point":
        reach = max(float(np.hypot(*shape[2])) if shape[0] == "circle" else 1.0 for shape in shapes)
        for point in _intersections(*shapes, touching=1e-12 * reach):
            if np.all(np.isfinite(point)):
                candidates.append(np.array([*point, 0.0]))
    else:
        a = np.array(m.platform.attachments)
        kind3, c3, b3 = shapes[2]
        scale = np.hypot(*b3) if kind3 == "circle" else 1.0

        def branches(alpha):
            c, s = np.cos(alpha)[..., None], np.sin(alpha)[..., None]

            def turn(v):
                return np.concatenate([c * v[0] - s * v[1], s * v[0] + c * v[1]], axis=-1)

            kind2, a2, b2 = shapes[1]
            moved = a2 - turn(a[1] - a[0])
            p1 = _intersections(shapes[0], (kind2, moved, np.broadcast_to(b2, moved.shape)))
            q3 = p1 + turn(a[2] - a[0])[..., None, :]
            d = q3 - c3
            off = ((d * d).sum(axis=-1) - (b3 * b3).sum()) / (2 * scale) if kind3 == "circle" else \
                (b3[0] * d[..., 1] - b3[1] * d[..., 0]) / np.hypot(*b3)
            return p1, off  # (..., 2, 2), (..., 2)

        grid = np.linspace(-np.pi, np.pi, FK_SAMPLES)
        _p1, f = branches(grid)  # (G, 2)
        size = float(np.ptp(a, axis=0).max()) or 1.0

        def value(alpha, b):
            return branches(np.array(alpha))[1][b]

        def root(b, start, end):
            """Bisection on branch ``b`` between orientations where ``f`` has opposite signs (``end`` may be
            where the branch ends): the pose there."""
            f_start = value(start, b)
            for _ in range(60):
                mid = 0.5 * (start + end)
                f_mid = value(mid, b)
                if np.isfinite(f_mid) and np.sign(f_mid) == np.sign(f_start):
                    start, f_start = mid, f_mid
                else:
                    end = mid
            alpha = 0.5 * (start + end) if np.isfinite(value(0.5 * (start + end), b)) else start
            p1 = branches(np.array(alpha))[0][b]
            c, s = math.cos(alpha), math.sin(alpha)
            return np.array([p1[0] - (c * a[0, 0] - s * a[0, 1]), p1[1] - (s * a[0, 0] + c * a[0, 1]), alpha])

        for b in range(2):
            fb = f[:, b]
            finite = np.isfinite(fb)
            both = finite[:-1] & finite[1:]
            for k in np.flatnonzero(both & (np.sign(fb[:-1]) * np.sign(fb[1:]) <= 0) & (fb[:-1] != fb[1:])):
                candidates.append(root(b, grid[k], grid[k + 1]))
            # where the branch ends (two legs' loci become tangent), between the last sample and the end
            for k in np.flatnonzero(finite[:-1] != finite[1:]):
                inside, outside = (k, k + 1) if finite[k] else (k + 1, k)
                last, gone = grid[inside], grid[outside]
                for _ in range(60):  # the end of the branch
                    mid = 0.5 * (last + gone)
                    last, gone = (mid, gone) if np.isfinite(value(mid, b)) else (last, mid)
                f_end = value(last, b)
                if np.sign(f_end) != np.sign(fb[inside]):
                    candidates.append(root(b, grid[inside], last))
                elif abs(f_end) < 1e-7 * size and not doubt:
                    doubt = f"|f| nearly vanishes at alpha = {last:.6g} rad, where two legs' loci become tangent"
            # what the grid cannot see: f dipping towards zero between samples of one sign, where two roots
            # may lie closer than the grid's step, or one double root (at a singularity)
            inner = both[:-1] & both[1:]
            dips = np.flatnonzero(inner & (np.abs(fb[1:-1]) <= np.abs(fb[:-2])) & (np.abs(fb[1:-1]) <= np.abs(fb[2:]))
                                  & (np.sign(fb[:-2]) == np.sign(fb[1:-1])) & (np.sign(fb[1:-1]) == np.sign(fb[2:])))
            for k in dips + 1:
                sign = np.sign(fb[k])
                lo, hi = grid[k - 1], grid[k + 1]
                for _ in range(80):  # golden section for the dip's bottom
                    x1, x2 = hi - 0.618034 * (hi - lo), lo + 0.618034 * (hi - lo)
                    if sign * value(x1, b) < sign * value(x2, b):
                        hi = x2
                    else:
                        lo = x1
                bottom = 0.5 * (lo + hi)
                depth = sign * value(bottom, b)
                if depth < 0:  # two roots in one step of the grid
                    candidates += [root(b, grid[k - 1], bottom), root(b, bottom, grid[k + 1])]
                elif depth < 1e-10 * size:  # a double root: one assembly mode, at a singularity
                    candidates.append(root(b, bottom, bottom))
    configurations = []
    for pose in candidates:
        pose = pose[:m.dof]
        passive = []
        for i, (leg, locus) in enumerate(zip(m.legs, loci, strict=True)):
            points = attachment_points(m, i, pose[None, :])
            coords = [0.0, 0.0]
            coords[leg.actuated], coords[locus.passive] = theta[i], float(locus.passive_coordinate(theta[i],
                                                                                                   points)[0])
            passive += [v for k, v in enumerate(coords) if k != leg.actuated]
        configurations.append(np.array([*theta, *passive, *pose]))
    return _assembly_modes(model, configurations), doubt


# ------------------------------------------------------------------ along a path
def path_inverse_kinematics(model: MechanismModel, poses, mode) -> tuple[np.ndarray, np.ndarray, tuple | None]:
    """Inverse kinematics of many poses ``(K, dof)`` in one working ``mode``, at once.

    Returns ``(q (K, n_coordinates), S (K,), failure)``: rows that cannot be reached are NaN, and
    ``failure`` is ``(k, error)`` for the first of them (the error names the leg), else None.
    """
    from .errors import UnreachablePoseError

    poses = np.asarray(poses, dtype=float).reshape(-1, model.description.dof)
    q, _unreachable, first = inverse_kinematics_batch(model, poses, mode)
    s = np.empty(poses.shape[0])
    model.kernels.singularity_measures(q, model.P, s)
    failure = None if first is None else (first[0], UnreachablePoseError(first[2], legs=(first[1] + 1,)))
    return q, s, failure


def path_rates(model: MechanismModel, q, pose_dot, pose_ddot) -> tuple[np.ndarray, np.ndarray, int]:
    """Actuator rates and accelerations along configurations ``q`` (K, n_coordinates) whose pose moves
    with ``pose_dot``, ``pose_ddot`` (K, dof): differentiating ``η(q) = 0`` once and twice,

        ``A u̇ = -B ẋ``,   ``A ü = -B ẍ - J̇ηq q̇``

    with ``u`` the actuators and passive joints, ``A = ∂η/∂u``, ``B = ∂η/∂pose`` (paper eqs. 14–17, 32).
    Returns ``(θ̇, θ̈, k)``: ``k`` the first sample where ``A`` is singular (the pose at the edge of the
    workspace: an inverse-kinematic singularity), else -1.
    """
    k_ = model.kernels
    count, n, N, dof = q.shape[0], model.n_actuators, k_.N_COORDINATES, model.description.dof
    j_eta, gamma = np.empty((count, k_.N_CONSTRAINTS, N)), np.empty((count, k_.N_CONSTRAINTS))
    k_.constraint_jacobians(np.ascontiguousarray(q), model.P, j_eta)
    a, b = j_eta[:, :, :N - dof], j_eta[:, :, N - dof:]
    singular = ~(np.linalg.cond(a) < 1e12)
    if singular.any():
        k = int(np.argmax(singular))
        return np.empty((count, n)), np.empty((count, n)), k
    u_dot = np.linalg.solve(a, -np.einsum("kij,kj->ki", b, pose_dot)[..., None])[..., 0]
    q_dot = np.concatenate([u_dot, pose_dot], axis=1)
    k_.constraint_biases(np.ascontiguousarray(q), q_dot, model.P, gamma)
    u_ddot = np.linalg.solve(a, (-np.einsum("kij,kj->ki", b, pose_ddot) - gamma)[..., None])[..., 0]
    return u_dot[:, :n].copy(), u_ddot[:, :n].copy(), -1
