"""Kinematics of any described mechanism: inverse kinematics in every working mode, forward kinematics
with every assembly mode, branch following, the constraint and velocity Jacobians, coordinate rates and
accelerations, and the singularity measure (the paper's §2 and §3.2, for every machine).

Every function takes a :class:`~pkmlab.model.mechanism_model.MechanismModel` first (:func:`pkmlab.load`) and
arrays shaped ``(..., n)``: one configuration or a batch of any leading shape, with the same code path.
``q`` is the model's coordinate vector ``(θ, passive joints, pose)`` (``model.coordinates`` names its
entries; for the paper's 3-RRR ``(θ1, θ2, θ3, φ1, φ2, φ3, x, y, α)``), ``theta`` the actuator values
(angles in rad or lengths in m), ``pose`` the platform's pose (``model.pose_names``).

Examples
--------
>>> import numpy as np
>>> import pkmlab
>>> model = pkmlab.load("paper")
>>> ik = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1))
>>> np.round(ik.theta, 4).tolist()
[1.6146, 1.9831, -1.1846]
>>> fk = pkmlab.forward_kinematics(model, ik.theta)
>>> int(fk.count), np.allclose(fk.nearest([0.2, 0.21, 0.0]).pose, [0.2, 0.21, 0.0], atol=1e-12)
(2, True)
"""

from __future__ import annotations

import functools
import warnings
from dataclasses import dataclass

import numpy as np

from .._validate import as_batch, as_broadcast, as_choice, as_mode, as_real, index_text
from ..errors import BranchFollowingError, IncompleteSolutionWarning, InvalidParameterError, SingularityError, shown
from ..model import mechanism_model as mm
from ..model.mechanism_model import MechanismModel
from ..numerics.angles import wrapped_where
from ..numerics.batched import first_singular
from .assembly import assembly_modes, method_statement

__all__ = [
    "SINGULAR_S",
    "InverseKinematicsSolution",
    "AssemblyMode",
    "ForwardKinematicsSolution",
    "working_modes",
    "inverse_kinematics",
    "forward_kinematics",
    "branch_following",
    "follow_path",
    "constraint_residual",
    "constraint_jacobian",
    "coordinate_jacobian",
    "velocity_jacobian",
    "coordinate_rates",
    "acceleration_bias",
    "coordinate_accelerations",
    "singularity_measure",
    "pose_coordinate_jacobian",
    "actuation_jacobian",
    "actuation_singularity_measure",
]

#: ``|S|`` below which a configuration counts as a gain-type singularity: the actuator-space model does not exist
#: there (branch following's default guard; the dynamics refuse such configurations).
SINGULAR_S = 1e-6

#: A configuration is on the loop-closure manifold when ``max |η(q)|`` is below this fraction of the
#: machine's size (:func:`length_scale`): the functions that need ``η(q) = 0`` refuse it otherwise.
CLOSURE_TOLERANCE = 1e-8


def as_model(model, name: str = "model") -> MechanismModel:
    """``model`` itself if it is a model (:func:`pkmlab.load`): anything else would fail deep inside, unnamed."""
    if not isinstance(model, MechanismModel):
        raise InvalidParameterError(f"{name} must be a pkmlab model (pkmlab.load('paper'), a preset name, or a "
                                    f"description file), got {type(model).__name__} {shown(model, 50)}")
    return model


def refuse_actuation_redundancy(model: MechanismModel, what: str) -> None:
    """Refuse a redundantly actuated machine in a function that takes its actuators as independent coordinates
    (branch following, the actuator-space model…): it names the functions of its pose instead."""
    extra = model.description.actuation_redundancy
    if extra > 0:
        raise InvalidParameterError(
            f"{model.name}: {what} takes the actuators as the machine's coordinates, and its {model.n_actuators} "
            f"actuators are {extra} more than its {model.dof} degrees of freedom (redundant actuation): use its pose "
            "(pose_coordinate_jacobian, actuation_jacobian, actuation_singularity_measure, pose_space_model, "
            "distribute_efforts)")


def length_scale(model: MechanismModel) -> float:
    """The machine's size (m): its largest base, attachment or link dimension (what tolerances on lengths
    are scaled by)."""
    m = model.description
    sizes = [np.linalg.norm(leg.base) for leg in m.legs] + [np.linalg.norm(a) for a in m.platform.attachments]
    sizes += [np.linalg.norm(b.tip) for leg in m.legs for b in leg.bodies]
    sizes += [max(abs(v) for v in leg.stroke) for leg in m.legs if leg.stroke is not None]
    return float(max(max(sizes), 1e-3))


def _configurations(model: MechanismModel, q, name: str = "q"):
    """``q`` as a C-contiguous ``(K, n)`` batch and its leading shape."""
    return as_batch(name, q, len(model.coordinates))


def check_loop_closure(model: MechanismModel, qs: np.ndarray, shape, name: str = "q") -> None:
    """Refuse configurations off the loop-closure manifold, naming the first and its residual."""
    refuse_off_closure(constraint_residuals(model, qs), CLOSURE_TOLERANCE * length_scale(model), shape, name)


def refuse_off_closure(residual: np.ndarray, tolerance: float, shape, name: str = "q") -> None:
    """Refuse the first configuration whose loop-closure residual ``residual`` (K, m) exceeds ``tolerance`` (m) in
    its largest entry (NaN included), naming it, its index in ``shape`` and the residual."""
    worst = np.abs(residual).max(axis=-1)
    bad = np.flatnonzero(~(worst <= tolerance))
    if bad.size:
        k = int(bad[0])
        raise InvalidParameterError(
            f"{name}{index_text(k, shape)} is off the loop closure: max |eta(q)| = {worst[k]:.3g} m exceeds "
            f"{tolerance:.3g} m (a configuration from inverse or forward kinematics or branch following is on it)")


def constraint_residuals(model: MechanismModel, qs: np.ndarray) -> np.ndarray:
    k = model.kernels
    out = np.empty((len(qs), k.N_CONSTRAINTS))
    for i, qi in enumerate(qs):
        k.constraints(qi, mm.trig_table(model, qi), model.P, out[i])
    return out


# ------------------------------------------------------------------ inverse kinematics
@dataclass(frozen=True)
class InverseKinematicsSolution:
    """Result of :func:`inverse_kinematics`: the configurations at given poses, in one working mode or in all.

    Attributes
    ----------
    q : ndarray, shape (..., n) for one working mode, (..., n_modes, n) for all of them
        Configurations (rad or m per entry, ``model.coordinates``), in the order of ``modes``; NaN where a leg
        cannot reach (``on_unreachable="nan"``).
    modes : ndarray of int, shape (k,) or (n_modes, k)
        The working modes: one sign per two-branch leg (``k`` may be 0: one mode, no signs).
    unreachable_legs : ndarray of int, shape (...) or (..., n_modes)
        Bit ``i`` set where leg ``i + 1`` cannot reach.
    S : ndarray, shape (...) or (..., n_modes)
        The singularity measure of each solution (dimensionless; NaN where unreachable); for a redundantly
        actuated machine its actuation's, :func:`actuation_singularity_measure`.
    n_actuators : int
        How many of ``q``'s leading entries are the actuators.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> ik = pkmlab.inverse_kinematics(pkmlab.load("paper"), [0.20, 0.21, 0.0])
    >>> ik.q.shape, ik.modes.shape
    ((8, 9), (8, 3))
    >>> bool(ik.reachable.all())
    True
    """

    q: np.ndarray
    modes: np.ndarray
    unreachable_legs: np.ndarray
    S: np.ndarray
    n_actuators: int

    @property
    def theta(self) -> np.ndarray:
        """The actuator values ``θ``, ``q[..., :n_actuators]`` (rad or m), shape (..., n_actuators)."""
        return self.q[..., :self.n_actuators]

    @property
    def reachable(self) -> np.ndarray:
        """Where every leg reaches (``unreachable_legs == 0``), boolean, shape as ``unreachable_legs``."""
        return self.unreachable_legs == 0


def as_working_mode(model: MechanismModel, mode, name: str = "working_mode"):
    """A working-mode argument checked: ``"auto"``, or one sign per two-branch leg as a tuple of ints
    (``"+-"``, ``(1, -1)``, ``()`` for a machine with one working mode); ``name`` names it in errors."""
    if isinstance(mode, str) and mode == "auto":
        return mode
    modes = mm.working_modes(model)
    try:
        signs = tuple(int(v) for v in as_mode(mode, name, len(modes[0])))
    except InvalidParameterError:
        signs = None
    if signs not in modes:
        spelt = ", ".join("".join("+" if v > 0 else "-" for v in m) or "[]" for m in modes)
        raise InvalidParameterError(f'{name} must be "auto" or one of the modes of {model.description.name} '
                                    f"({spelt}), got {shown(mode)}")
    return signs


def working_modes(model: MechanismModel) -> np.ndarray:
    """Every working mode of ``model``: one sign per two-branch leg.

    The modes are listed +1 before -1, in lexicographic order (conventions §3 defines the signs); a machine with
    no two-branch leg, as the 3-RPR, has one empty mode, shape (1, 0).

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).

    Returns
    -------
    ndarray of int, shape (n_modes, k)
        ``k`` signs (+1 or -1) per mode.

    Raises
    ------
    InvalidParameterError
        If ``model`` is not a pkmlab model.

    Examples
    --------
    >>> import pkmlab
    >>> modes = pkmlab.working_modes(pkmlab.load("paper"))
    >>> modes.shape, modes[:2].tolist()
    ((8, 3), [[1, 1, 1], [1, 1, -1]])
    >>> pkmlab.working_modes(pkmlab.load("3rpr")).shape
    (1, 0)
    """
    modes = mm.working_modes(as_model(model))
    return np.array(modes, dtype=np.int64).reshape(len(modes), -1)


def inverse_kinematics(model: MechanismModel, pose, mode=None, *, on_unreachable: str = "raise"):
    """The configurations that put the platform at ``pose``, in every working mode or in one.

    Closed form per leg type; conventions §3 defines the modes' signs. Each solution's singularity measure is
    computed too.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    pose : array_like, shape (..., dof)
        The platform's pose (``model.pose_names``; m and rad).
    mode : sequence of signs, optional
        One working mode (``(1, -1, 1)``, ``"+-+"``); every mode (:func:`working_modes`) when omitted.
    on_unreachable : {"raise", "nan"}
        Raise :class:`~pkmlab.errors.UnreachablePoseError` naming the leg that cannot reach, or fill
        those solutions with NaN (for maps over a region).

    Returns
    -------
    InverseKinematicsSolution
        ``q`` (..., n) and ``S`` (...) for one mode; (..., n_modes, n) and (..., n_modes) for all;
        ``unreachable_legs`` a bit per leg that cannot reach.

    Raises
    ------
    UnreachablePoseError
        With ``on_unreachable="raise"``, where a leg cannot reach the pose (its ``legs`` and ``index`` say which).
    InvalidParameterError
        If ``pose`` does not have ``dof`` components, ``mode`` is not one sign per two-branch leg, or
        ``on_unreachable`` is neither choice.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> ik = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1))
    >>> np.round(ik.theta, 4).tolist(), f"{float(ik.S):.4f}"
    ([1.6146, 1.9831, -1.1846], '-0.7446')
    >>> far = pkmlab.inverse_kinematics(model, [[0.2, 0.21, 0.0], [2.0, 2.0, 0.0]], mode="+-+", on_unreachable="nan")
    >>> far.unreachable_legs.tolist()
    [0, 7]
    """
    from ..errors import UnreachablePoseError

    model = as_model(model)
    as_choice("on_unreachable", on_unreachable, ("raise", "nan"))
    m = model.description
    poses, shape = as_batch("pose", pose, m.dof)
    all_modes = working_modes(model)
    modes = all_modes if mode is None else as_mode(mode, "mode", all_modes.shape[1])[None, :]
    if getattr(m, "spatial", False):
        from ..description.spatial import check_pose

        for p in poses:
            check_pose(m, p)
    n = len(model.coordinates)
    q = np.empty((len(poses), len(modes), n))
    unreachable = np.zeros((len(poses), len(modes)), dtype=np.int64)
    for j, sigma in enumerate(modes):
        q[:, j], unreachable[:, j], first = mm.inverse_kinematics_batch(model, poses, tuple(int(s) for s in sigma))
        if first is not None and on_unreachable == "raise":
            k, leg, message = first
            raise UnreachablePoseError(f"pose {np.round(poses[k], 6).tolist()}{index_text(k, shape)}: {message}",
                                       legs=(leg + 1,),
                                       index=None if shape == () else tuple(int(i) for i in np.unravel_index(k, shape)))
    s = np.full(q.shape[:-1], np.nan)
    ok = unreachable == 0
    if ok.any():  # a redundantly actuated machine's: its actuation's (S takes the actuators as coordinates)
        s[ok] = mm.configuration_measures(model, q[ok])
    if mode is not None:
        return InverseKinematicsSolution(q[:, 0].reshape(*shape, n), modes[0], unreachable[:, 0].reshape(shape),
                                         s[:, 0].reshape(shape), model.n_actuators)
    k = len(modes)
    return InverseKinematicsSolution(q.reshape(*shape, k, n), modes, unreachable.reshape(*shape, k),
                                     s.reshape(*shape, k), model.n_actuators)


# ------------------------------------------------------------------ forward kinematics
@dataclass(frozen=True)
class AssemblyMode:
    """One solution of forward kinematics (conventions §3).

    Attributes
    ----------
    q : ndarray, shape (n,)
        The configuration (rad or m per entry).
    pose : ndarray, shape (dof,)
        The platform's pose, ``q[-dof:]`` (m, rad).
    S : float
        The singularity measure there (dimensionless).

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> fk = pkmlab.forward_kinematics(pkmlab.load("paper"), [1.6146, 1.9831, -1.1846])
    >>> mode = fk[0]
    >>> np.round(mode.pose, 2).tolist(), f"{mode.S:.3f}"
    ([0.22, 0.3, -0.58], '0.815')
    """

    q: np.ndarray
    pose: np.ndarray
    S: float


@dataclass(frozen=True)
class ForwardKinematicsSolution:
    """Every assembly mode for each ``θ`` of a batch: the result of :func:`forward_kinematics`.

    For a single ``θ`` the object is a sequence of :class:`AssemblyMode` (``len``, indexing, iteration).

    Attributes
    ----------
    q : ndarray, shape (..., m, n)
        Up to ``m`` configurations per ``θ`` (``m`` the most found in the batch), sorted by the pose's
        last coordinate; the first ``count`` are valid, the rest NaN.
    pose : ndarray, shape (..., m, dof)
        The platform's pose of each (m, rad).
    S : ndarray, shape (..., m)
        The singularity measure of each (dimensionless).
    count : ndarray of int, shape (...)
        How many assembly modes exist (0 where the machine cannot be assembled).
    method : str
        The method that found them and what it guarantees
        (:func:`~pkmlab.algorithms.assembly.method_statement`).
    angles : tuple of bool
        Which pose coordinates are angles (compared modulo 2π by :meth:`nearest`).
    residual : ndarray, shape (..., m, n_actuators), or None
        A redundantly actuated machine's (solved from a subset of its actuators): each actuator's given value minus
        its value in the configuration found (angles modulo 2π) — zero on the subset, the measured-actuator
        residual on the others: how far the given values are from a consistent set. None for other machines.
    solved : tuple of int, or None
        A redundantly actuated machine's: the actuators (0-based) solved for, in increasing order; the others are
        checked (their ``residual``). None for other machines.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> fk = pkmlab.forward_kinematics(pkmlab.load("paper"), [1.6146, 1.9831, -1.1846])
    >>> len(fk), (np.round(fk.pose, 2) + 0.0).tolist()
    (2, [[0.22, 0.3, -0.58], [0.2, 0.21, 0.0]])
    """

    q: np.ndarray
    pose: np.ndarray
    S: np.ndarray
    count: np.ndarray
    method: str = ""
    angles: tuple[bool, ...] = (False, False, True)
    residual: np.ndarray | None = None
    solved: tuple[int, ...] | None = None

    def __len__(self) -> int:
        if self.count.ndim:
            raise TypeError("len() of a batched ForwardKinematicsSolution: use .count")
        return int(self.count)

    def __getitem__(self, j: int) -> AssemblyMode:
        n = len(self)
        if not isinstance(j, int | np.integer) or not -n <= j < n:
            raise IndexError(f"assembly mode {j!r} of {n}")
        j = int(j) % n
        return AssemblyMode(self.q[j].copy(), self.pose[j].copy(), float(self.S[j]))

    def nearest(self, pose) -> AssemblyMode:
        """The assembly mode whose pose is nearest to ``pose`` (angles compared modulo 2π).

        Parameters
        ----------
        pose : array_like, shape (dof,)
            The pose to compare with (m, rad).

        Returns
        -------
        AssemblyMode

        Raises
        ------
        IndexError
            If there is no assembly mode.
        TypeError
            If the solution is a batch (use one ``θ``).

        Examples
        --------
        >>> import numpy as np
        >>> import pkmlab
        >>> fk = pkmlab.forward_kinematics(pkmlab.load("paper"), [1.6146, 1.9831, -1.1846])
        >>> (np.round(fk.nearest([0.2, 0.2, 0.0]).pose, 3) + 0.0).tolist()
        [0.2, 0.21, 0.0]
        """
        n = len(self)
        if n == 0:
            raise IndexError("no assembly mode")
        target = as_batch("pose", pose, self.pose.shape[-1], single=True)[0][0]
        d = wrapped_where(self.pose[:n] - target, self.angles)
        return self[int(np.argmin(np.linalg.norm(d, axis=1)))]


def forward_kinematics(model: MechanismModel, theta, *, actuators=None) -> ForwardKinematicsSolution:
    """Every assembly mode at the actuator values ``theta``.

    Planar machines whose legs hold their attachment points on circles: the real roots of one degree-6
    polynomial (the paper's eq. 12 in Gosselin's general form); the five-bar: two circles; the Delta: three
    spheres; a platform on six UP*S legs: every real solution by homotopy continuation; any other planar
    machine: a sweep of the platform's orientation (conventions §3), which warns
    (:class:`~pkmlab.errors.IncompleteSolutionWarning`) where it cannot be sure it found every mode. Each
    configuration is polished by Newton's method on ``η = 0``.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    theta : array_like, shape (..., n_actuators)
        The actuator values (rad for a revolute actuator, m for a prismatic one).
    actuators : sequence of int, optional
        A redundantly actuated machine's: the ``dof`` actuators (0-based) whose values are solved for, the others
        checked (:attr:`ForwardKinematicsSolution.residual`): one of each chosen leg's, and every actuator that
        moves a leg's base with one of that leg's others. By default each leg's own
        (:attr:`~pkmlab.description.mechanism.JointChain.actuated`), first the legs that move their base, then
        the others in order (:attr:`ForwardKinematicsSolution.solved` says which).
        Each assembly mode of the machine they alone would drive is completed by the other legs' inverse
        kinematics, in the working mode nearest their given values. Choose actuators away from their own forward
        singularities (:func:`actuation_singularity_measure` with ``actuators``).

    Returns
    -------
    ForwardKinematicsSolution
        ``q`` (..., m, n), ``pose`` (..., m, dof), ``S`` (..., m), ``count`` (...): ``count`` is 0 where the
        machine cannot be assembled; ``residual`` for a redundantly actuated machine.

    Raises
    ------
    InvalidParameterError
        If ``theta`` does not have ``n_actuators`` components, or an entry is refused (the message names it).
    SingularityError
        Where the method cannot solve at an entry of ``theta`` (the message names it).

    Warns
    -----
    IncompleteSolutionWarning
        Where the orientation sweep cannot be sure it found every assembly mode.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> fk = pkmlab.forward_kinematics(pkmlab.load("paper"), [1.6146, 1.9831, -1.1846])
    >>> int(fk.count), np.round(fk.S, 3).tolist()
    (2, [0.815, -0.745])
    >>> fk.method
    "every real root of one degree-6 polynomial (the paper's eq. 12, Gosselin's general form): complete"
    """
    model = as_model(model)
    thetas, shape = as_batch("theta", theta, model.n_actuators)
    subset = _solved_actuators(model, actuators)
    found = []
    for k, t in enumerate(thetas):
        try:
            with warnings.catch_warnings(record=True) as caught:
                warnings.simplefilter("always", IncompleteSolutionWarning)
                found.append(assembly_modes(model, t) if subset is None
                             else _redundant_assembly_modes(model, t, subset))
        except (InvalidParameterError, SingularityError) as exc:
            raise type(exc)(f"theta{index_text(k, shape)}: {exc}") from None
        for w in caught:
            warnings.warn(f"{w.message}{index_text(k, shape)}", w.category, stacklevel=2)
    most = max([len(f) for f in found] + [0])
    n, dof, columns = len(model.coordinates), model.description.dof, list(model.pose_columns)
    q = np.full((len(thetas), most, n), np.nan)
    s = np.full((len(thetas), most), np.nan)
    count = np.array([len(f) for f in found], dtype=np.int64)
    for k, solutions in enumerate(found):
        for j, (qj, sj) in enumerate(solutions):
            q[k, j], s[k, j] = qj, sj
    residual = None
    if subset is not None:
        na = model.n_actuators
        residual = wrapped_where(thetas[:, None, :] - q[..., :na], model.kernels.ANGLES[:na])
        residual = residual.reshape(*shape, most, na)
    method = method_statement(model) if subset is None else (
        f"the actuators {', '.join(f'a{i + 1}' for i in subset)} solved by the machine they alone drive "
        f"({method_statement(_sub_machine(model, subset))}), the others' legs completed by inverse kinematics")
    return ForwardKinematicsSolution(q.reshape(*shape, most, n), q[..., columns].reshape(*shape, most, dof),
                                     s.reshape(*shape, most), count.reshape(shape), method,
                                     tuple(bool(model.kernels.ANGLES[c]) for c in columns), residual, subset)


def _solved_actuators(model: MechanismModel, actuators) -> tuple[int, ...] | None:
    """The actuators forward kinematics solves for: None (all) but for a redundantly actuated machine, whose
    ``actuators`` must be ``dof`` distinct ones: one per leg of its own ordinary part, as many legs as the
    platform's pose has coordinates, with every actuator moving a leg's base — those legs' among them (the base's
    actuators are controlled coordinates). Default: each leg's own
    (:attr:`~pkmlab.description.mechanism.JointChain.actuated`), the legs that move their base first, checked as a
    given choice is. Returned in increasing order, the sub-machine's (:func:`_sub_machine`)."""
    m = model.description
    if not m.actuation_redundancy:
        if actuators is not None:
            raise InvalidParameterError(f"actuators chooses the actuators a redundantly actuated machine's forward "
                                        f"kinematics solves for; the {model.name} has as many as its degrees of "
                                        "freedom")
        return None
    bases = set(m.redundancy_actuators)
    if actuators is None:
        moved = [i for i, leg in enumerate(m.legs) if leg.moving_base]
        legs = (moved + [i for i in range(len(m.legs)) if i not in moved])[:len(m.platform.pose_names)]
        actuators = sorted(bases | {m.actuators.index((i, m.legs[i].actuated)) for i in legs})
    chosen = tuple(as_actuators(model, actuators, exactly=True))
    legs: dict[int, int] = {}
    for i in chosen:
        leg, joint = m.actuators[i]
        if i in bases:
            continue
        if leg in legs:
            raise InvalidParameterError(f"actuators a{legs[leg] + 1} and a{i + 1} are both leg {leg + 1}'s: forward "
                                        "kinematics from a subset takes one actuator per leg")
        legs[leg] = i
    for i in sorted(bases):
        leg = m.actuators[i][0]
        if i not in chosen or leg not in legs:
            raise InvalidParameterError(f"actuator a{i + 1} moves the base of leg {leg + 1}: forward kinematics from a "
                                        f"subset takes it and one of that leg's other actuators")
    return tuple(sorted(chosen))


def _sub_machine(model: MechanismModel, actuators: tuple[int, ...]) -> MechanismModel:
    """The machine of the legs of ``actuators`` (increasing) alone, their platform attachments kept, each with only
    those of its actuators: one of as many actuators as degrees of freedom, whose forward kinematics solves the
    redundant machine's."""
    return _sub_machine_of(model.description, tuple(model.description.actuators[i] for i in actuators))


@functools.lru_cache(maxsize=32)
def _sub_machine_of(description, actuators: tuple[tuple[int, int], ...]) -> MechanismModel:
    import dataclasses

    chosen = dict.fromkeys(i for i, _k in actuators)
    legs = []
    for i in chosen:  # the leg with only the chosen joints actuated (its stroke, its own actuator's)
        leg = description.legs[i]
        joints = tuple(dataclasses.replace(j, actuated=(i, n) in actuators) for n, j in enumerate(leg.joints))
        own = (i, leg.actuated) in actuators
        legs.append(dataclasses.replace(leg, joints=joints, stroke=leg.stroke if own else None))
    platform = description.platform
    platform = dataclasses.replace(platform, attachments=tuple(platform.attachments[i] for i in chosen))
    sub = dataclasses.replace(description, legs=tuple(legs), platform=platform)
    return MechanismModel.from_description(sub)


def _redundant_assembly_modes(model: MechanismModel, theta: np.ndarray, subset: tuple[int, ...]):
    """Every assembly mode of the machine the ``subset`` of actuators drives, each completed by the other legs'
    inverse kinematics in the working mode whose actuator values are nearest ``theta``'s (``[(q, S), …]``)."""
    sub = _sub_machine(model, subset)
    na = model.n_actuators
    angles = np.asarray(model.kernels.ANGLES[:na], dtype=bool)
    modes = [tuple(int(s) for s in mode) for mode in mm.working_modes(model)]
    out = []
    for q_sub, _s in assembly_modes(sub, theta[list(subset)]):
        pose = mm.pose_of(sub, q_sub)
        candidates = []
        for mode in modes:
            q, unreachable, _failure = mm.inverse_kinematics_batch(model, pose[None, :], mode)
            if unreachable[0]:
                continue
            gap = wrapped_where(theta - q[0, :na], angles)
            candidates.append((float(np.abs(gap[list(subset)]).max()), float(np.abs(gap).max()), q[0]))
        if candidates:
            candidates.sort(key=lambda c: (c[0] > 1e-6, c[1]))
            q = candidates[0][2]
            out.append((q, float(mm.configuration_measures(model, q[None, :])[0])))
    return out


def branch_following(model: MechanismModel, q_previous, theta, *, singularity_guard: float = SINGULAR_S,
                     max_step: float = 0.05) -> np.ndarray:
    """The configuration at ``theta`` continuously connected to ``q_previous`` (paper §3.2).

    The forward kinematics a simulation uses, the compiled core's own: the actuators are moved from
    ``q_previous``'s to ``theta`` in sub-steps, the passive coordinates and the pose solved at each.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q_previous : array_like, shape (..., n)
        Configurations on the loop closure (the assembly modes to follow; rad or m per entry).
    theta : array_like, shape (..., n_actuators)
        The actuator values to follow them to (rad or m; broadcast against ``q_previous``).
    singularity_guard : float
        The guard (dimensionless, non-negative): the way may not come nearer a gain-type singularity
        (``|S|`` below it). Default :data:`SINGULAR_S`.
    max_step : float
        The largest sub-step in the actuators (rad or m, positive; halved where one fails; an angle moves the
        shorter way round, by at most π).

    Returns
    -------
    ndarray, shape (..., n)
        The configurations at ``theta``.

    Raises
    ------
    BranchFollowingError
        Where the way nears a gain-type singularity or the passive coordinates cannot be found.
    InvalidParameterError
        If an argument has the wrong shape or value.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> np.round(pkmlab.branch_following(model, q, q[:3] + 0.01)[-3:], 4).tolist()
    [0.1994, 0.2095, -0.0316]
    """
    model = as_model(model)
    refuse_actuation_redundancy(model, "branch following")
    n, na = len(model.coordinates), model.n_actuators
    qs, thetas, shape = as_broadcast(("q_previous", q_previous, n), ("theta", theta, na))
    singularity_guard = as_real("singularity_guard", singularity_guard, "non-negative")
    step = as_real("max_step", max_step, "positive")
    k = model.kernels
    out, status = np.empty_like(qs), np.zeros(len(qs), dtype=np.int64)
    k.branch_following_batch(qs, thetas, model.P, singularity_guard, step, out, status)
    if np.any(status != k.OK):
        i = int(np.flatnonzero(status != k.OK)[0])
        why = ("a gain-type singularity on the way" if status[i] == k.SINGULAR else
               "the passive coordinates cannot be found on the way: out of reach, or at a gain-type singularity")
        reached = float(singularity_measure(model, out[i]))
        raise BranchFollowingError(
            f"cannot follow the assembly mode to theta {np.round(thetas[i], 6).tolist()}{index_text(i, shape)}: "
            f"{why} (|S| = {abs(reached):.3g} at theta {np.round(out[i, :na], 6).tolist()}, the last configuration "
            f"reached; limit singularity_guard = {singularity_guard:g})")
    return out.reshape(*shape, n)


def follow_path(model: MechanismModel, q_start, theta, *, singularity_guard: float = SINGULAR_S,
                max_step: float = 0.05) -> np.ndarray:
    """The configurations along a path of actuator values ``theta``, each followed from the one before it.

    The first is followed from ``q_start`` (paper §3.2, as a simulation follows its plant): what a log of
    measured actuators gives of the passive joints and the pose.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q_start : array_like, shape (n,)
        A configuration on the loop closure near ``theta[0]`` (the assembly mode to follow; rad or m per entry).
    theta : array_like, shape (K, n_actuators)
        The actuator values in turn (rad or m), sampled densely enough that each step stays on the branch.
    singularity_guard : float
        The path may not come nearer a gain-type singularity (``|S|`` below it; dimensionless).
    max_step : float
        The largest change of an actuator from one row to the next (rad or m): a longer step could land on
        another branch unseen, so it is refused (sample the path more densely).

    Returns
    -------
    ndarray, shape (K, n)
        The configuration at each row of ``theta``.

    Raises
    ------
    BranchFollowingError
        Naming the first row of ``theta`` that cannot be reached, or that jumps farther than ``max_step``
        (its ``row`` and ``reason`` attributes say which and why).
    InvalidParameterError
        If ``q_start`` is off the loop closure, or an argument has the wrong shape or value.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q0 = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> theta = q0[:3] + np.linspace(0.0, 0.05, 6)[:, None] * [1.0, 0.0, 0.0]
    >>> qs = pkmlab.follow_path(model, q0, theta)
    >>> qs.shape, np.round(qs[-1, -3:], 4).tolist()
    ((6, 9), [0.2005, 0.2263, -0.0976])
    """
    model = as_model(model)
    refuse_actuation_redundancy(model, "branch following")
    n, na = len(model.coordinates), model.n_actuators
    q0, _ = as_batch("q_start", q_start, n, single=True)
    thetas, _ = as_batch("theta", theta, na)
    guard = as_real("singularity_guard", singularity_guard, "non-negative")
    step = as_real("max_step", max_step, "positive")
    check_loop_closure(model, q0, (), "q_start")
    jumps = np.abs(np.diff(np.vstack([q0[:, :na], thetas]), axis=0)).max(axis=1)
    if np.any(jumps > step):
        row = int(np.flatnonzero(jumps > step)[0])
        error = BranchFollowingError(f"theta at row {row} jumps by {jumps[row]:.3g} from the row before it, more than "
                                     f"max_step = {step:g}: sample the path more densely")
        error.row, error.reason = row, f"a jump of {jumps[row]:.3g}, more than max_step = {step:g}"
        raise error
    k = model.kernels
    out = np.empty((len(thetas), n))
    status, row = k.follow_path(np.ascontiguousarray(q0[0]), np.ascontiguousarray(thetas), model.P, guard, out)
    if status != k.OK:
        why = ("a gain-type singularity on the way" if status == k.SINGULAR else
               "the passive coordinates cannot be found there: out of reach, a jump, or a gain-type singularity")
        last = out[row - 1] if row > 0 else q0[0]
        reached = abs(float(singularity_measure(model, last)))
        reason = f"{why} (|S| = {reached:.3g} there; limit singularity_guard = {guard:g})"
        error = BranchFollowingError(f"theta at row {row} {np.round(thetas[row], 6).tolist()} cannot be reached from "
                                     f"the row before it: {reason}")
        error.row, error.reason = int(row), reason  # for a caller that numbers the rows otherwise (a file's)
        raise error
    return out


# ------------------------------------------------------------------ first-order kinematics
def constraint_residual(model: MechanismModel, q) -> np.ndarray:
    """The loop-closure residual ``η(q)``.

    For each leg, the end of its chain minus its platform attachment point (zero on the manifold; the paper's
    eqs. 2–6 for its machine).

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations (rad or m per entry).

    Returns
    -------
    ndarray, shape (..., n_constraints)
        The residuals (m), 2 rows per leg in the plane, 3 in space.

    Raises
    ------
    InvalidParameterError
        If ``q`` does not have ``n`` components.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> eta = pkmlab.constraint_residual(model, q)
    >>> eta.shape, bool(np.abs(eta).max() < 1e-12)
    ((6,), True)
    """
    model = as_model(model)
    qs, shape = _configurations(model, q)
    return constraint_residuals(model, qs).reshape(*shape, model.kernels.N_CONSTRAINTS)


def constraint_jacobian(model: MechanismModel, q) -> np.ndarray:
    """The constraint Jacobian ``Jηq = ∂η/∂q``.

    Its columns of the actuators are ``Jηθ``, those of the passive joints and the pose ``Jηφ``.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations (rad or m per entry); need not be on the loop closure.

    Returns
    -------
    ndarray, shape (..., n_constraints, n)
        m per unit of each coordinate (m/rad or m/m).

    Raises
    ------
    InvalidParameterError
        If ``q`` does not have ``n`` components.

    Examples
    --------
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> pkmlab.constraint_jacobian(model, q).shape
    (6, 9)
    """
    model = as_model(model)
    qs, shape = _configurations(model, q)
    k = model.kernels
    out = np.empty((len(qs), k.N_CONSTRAINTS, k.N_COORDINATES))
    k.constraint_jacobians(qs, model.P, out)
    return out.reshape(*shape, k.N_CONSTRAINTS, k.N_COORDINATES)


def _dependent_solve(model: MechanismModel, j_eta: np.ndarray, rhs: np.ndarray, shape, name: str) -> np.ndarray:
    """``-(∂η/∂u)⁻¹ rhs`` for the dependent coordinates ``u`` (passive joints and pose) of each configuration;
    raises at a gain-type singularity (``∂η/∂u`` singular)."""
    refuse_actuation_redundancy(model, "the coordinates' rates from the actuators'")
    na = model.n_actuators
    a = j_eta[:, :, na:]
    k = first_singular(a)
    if k >= 0:
        raise SingularityError(f"{name}{index_text(k, shape)} is at a gain-type singularity: the passive "
                               "coordinates' rates are undetermined (d eta / d(passive, pose) is singular)")
    return -np.linalg.solve(a, rhs)


def coordinate_jacobian(model: MechanismModel, q) -> np.ndarray:
    """The coordinate Jacobian ``Jqθ = ∂q/∂θ`` on the loop closure.

    ``q̇ = Jqθ θ̇`` (the paper's eq. 31, for every machine). Its first ``n_actuators`` rows are the identity.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations on the loop closure (rad or m per entry).

    Returns
    -------
    ndarray, shape (..., n, n_actuators)
        Each coordinate's rate per unit actuator rate.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual) or does not have ``n`` components.
    SingularityError
        At a gain-type singularity, where the passive coordinates' rates are undetermined.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> J = pkmlab.coordinate_jacobian(model, q)
    >>> J.shape, bool(np.array_equal(J[:3], np.eye(3)))
    ((9, 3), True)
    """
    model = as_model(model)
    qs, shape = _configurations(model, q)
    check_loop_closure(model, qs, shape)
    na = model.n_actuators
    j_eta = constraint_jacobian(model, qs)
    dependent = _dependent_solve(model, j_eta, j_eta[:, :, :na], shape, "q")
    eye = np.broadcast_to(np.eye(na), (len(qs), na, na))
    return np.concatenate([eye, dependent], axis=1).reshape(*shape, len(model.coordinates), na)


def velocity_jacobian(model: MechanismModel, q) -> np.ndarray:
    """The velocity Jacobian ``Jv = ∂pose/∂θ``: the platform's pose rates from the actuator rates.

    The rows of :func:`coordinate_jacobian` of the controlled coordinates (``q``'s last ``dof``; a kinematically
    redundant machine's base actuators among its first), orientation included.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations on the loop closure (rad or m per entry).

    Returns
    -------
    ndarray, shape (..., dof, n_actuators)
        The pose's rates (m/s, rad/s) per unit actuator rate (rad/s or m/s).

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (naming its residual) or does not have ``n`` components.
    SingularityError
        At a gain-type singularity.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> np.round(pkmlab.velocity_jacobian(model, q), 4)
    array([[-0.0029, -0.1431,  0.0861],
           [ 0.2654, -0.3092, -0.0161],
           [-1.5534, -0.2195, -1.3871]])
    """
    return coordinate_jacobian(model, q)[..., list(as_model(model).pose_columns), :]


def coordinate_rates(model: MechanismModel, q, theta_dot) -> np.ndarray:
    """The coordinates' rates ``q̇ = Jqθ θ̇`` at configurations ``q`` for actuator rates ``theta_dot``.

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
    ndarray, shape (..., n)
        rad/s or m/s per coordinate.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure or the shapes do not broadcast.
    SingularityError
        At a gain-type singularity.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> np.round(pkmlab.coordinate_rates(model, q, [0.1, 0.0, 0.0]), 4).tolist()
    [0.1, 0.0, 0.0, 0.2515, -0.107, -0.1721, -0.0003, 0.0265, -0.1553]
    """
    model = as_model(model)
    qs, theta_dots, shape = as_broadcast(("q", q, len(model.coordinates)), ("theta_dot", theta_dot, model.n_actuators))
    return np.einsum("kij,kj->ki", coordinate_jacobian(model, qs), theta_dots).reshape(*shape, len(model.coordinates))


def acceleration_bias(model: MechanismModel, q, theta_dot) -> np.ndarray:
    """The acceleration bias ``J̇qθ θ̇``: the coordinates' accelerations at zero actuator acceleration.

    So that ``q̈ = Jqθ θ̈ + J̇qθ θ̇`` (the paper's eq. 32, for every machine); zero in the actuators' rows.

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
    ndarray, shape (..., n)
        rad/s² or m/s² per coordinate.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure, the shapes do not broadcast, or ``theta_dot`` overflows the result.
    SingularityError
        At a gain-type singularity.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> np.round(pkmlab.acceleration_bias(model, q, [0.1, 0.0, 0.0]), 4).tolist()
    [0.0, 0.0, 0.0, 0.1413, -0.0614, -0.1041, 0.0037, 0.0159, -0.1039]
    """
    model = as_model(model)
    qs, theta_dots, shape = as_broadcast(("q", q, len(model.coordinates)), ("theta_dot", theta_dot, model.n_actuators))
    q_dot = coordinate_rates(model, qs, theta_dots)
    k = model.kernels
    gamma = np.empty((len(qs), k.N_CONSTRAINTS))
    k.constraint_biases(qs, np.ascontiguousarray(q_dot), model.P, gamma)
    dependent = _dependent_solve(model, constraint_jacobian(model, qs), gamma[..., None], shape, "q")[..., 0]
    out = np.concatenate([np.zeros((len(qs), model.n_actuators)), dependent], axis=1)
    if not np.all(np.isfinite(out)):
        raise InvalidParameterError("theta_dot overflows the acceleration bias (rates too large)")
    return out.reshape(*shape, len(model.coordinates))


def coordinate_accelerations(model: MechanismModel, q, theta_dot, theta_ddot) -> np.ndarray:
    """The coordinates' accelerations ``q̈ = Jqθ θ̈ + J̇qθ θ̇`` (the paper's eq. 32).

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
    ndarray, shape (..., n)
        rad/s² or m/s² per coordinate.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure, the shapes do not broadcast, or the rates overflow.
    SingularityError
        At a gain-type singularity.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> np.round(pkmlab.coordinate_accelerations(model, q, [0.1, 0.0, 0.0], [1.0, 0.0, 0.0]), 4).tolist()
    [1.0, 0.0, 0.0, 2.6567, -1.1311, -1.8255, 0.0007, 0.2813, -1.6573]
    """
    model = as_model(model)
    n, na = len(model.coordinates), model.n_actuators
    qs, theta_dots, theta_ddots, shape = as_broadcast(("q", q, n), ("theta_dot", theta_dot, na),
                                                      ("theta_ddot", theta_ddot, na))
    out = (np.einsum("kij,kj->ki", coordinate_jacobian(model, qs), theta_ddots)
           + acceleration_bias(model, qs, theta_dots))
    return out.reshape(*shape, n)


def pose_coordinate_jacobian(model: MechanismModel, q) -> np.ndarray:
    """The coordinate Jacobian with respect to the pose, ``Jqx = ∂q/∂x``, on the loop closure.

    ``q̇ = Jqx ẋ``: its rows of the controlled coordinates are the identity, the others come from
    ``Jηq q̇ = 0``. It exists wherever every leg's joint rates follow from its attachment's (no leg at a serial
    singularity), forward singularities included.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations on the loop closure (rad or m per entry).

    Returns
    -------
    ndarray, shape (..., n, dof)
        Each coordinate's rate per unit rate of each controlled coordinate.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure or does not have ``n`` components.
    SingularityError
        At a serial singularity of a leg.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("examples/mechanisms/4rrr.toml")
    >>> q = pkmlab.inverse_kinematics(model, [0.26, 0.27, 0.1], mode=(1, 1, 1, 1)).q
    >>> J = pkmlab.pose_coordinate_jacobian(model, q)
    >>> J.shape, bool(np.array_equal(J[-3:], np.eye(3)))
    ((11, 3), True)
    """
    model = as_model(model)
    n = len(model.coordinates)
    qs, shape = as_broadcast(("q", q, n))
    check_loop_closure(model, qs, shape)
    out, singular = mm.pose_jacobians(model, qs)
    _refuse_serial(singular, shape)
    return out.reshape(*shape, n, model.dof)


def _refuse_serial(singular: np.ndarray, shape) -> None:
    if singular.any():
        raise SingularityError(f"q{index_text(int(np.flatnonzero(singular)[0]), shape)} is at a serial singularity: "
                               "a leg's joint rates are undetermined by the pose's (d eta / d(actuators, passive) is "
                               "singular)")


def actuation_jacobian(model: MechanismModel, q) -> np.ndarray:
    """The actuation Jacobian ``W = ∂θ/∂x``: the actuators' rates from the pose's, ``θ̇ = W ẋ``.

    Its transpose maps actuator efforts to the generalised forces they exert in the pose (``Wᵀ τ``, the
    platform wrench of the actuation). For a machine of as many actuators as degrees of freedom it is the
    inverse of :func:`~pkmlab.algorithms.kinematics.velocity_jacobian`; for a redundantly actuated one it has
    more rows than columns.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations on the loop closure (rad or m per entry).

    Returns
    -------
    ndarray, shape (..., n_actuators, dof)
        Each actuator's rate (rad/s or m/s) per unit rate of each controlled coordinate (m/s, rad/s).

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure or does not have ``n`` components.
    SingularityError
        At a serial singularity of a leg.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> bool(np.allclose(pkmlab.actuation_jacobian(model, q) @ pkmlab.velocity_jacobian(model, q), np.eye(3)))
    True
    """
    model = as_model(model)
    return pose_coordinate_jacobian(model, q)[..., :model.n_actuators, :]  # θ = q[..., :n_a]


def actuation_singularity_measure(model: MechanismModel, q, actuators=None) -> np.ndarray:
    """The forward singularity measure of the actuation: the smallest singular value of ``W`` (scaled).

    Zero where a platform motion leaves every actuator still (a forward, or parallel, singularity), larger the
    farther from one. ``W``'s orientation columns are divided by the platform's size ``ℓ`` (the mean distance
    between its attachment points: a turn at rate ``ω`` moves a point ``ℓ`` from the centre at ``ℓ ω``), so that
    every column is in actuator units per metre. Restricted to some ``actuators``, it is the measure of the machine
    those alone would drive: a redundant machine's is at least that of each of its non-redundant sub-machines.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations on the loop closure.
    actuators : sequence of int, optional
        The actuators (0-based, at least ``dof`` of them) whose rows of ``W`` count; all by default.

    Returns
    -------
    ndarray, shape (...)
        The smallest singular value (actuator units per metre: rad/m or m/m); NaN where a leg is at a serial
        singularity (``W`` does not exist there).

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure, or ``actuators`` names no actuator of the machine.
    SingularityError
        At a serial singularity of a leg.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> model = pkmlab.load("examples/mechanisms/4rrr.toml")
    >>> q = pkmlab.inverse_kinematics(model, [0.26, 0.27, 0.1], mode=(1, 1, 1, 1)).q
    >>> every = pkmlab.actuation_singularity_measure(model, q)
    >>> bool(every >= pkmlab.actuation_singularity_measure(model, q, actuators=[0, 1, 2]))
    True
    """
    model = as_model(model)
    rows = as_actuators(model, actuators)
    qs, shape = as_broadcast(("q", q, len(model.coordinates)))
    check_loop_closure(model, qs, shape)
    return mm.actuation_measures(model, qs, rows).reshape(shape)


def as_actuators(model: MechanismModel, actuators, exactly: bool = False) -> list[int]:
    """``actuators`` as a list of the model's actuator indices (0-based; None: all), at least ``dof`` of them
    (``exactly`` ``dof``), or one line refusing it."""
    if actuators is None:
        return list(range(model.n_actuators))
    listed = isinstance(actuators, list | tuple) or (isinstance(actuators, np.ndarray) and actuators.ndim == 1)
    rows = list(actuators) if listed else []
    if ((len(rows) != model.dof if exactly else len(rows) < model.dof)
            or any(isinstance(a, bool | np.bool_) or not isinstance(a, int | np.integer)
                   or not 0 <= a < model.n_actuators for a in rows)
            or len({int(a) for a in rows}) < len(rows)):  # (distinct once they are known to be indices)
        count = f"{model.dof}" if exactly else f"at least {model.dof}"
        more = "" if exactly else " (as many as its degrees of freedom, or more)"
        raise InvalidParameterError(f"actuators must be {count} distinct indices from 0 to "
                                    f"{model.n_actuators - 1} of {model.name}'s actuators{more}, got "
                                    f"{shown(actuators)}")
    return [int(a) for a in rows]


def singularity_measure(model: MechanismModel, q) -> np.ndarray:
    """The gain-type singularity measure ``S`` at configurations ``q`` on the loop closures.

    Zero where the passive motion is undetermined, with its sign (conventions §2: the determinant of the legs'
    lines of action, the paper's eq. 19 for its machine; ``sin(φ1 - φ2)`` for the five-bar).

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    q : array_like, shape (..., n)
        Configurations on the loop closure (rad or m per entry).

    Returns
    -------
    ndarray, shape (...)
        ``S``, dimensionless.

    Raises
    ------
    InvalidParameterError
        If ``q`` is off the loop closure (the measure of a configuration the machine cannot be in means
        nothing; the message names its residual) or does not have ``n`` components.

    Examples
    --------
    >>> import pkmlab
    >>> model = pkmlab.load("paper")
    >>> q = pkmlab.inverse_kinematics(model, [0.20, 0.21, 0.0], mode=(1, -1, 1)).q
    >>> f"{float(pkmlab.singularity_measure(model, q)):.4f}"
    '-0.7446'
    """
    model = as_model(model)
    refuse_actuation_redundancy(model, "the singularity measure S")
    qs, shape = _configurations(model, q)
    check_loop_closure(model, qs, shape)  # the measure of a configuration the machine cannot be in means nothing
    out = np.empty(len(qs))
    model.kernels.singularity_measures(qs, model.P, out)
    return out.reshape(shape)
