"""Kinematic calibration of any described mechanism: its geometry identified from measured actuators and
external measurements of the platform.

What is calibrated. The description's geometric parameters — every leg's base point, every body's tip (its
joint-to-joint vector, hence the link lengths), the platform's attachment points — and each actuator's zero
offset (``θ_true = θ_read + δ``) — and its joint axes, as small turns from the described ones (rad): a planar
rail's angle (``rail1_angle``); a spatial revolute's or prismatic joint's axis turned about two directions
perpendicular to it (``axis1_1_tilt_u``, ``_tilt_v``: ``u`` the unit ``a × e`` for the world axis ``e`` least
aligned with the axis ``a``, ``v = a × u``); a universal joint's two axes turned together, keeping them
perpendicular, about the x, y and z of the frame they are given in (``axis1_2_turn_x``, ``_y``, ``_z``; a turn
about the first axis alone only moves the zero of a passive coordinate, and is found unidentifiable). A leg's
parallel hinges or slides turn together, kept parallel (``axis1_1_2_tilt_u``: joints 1 and 2 of leg 1): a leg's
kinematics may rest on them being so (the 3-RRS's). The axes of
a leg that ends in a universal joint at the platform (Tsai's 3-UPU) are kept as described: they are what keeps a
translating platform level, and turned alone they would let it turn.
:func:`geometric_parameters` names them all (``base2_y``, ``body1_2_tip_x``, ``attach3_x``, ``rail1_angle``,
``offset1``).

The measurement model. A pose ``k`` is the machine at rest at the actuator readings ``θ_k`` with the platform
measured by an external instrument: its tracked point (a laser tracker, ``measure = "position"``) or its whole
pose (``"pose"``). With parameters ``p`` the forward kinematics ``x(θ_k + δ; p)`` — by branch following from the
assembly mode nearest the measurement, so that every pose stays in the mode it was measured in — predicts it;
calibration solves ``min_p Σ_k ‖x_k,measured - x(θ_k + δ; p)‖²`` by SciPy's trust-region least squares (its
Jacobian by finite differences of the compiled branch following).

Identifiability. The Jacobian ``J`` of the predictions with respect to the parameters (each scaled by the
machine's size, or a radian) tells what the poses can determine: its singular values ``σ_i``; Borm and Menq's
observability index ``O1 = (σ_1 ⋯ σ_r)^(1/r) / √N`` (larger is better); and a QR factorisation with column
pivoting picks the parameters it determines independently. The others — combinations that move no measured
coordinate, e.g. a base point shifted along with its link — are kept at their described values and listed as
fixed. :func:`select_poses` chooses, among candidate poses, those that maximise ``log det(Jᵀ J)`` (D-optimality),
greedily.

The estimate's standard deviations are ``s² (JᵀJ)⁻¹`` at the solution (``s²`` the residual variance), for the
measurement noise the residuals show.
"""

from __future__ import annotations

import math
import re
from dataclasses import dataclass, field, replace

import numpy as np

from .._validate import as_batch, as_choice, as_count
from ..errors import InvalidParameterError, PkmlabError
from ..model import mechanism_model as mm
from ..model.mechanism_model import MechanismModel
from ..numerics.angles import wrapped_where
from .kinematics import as_model, length_scale, refuse_actuation_redundancy

__all__ = ["Calibration", "geometric_parameters", "with_geometry", "perturbed_geometry", "reachable_poses", "calibrate",
           "calibration_jacobian", "select_poses", "predicted_measurements"]

_GEOMETRY = re.compile(r"^(base\d+|body\d+_\d+_tip|attach\d+)_[xyz]$")
#: A parameter whose pivot in the scaled Jacobian's QR factorisation is below this share of the first is not
#: determined by the poses.
RANK_TOL = 1e-6
#: The finite-difference step of the Jacobian, as a share of the machine's size (or of a radian).
STEP = 1e-7


@dataclass(frozen=True)
class _AxisTurn:
    """The turn parameters of one joint's axes (rad; the module's text) and the packed vector's entries of those
    axes: a planar rail's ``(cos, sin)``, or a spatial joint's axis or pair of axes (3 or 6 components)."""

    names: tuple[str, ...]
    leg: int
    joints: tuple[int, ...]  # the leg's joints it turns (parallel hinges or slides turn together)
    index: np.ndarray
    nominal: np.ndarray
    basis: np.ndarray | None  # (len(names), 3): each turn's direction (spatial); None for a rail's angle

    def rotation(self, turns) -> np.ndarray:
        from ..description.spatial import axis_rotation

        omega = np.asarray(turns, dtype=float) @ self.basis
        angle = float(np.linalg.norm(omega))
        return axis_rotation(omega / angle, angle) if angle > 0 else np.eye(3)

    def values(self, turns) -> np.ndarray:
        """The packed entries of the axes turned by ``turns`` (len(names),)."""
        if self.basis is None:
            angle = float(np.arctan2(self.nominal[1], self.nominal[0])) + float(turns[0])
            return np.array([np.cos(angle), np.sin(angle)])
        return (self.nominal.reshape(-1, 3) @ self.rotation(turns).T).ravel()


def _perpendicular_basis(axis) -> np.ndarray:
    """``u = a × e / |a × e|`` for the world axis ``e`` least aligned with ``a``, and ``v = a × u``."""
    a = np.asarray(axis, dtype=float)
    e = np.eye(3)[int(np.argmin(np.abs(a)))]
    u = np.cross(a, e)
    u /= np.linalg.norm(u)
    return np.stack([u, np.cross(a, u)])


def _axis_turns(model: MechanismModel) -> tuple[_AxisTurn, ...]:
    """Every joint axis's turn parameters, leg by leg and joint by joint (the module's text)."""
    index = {n: i for i, n in enumerate(model.kernels.PARAMETERS)}
    m = model.description
    turns = []
    for i, leg in enumerate(m.legs):
        if not hasattr(leg.joints[0], "axes"):  # planar: a rail's angle
            if f"rail{i + 1}_x" in index:
                entries = np.array([index[f"rail{i + 1}_{c}"] for c in "xy"])
                turns.append(_AxisTurn((f"rail{i + 1}_angle",), i, (0,), entries, model.P[entries].copy(), None))
            continue
        if leg.joints[-1].kind == "U":  # its axes keep the platform level: turned alone, they would turn it
            continue
        for group in _turn_groups(leg):
            keys = [f"axis{i + 1}_{k + 1}{'ab'[a]}_{c}" for k in group for a in range(len(leg.joints[k].axes))
                    for c in "xyz"]
            entries = np.array([index[key] for key in keys])
            stem = f"axis{i + 1}_" + "_".join(str(k + 1) for k in group)
            if len(leg.joints[group[0]].axes) == 1:
                names, basis = (f"{stem}_tilt_u", f"{stem}_tilt_v"), _perpendicular_basis(leg.joints[group[0]].axes[0])
            else:
                names, basis = tuple(f"{stem}_turn_{c}" for c in "xyz"), np.eye(3)
            turns.append(_AxisTurn(names, i, group, entries, model.P[entries].copy(), basis))
    return tuple(turns)


def _turn_groups(leg) -> list[tuple[int, ...]]:
    """The leg's joints with axes, as the groups turned together: a universal joint alone; revolute and prismatic
    joints whose axes are parallel in the description together (a leg's parallel hinges, as the 3-RRS's, are what
    its kinematics rests on: one turn keeps them parallel)."""
    groups: list[list[int]] = []
    for k, joint in enumerate(leg.joints):
        if not joint.axes:
            continue
        if len(joint.axes) == 1:
            for group in groups:
                first = leg.joints[group[0]]
                if len(first.axes) == 1 and abs(abs(float(np.dot(first.axes[0], joint.axes[0]))) - 1.0) < 1e-12:
                    group.append(k)
                    break
            else:
                groups.append([k])
        else:
            groups.append([k])
    return [tuple(g) for g in groups]


def _turned(turn: _AxisTurn, values: dict) -> np.ndarray:
    return np.array([float(values.get(n, 0.0)) for n in turn.names])


def geometric_parameters(model) -> tuple[str, ...]:
    """The names of ``model``'s geometric parameters (the module's text), in the packed vector's order, then the
    turns of its joint axes, then the actuators' offsets ``offset<j>``.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).

    Returns
    -------
    tuple of str
        Points' coordinates (m) such as ``base1_x``, ``body1_2_tip_y``, ``attach3_x``; axes' turns (rad) such as
        ``rail1_angle`` or ``axis1_1_tilt_u``; and ``offset1``, ... (rad, or m for a prismatic actuator).

    Raises
    ------
    InvalidParameterError
        If ``model`` is not a pkmlab model.

    Examples
    --------
    >>> import pkmlab
    >>> geometric_parameters(pkmlab.load("five_bar"))[:4]
    ('base1_x', 'base1_y', 'body1_1_tip_x', 'body1_1_tip_y')
    """
    model = as_model(model)
    _check_calibratable(model)
    names = [n for n in model.kernels.PARAMETERS if _GEOMETRY.match(n)]
    turns = [n for turn in _axis_turns(model) for n in turn.names]
    return (*names, *turns, *(f"offset{j + 1}" for j in range(model.n_actuators)))


def _check_calibratable(model: MechanismModel) -> None:
    """Refuse, in one line, a machine whose legs end in universal or revolute joints under a rigid platform (a
    3-UPU wrist, the Agile Eye): its motion rests on axes that meet at one centre, which the parameters turned and
    moved one at a time would not keep (the machine so perturbed has another mobility)."""
    from ..description.mobility import all_orientation_rows

    m = model.description
    if getattr(m, "spatial", False) and all_orientation_rows(m):
        raise InvalidParameterError(f"{m.name}: its platform is carried by universal or revolute joints whose axes its "
                                    "motion needs as they are; pkmlab does not calibrate such a machine")


def _is_angle(name: str) -> bool:
    """A parameter in radians from its described value (a turn of an axis), not a coordinate in metres."""
    return name.endswith("_angle") or "_tilt_" in name or "_turn_" in name


def _scales(model: MechanismModel, names) -> np.ndarray:
    size = length_scale(model)
    kinds = model.description.actuator_kinds
    return np.array([(1.0 if kinds[int(n[6:]) - 1] == "R" else size) if n.startswith("offset")
                     else 1.0 if _is_angle(n) else size for n in names])


def _measured_columns(model: MechanismModel, measure: str) -> list[int]:
    """The pose's coordinates an instrument measures: the tracked point's, or every one of the platform's (a
    kinematically redundant machine's base actuators are read, not measured)."""
    names = model.pose_names
    if measure == "pose":
        return [i for i, n in enumerate(names) if n not in model.description.redundancy_names]
    return [i for i, n in enumerate(names) if n in ("x", "y", "z")]


class _Predictor:
    """The predicted measurements of poses ``theta`` (N, n) for parameters, by branch following in the packed
    vector from configurations ``q`` of the previous evaluation."""

    def __init__(self, model: MechanismModel, names, theta, q_start, columns):
        self.model, self.theta, self.q = model, theta, q_start
        index = {n: i for i, n in enumerate(model.kernels.PARAMETERS)}
        position = {n: i for i, n in enumerate(names)}
        points = [n for n in names if not n.startswith("offset") and not _is_angle(n)]
        self.geometry = np.array([index[n] for n in points], dtype=np.int64)
        self.points = np.array([position[n] for n in points], dtype=np.int64)
        # each turned joint: its turns' places in the vector (-1: not calibrated, kept at 0)
        self.turns = [(turn, np.array([position.get(n, -1) for n in turn.names]))
                      for turn in _axis_turns(model) if any(n in position for n in turn.names)]
        self.offsets = np.array([int(n[6:]) - 1 for n in names if n.startswith("offset")], dtype=np.int64)
        self.offset_places = np.array([position[n] for n in names if n.startswith("offset")], dtype=np.int64)
        self.columns = columns

    def __call__(self, p: np.ndarray) -> np.ndarray:
        """The predicted measurements (N, len(columns)) at parameters ``p``; NaN rows where the machine cannot be
        assembled."""
        P = self.model.P.copy()
        P[self.geometry] = p[self.points]
        for turn, places in self.turns:
            P[turn.index] = turn.values(np.where(places >= 0, p[np.maximum(places, 0)], 0.0))
        theta = self.theta.copy()
        theta[:, self.offsets] += p[self.offset_places]
        P.setflags(write=False)  # as every model's: the kernels are compiled for read-only parameters only
        out = np.empty_like(self.q)
        status = np.empty(len(theta), dtype=np.int64)
        self.model.kernels.branch_following_batch(self.q, np.ascontiguousarray(theta), P, 1e-9, np.inf, out, status)
        pose = mm.pose_of(self.model, out)[:, self.columns]
        ok = status == self.model.kernels.OK
        pose[~ok] = np.nan
        self.last = (out, ok)
        return pose

    def accept(self) -> None:
        """Start the next evaluations from the last one's configurations (continuation along the solver's
        accepted steps: a rejected trial far away must not move the poses to another branch)."""
        out, ok = self.last
        self.q[ok] = out[ok]


def _start_configurations(model: MechanismModel, theta: np.ndarray, measured: np.ndarray, columns) -> np.ndarray:
    """Each pose's configuration at its readings in the assembly mode nearest its measurement (the nominal
    geometry): the inverse kinematics of a fully measured pose (in the working mode whose actuators are nearest
    the readings) moved to the readings by branch following, or else the forward kinematics' solution nearest the
    measured point."""
    from .kinematics import forward_kinematics

    dof, n, k_ = model.description.dof, model.n_actuators, model.kernels
    count = len(theta)
    out = np.full((count, k_.N_COORDINATES), np.nan)
    if len(columns) + len(model.description.redundancy_names) == dof:  # the whole pose: its inverse kinematics
        best_gap = np.full(count, np.inf)
        for mode in mm.working_modes(model):
            q, _s, _failure = mm.path_inverse_kinematics(model, measured, mode)
            with np.errstate(invalid="ignore"):
                gap = np.abs(wrapped_where(q[:, :n] - theta, model.kernels.ANGLES[:n])).max(axis=1)
            better = np.isfinite(gap) & (gap < best_gap)
            out[better], best_gap[better] = q[better], gap[better]
        found = np.isfinite(best_gap)
        if found.any():
            moved, status = np.empty((int(found.sum()), k_.N_COORDINATES)), np.empty(int(found.sum()), np.int64)
            k_.branch_following_batch(np.ascontiguousarray(out[found]), np.ascontiguousarray(theta[found]), model.P,
                                      1e-9, np.inf, moved, status)
            moved[status != k_.OK] = np.nan
            out[found] = moved
    for k in np.flatnonzero(~np.all(np.isfinite(out), axis=1)):
        fk = forward_kinematics(model, theta[k])
        if int(fk.count) == 0:
            raise InvalidParameterError(f"pose {k}: the readings theta = {theta[k].tolist()} assemble the "
                                        "described machine in no way: are they of this machine?")
        gaps = np.linalg.norm(fk.pose[: int(fk.count)][:, columns] - measured[k][columns], axis=1)
        out[k] = fk.q[int(np.argmin(gaps))]
    return out


def predicted_measurements(model, theta, measured, *, measure: str = "position", offsets=None) -> np.ndarray:
    """What the instrument would measure (N, m) of ``model`` at the readings ``theta`` (N, n_actuators) plus the
    actuators' ``offsets`` (e.g. :attr:`Calibration.offsets`; default none), each pose in the assembly mode
    nearest its measurement ``measured`` (as for :func:`calibrate`): a calibration's check on held-out poses
    is ``measured - predicted_measurements(calibration.model, theta, measured, offsets=calibration.offsets)``.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`, :func:`with_geometry`, :attr:`Calibration.model`).
    theta : array_like, shape (N, n_actuators)
        The actuators' readings at each pose (rad, or m for a prismatic actuator).
    measured : array_like, shape (N, m) or (N, dof)
        The measured tracked point (``measure="position"``, m) or whole pose (``"pose"``, m and rad) at each:
        what chooses the assembly mode.
    measure : {"position", "pose"}
        What the instrument measures.
    offsets : array_like, shape (n_actuators,), optional
        Added to the readings (rad, or m for a prismatic actuator).

    Returns
    -------
    ndarray, shape (N, m)
        The measured coordinates the machine predicts (m, and rad for an orientation).

    Raises
    ------
    InvalidParameterError
        If the readings do not assemble the machine, or the arguments' shapes do not agree.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> from pkmlab.algorithms.calibration import predicted_measurements, reachable_poses
    >>> model = pkmlab.load("five_bar")
    >>> poses, q = reachable_poses(model, 8, np.random.default_rng(1))
    >>> bool(np.allclose(predicted_measurements(model, q[:, :2], poses), poses))  # the machine's own poses
    True
    """
    model = as_model(model)
    refuse_actuation_redundancy(model, "calibration (its predicted measurements)")
    theta, measured, columns = _inputs(model, theta, measured, measure)
    if offsets is not None:
        offsets = as_batch("offsets", offsets, model.n_actuators, single=True)[0][0]
        theta = theta + offsets
    q = _start_configurations(model, theta, measured, columns)
    return mm.pose_of(model, q)[:, columns]


def calibration_jacobian(model, theta, measured, *, measure: str = "position", names=None) -> np.ndarray:
    """The Jacobian (N·m, p) of the predicted measurements of the poses at readings ``theta`` (N, n) with respect
    to the parameters ``names`` (default every :func:`geometric_parameters`), each in units of its scale (the
    machine's size, or a radian): what :func:`calibrate` and :func:`select_poses` analyse.

    Parameters
    ----------
    model : MechanismModel
        The machine as described (:func:`pkmlab.load`): the Jacobian is at its nominal geometry.
    theta : array_like, shape (N, n_actuators)
        The actuators' readings at each pose (rad, or m for a prismatic actuator).
    measured : array_like, shape (N, m) or (N, dof)
        The measured tracked point (``measure="position"``, m) or whole pose (``"pose"``, m and rad) at each:
        what chooses the assembly mode.
    measure : {"position", "pose"}
        What the instrument measures (``m`` coordinates per pose).
    names : sequence of str, optional
        The parameters (default every :func:`geometric_parameters`).

    Returns
    -------
    ndarray, shape (N * m, p)
        Row ``k * m + i``: measured coordinate ``i`` of pose ``k`` (m, or rad), per unit of each parameter's
        scale.

    Raises
    ------
    InvalidParameterError
        For a name that is not a geometric parameter, readings that do not assemble the machine, or arguments
        whose shapes do not agree.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> from pkmlab.algorithms.calibration import calibration_jacobian, reachable_poses
    >>> model = pkmlab.load("five_bar")
    >>> poses, q = reachable_poses(model, 8, np.random.default_rng(1))
    >>> jac = calibration_jacobian(model, q[:, :2], poses)
    >>> jac.shape, int(np.linalg.matrix_rank(jac, tol=1e-6 * np.linalg.norm(jac, 2)))  # 10 of 14 determined
    ((16, 14), 10)
    """
    model = as_model(model)
    refuse_actuation_redundancy(model, "calibration (its Jacobian)")
    theta, measured, columns = _inputs(model, theta, measured, measure)
    return _nominal_jacobian(model, _names(model, names), theta, measured, columns)


def _nominal_jacobian(model: MechanismModel, names, theta, measured, columns) -> np.ndarray:
    """:func:`calibration_jacobian` of checked inputs."""
    q = _start_configurations(model, theta, measured, columns)
    predictor = _Predictor(model, names, theta, q, columns)
    return _jacobian(predictor, _nominal(model, names), _scales(model, names))


def _names(model: MechanismModel, names) -> tuple[str, ...]:
    """The parameters to calibrate: ``names`` checked against :func:`geometric_parameters` (default all)."""
    every = geometric_parameters(model)
    if names is None:
        return every
    names = tuple(names)
    for n in names:
        if n not in every:
            raise InvalidParameterError(f"no geometric parameter {n!r} (pkmlab.geometric_parameters: "
                                        f"{', '.join(every[:6])}, ...)")
    return names


def _nominal(model: MechanismModel, names) -> np.ndarray:
    index = {n: i for i, n in enumerate(model.kernels.PARAMETERS)}
    return np.array([0.0 if n.startswith("offset") or _is_angle(n) else model.P[index[n]] for n in names])


def _jacobian(predictor: _Predictor, p: np.ndarray, scales: np.ndarray) -> np.ndarray:
    base = predictor(p).ravel()
    J = np.empty((base.size, p.size))
    for i in range(p.size):
        step = STEP * scales[i]
        dp = p.copy()
        dp[i] += step
        J[:, i] = (predictor(dp).ravel() - base) / STEP  # per unit of scale
    return np.nan_to_num(J, nan=0.0)  # a pose that does not assemble tells nothing about its neighbourhood


def _inputs(model: MechanismModel, theta, measured, measure: str):
    measure = as_choice("measure", measure, ("position", "pose"))
    theta, _ = as_batch("theta", theta, model.n_actuators)
    columns = _measured_columns(model, measure)
    dof = model.description.dof
    width = np.shape(measured)[-1] if np.ndim(measured) == 2 else 0
    if width == dof:
        measured = as_batch("measured", measured, dof)[0]
    elif width == len(columns):
        short = as_batch("measured", measured, len(columns))[0]
        measured = np.full((len(short), dof), np.nan)
        measured[:, columns] = short
    else:
        what = "pose" if measure == "pose" else "tracked point"
        raise InvalidParameterError(f"measured must be one row per pose of the {what} "
                                    f"({', '.join(model.pose_names[c] for c in columns)}), got shape "
                                    f"{np.shape(measured)}")
    if len(measured) != len(theta):
        raise InvalidParameterError(f"measured has {len(measured)} poses but theta {len(theta)}: one each")
    m = model.description
    if m.redundancy_names:  # a kinematically redundant machine's base actuators: their readings are their values
        measured = measured.copy()
        measured[:, [model.pose_names.index(n) for n in m.redundancy_names]] = theta[:, list(m.redundancy_actuators)]
    return theta, measured, columns


@dataclass(frozen=True)
class Calibration:
    """A calibrated geometry (:func:`calibrate`).

    Attributes
    ----------
    names : tuple of str
        Every parameter considered (:func:`geometric_parameters`).
    nominal, estimate : ndarray, shape (p,)
        Their described and calibrated values (m; rad or m for an offset; rad from the described axis, 0, for a
        turn of an axis); fixed ones are equal.
    sigma : ndarray, shape (p,)
        The estimate's standard deviations (0 for a fixed parameter).
    fixed : tuple of str
        The parameters the poses do not determine, kept as described.
    singular_values : ndarray
        Of the scaled Jacobian of the identified parameters at the solution.
    observability : float
        Borm and Menq's O1 of those.
    rms_before, rms_after : float
        The RMS of the measured coordinates' residuals with the described and the calibrated geometry.
    residual : ndarray, shape (N, m)
        The residuals after calibration.
    model : MechanismModel
        The calibrated machine (offsets are the actuators', not the description's: add them to the readings).
    aliases : dict
        Each fixed parameter as the identified ones it cannot be told from: ``{fixed: {identified: c}}``, a change
        ``d`` of the fixed one moving the predictions as changes ``c d`` of those (each in its own unit; terms
        below 1e-3 of the largest left out; empty: it moves no measured coordinate at all).
    """

    names: tuple[str, ...]
    nominal: np.ndarray
    estimate: np.ndarray
    sigma: np.ndarray
    fixed: tuple[str, ...]
    singular_values: np.ndarray
    observability: float
    rms_before: float
    rms_after: float
    residual: np.ndarray
    model: MechanismModel
    aliases: dict = field(default_factory=dict)

    @property
    def offsets(self) -> np.ndarray:
        """The actuators' zero offsets (n_actuators,): ``θ_true = θ_read + offsets``."""
        return np.array([e for n, e in zip(self.names, self.estimate, strict=True) if n.startswith("offset")])

    def error(self) -> np.ndarray:
        """``estimate - nominal`` (p,)."""
        return self.estimate - self.nominal

    def summary(self) -> dict:
        rows = [{"name": n, "nominal": float(a), "estimate": float(e), "sigma": float(s), "fixed": n in self.fixed}
                for n, a, e, s in zip(self.names, self.nominal, self.estimate, self.sigma, strict=True)]
        return {"parameters": rows, "fixed": list(self.fixed), "aliases": self.aliases,
                "observability_O1": self.observability, "singular_values": self.singular_values.tolist(),
                "condition_number": float(self.singular_values[0] / self.singular_values[-1]),
                "rms_before": self.rms_before, "rms_after": self.rms_after, "poses": int(self.residual.shape[0])}


def _independent(J: np.ndarray) -> np.ndarray:
    """The columns of ``J`` a QR factorisation with pivoting finds independent (sorted)."""
    from scipy.linalg import qr

    norms = np.linalg.norm(J, axis=0)
    live = np.flatnonzero(norms > RANK_TOL * max(norms.max(), 1e-300))
    if live.size == 0:
        return live
    _q, r, pivots = qr(J[:, live], mode="economic", pivoting=True)
    diag = np.abs(np.diag(r))
    rank = int(np.sum(diag > RANK_TOL * diag[0]))
    return np.sort(live[pivots[:rank]])


def _aliases(J: np.ndarray, keep: np.ndarray, names, scales: np.ndarray) -> dict:
    """:attr:`Calibration.aliases` from the scaled Jacobian ``J`` and the identified columns ``keep``."""
    out = {}
    for i in sorted(set(range(len(names))) - set(keep.tolist())):
        if not np.linalg.norm(J[:, i]) > RANK_TOL * max(np.linalg.norm(J, 2), 1e-300):
            out[names[i]] = {}
            continue
        c = np.linalg.lstsq(J[:, keep], J[:, i], rcond=None)[0] * scales[keep] / scales[i]
        big = np.abs(c) > 1e-3 * np.abs(c).max()
        out[names[i]] = {names[k]: float(v) for k, v, b in zip(keep, c, big, strict=True) if b}
    return out


def with_geometry(model, values: dict) -> MechanismModel:
    """``model`` with some of its geometric parameters (:func:`geometric_parameters`, offsets excepted) set to
    ``values`` ({name: value}: a point's coordinate in m, an axis's turn from the described one in rad): a
    machine as built rather than as drawn.

    Parameters
    ----------
    model : MechanismModel
        The machine as described (:func:`pkmlab.load`).
    values : dict
        ``{name: value}``: a point's coordinate (m) or an axis's turn from the described one (rad); the
        parameters not named keep their described values.

    Returns
    -------
    MechanismModel
        The machine with that geometry (its inertias unchanged).

    Raises
    ------
    InvalidParameterError
        If ``values`` is not a dict, names something that is not a geometric parameter (or an actuator's
        offset), or gives a value that is not a finite number.

    Examples
    --------
    >>> import pkmlab
    >>> model = pkmlab.load("five_bar")
    >>> float(with_geometry(model, {"base1_x": -0.26}).P[model.kernels.PARAMETERS.index("base1_x")])
    -0.26
    """
    model = as_model(model)
    if not isinstance(values, dict):
        raise InvalidParameterError(f"values must be a dict {{name: value}}, got {type(values).__name__}")
    known = set(geometric_parameters(model))
    for name, value in values.items():
        if name not in known or str(name).startswith("offset"):
            raise InvalidParameterError(f"{name!r} is not a geometric parameter of this machine (offsets are the "
                                        "actuators', not the description's)")
        if isinstance(value, bool) or not isinstance(value, (int, float, np.floating)) or not np.isfinite(value):
            raise InvalidParameterError(f"{name} must be a finite number ({'rad' if _is_angle(name) else 'm'}), "
                                        f"got {value!r}")
    return MechanismModel.from_description(_with_geometry(model, values))


def perturbed_geometry(model, rng, size: float = 1e-3, angle: float = float(np.deg2rad(0.5))
                       ) -> tuple[MechanismModel, np.ndarray]:
    """A machine built with errors: every point's coordinate moved by a uniform draw in ``[-size, size]`` (m),
    every axis turned by draws in ``[-angle, angle]`` (rad), and actuator zero offsets drawn in
    ``[-angle, angle]`` (rad; ``[-size, size]`` for a prismatic actuator).

    Returns the machine and its offsets ``δ`` (n_actuators,): its readings are ``θ_read = θ_true - δ``.
    Draws the parameters in :func:`geometric_parameters`' order, then the offsets.

    Parameters
    ----------
    model : MechanismModel
        The machine as described (:func:`pkmlab.load`).
    rng : numpy.random.Generator
        The source of the draws (``np.random.default_rng(seed)``: the same seed, the same machine).
    size : float
        The largest error of a point's coordinate (m), and of a prismatic actuator's offset.
    angle : float
        The largest turn of an axis and offset of a revolute actuator (rad; default 0.5°).

    Returns
    -------
    built : MechanismModel
        The machine as built.
    offsets : ndarray, shape (n_actuators,)
        Its actuators' zero offsets ``δ`` (rad, or m for a prismatic actuator).

    Raises
    ------
    InvalidParameterError
        If ``rng`` is not a ``numpy.random.Generator`` or ``size`` or ``angle`` is negative.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> from pkmlab.algorithms.calibration import perturbed_geometry
    >>> model = pkmlab.load("five_bar")
    >>> built, offsets = perturbed_geometry(model, np.random.default_rng(0), size=1e-3)
    >>> i = model.kernels.PARAMETERS.index("base1_x")
    >>> bool(abs(built.P[i] - model.P[i]) <= 1e-3), offsets.shape, bool(np.all(np.abs(offsets) <= np.deg2rad(0.5)))
    (True, (2,), True)
    """
    from .._validate import as_real

    model = as_model(model)
    if not isinstance(rng, np.random.Generator):
        raise InvalidParameterError(f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got "
                                    f"{type(rng).__name__}")
    size, angle = as_real("size", size, "non-negative"), as_real("angle", angle, "non-negative")
    index = {n: i for i, n in enumerate(model.kernels.PARAMETERS)}
    values = {n: float(rng.uniform(-angle, angle)) if _is_angle(n) else float(model.P[index[n]]
                                                                              + rng.uniform(-size, size))
              for n in geometric_parameters(model) if not n.startswith("offset")}
    revolute = np.array([k == "R" for k in model.description.actuator_kinds])
    offsets = np.where(revolute, angle, size) * rng.uniform(-1, 1, model.n_actuators)
    return with_geometry(model, values), offsets


#: The most draws :func:`reachable_poses` tries per pose it returns before giving up.
TRIES_PER_POSE = 200


def reachable_poses(model, count: int, rng, *, span: float = 0.1, turn: float = 0.3, margin: float = 0.05,
                    mode=None) -> tuple[np.ndarray, np.ndarray]:
    """``count`` poses drawn uniformly about the home configuration of a working mode — within ``span`` of the
    machine's size (:func:`~pkmlab.algorithms.kinematics.length_scale`) in position and ``turn`` rad in
    orientation —, kept where the inverse kinematics has a solution with ``|S|`` above ``margin``: the candidate
    measurement poses of a calibration.

    Returns the poses (count, dof) and their configurations (count, n) in ``mode`` (default the first working
    mode); the actuators are their first ``n_actuators`` columns.

    Parameters
    ----------
    model : MechanismModel
        The machine (:func:`pkmlab.load`).
    count : int
        How many poses (at least 1).
    rng : numpy.random.Generator
        The source of the draws (``np.random.default_rng(seed)``).
    span : float
        The half-width of the region in each position coordinate, as a share of the machine's size
        (dimensionless, positive).
    turn : float
        The half-width of the region in each orientation coordinate (rad).
    margin : float
        The least ``|S|`` (dimensionless) of a pose kept.
    mode : sequence of signs, optional
        The working mode (default the machine's first).

    Returns
    -------
    poses : ndarray, shape (count, dof)
        The poses (m, and rad for an orientation).
    configurations : ndarray, shape (count, n)
        Their configurations on the loop closure in ``mode`` (rad or m per entry).

    Raises
    ------
    InvalidParameterError
        If fewer than ``count`` poses are found in ``TRIES_PER_POSE * count`` draws (a smaller region or margin),
        or an argument has the wrong type or value.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> from pkmlab.algorithms.calibration import reachable_poses
    >>> model = pkmlab.load("five_bar")
    >>> poses, q = reachable_poses(model, 8, np.random.default_rng(1))
    >>> poses.shape, q.shape, bool(np.allclose(q[:, -2:], poses))  # the pose is the configuration's last entries
    ((8, 2), (8, 6), True)
    >>> bool(np.all(np.abs(pkmlab.singularity_measure(model, q)) > 0.05))
    True
    """
    from .._validate import as_real
    from .kinematics import as_working_mode

    model = as_model(model)
    refuse_actuation_redundancy(model, "calibration (its reachable poses)")
    count = as_count("count", count, 1)
    span, turn = as_real("span", span, "positive"), as_real("turn", turn, "non-negative")
    margin = as_real("margin", margin, "non-negative")
    if not isinstance(rng, np.random.Generator):
        raise InvalidParameterError(f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), got "
                                    f"{type(rng).__name__}")
    mode = mm.working_modes(model)[0] if mode is None else as_working_mode(model, mode, "mode")
    centre = mm.pose_of(model, mm.well_conditioned_configuration(model, mode))
    # a kinematically redundant machine's base actuators by their kind: a slide as a position
    m = model.description
    lengths = ("x", "y", "z", *(name for name, k in zip(m.redundancy_names, m.redundancy_actuators, strict=True)
                                if m.actuator_kinds[k] == "P"))
    scale = np.array([span * length_scale(model) if n in lengths else turn for n in model.pose_names])
    poses, configurations = [], []
    for _ in range(TRIES_PER_POSE * count):
        if len(poses) == count:
            break
        pose = centre + rng.uniform(-1, 1, len(centre)) * scale
        try:
            q = mm.inverse_kinematics(model, pose, mode)
        except PkmlabError:
            continue
        if abs(mm.singularity_measure(model, q)) > margin:
            poses.append(pose)
            configurations.append(q)
    if len(poses) < count:
        raise InvalidParameterError(f"only {len(poses)} of {count} poses drawn within span {span:g} and turn "
                                    f"{turn:g} are reachable with |S| > {margin:g}: a smaller region or margin")
    return np.array(poses), np.array(configurations)


def _with_geometry(model: MechanismModel, values: dict):
    """``model``'s description with the geometric parameters ``values`` (name: value) written into its fields."""
    description = model.description

    def point(old, prefix):
        return tuple(values.get(f"{prefix}_{c}", v) for c, v in zip("xyz", old, strict=False))

    joints = {}  # (leg, joint): the joint with its axes turned
    for turn in _axis_turns(model):
        if not any(n in values for n in turn.names):
            continue
        turns = _turned(turn, values)
        rot = turn.rotation(turns) if turn.basis is not None else None
        for k in turn.joints:
            joint = description.legs[turn.leg].joints[k]
            if rot is None:
                joints[turn.leg, k] = replace(joint, axis=float(joint.axis + turns[0]))
            else:
                joints[turn.leg, k] = replace(joint, axes=tuple(tuple(float(c) for c in rot @ np.array(a))
                                                                for a in joint.axes))
    legs = []
    for i, leg in enumerate(description.legs):
        bodies = tuple(replace(b, tip=point(b.tip, f"body{i + 1}_{k + 1}_tip")) for k, b in enumerate(leg.bodies))
        legs.append(replace(leg, base=point(leg.base, f"base{i + 1}"), bodies=bodies,
                            joints=tuple(joints.get((i, k), j) for k, j in enumerate(leg.joints))))
    p = description.platform
    attachments = tuple(point(a, f"attach{i + 1}") for i, a in enumerate(p.attachments))
    return replace(description, legs=tuple(legs), platform=replace(p, attachments=attachments))


def calibrate(model, theta, measured, *, measure: str = "position", names=None, max_iterations: int = 50
              ) -> Calibration:
    """The geometry of ``model`` calibrated from actuator readings and external measurements (the module's text).

    Parameters
    ----------
    model : MechanismModel
        The machine as described (the nominal geometry, the start).
    theta : array_like, shape (N, n_actuators)
        The actuators' readings at each measured pose.
    measured : array_like, shape (N, 2 or 3) or (N, dof)
        The measured tracked point (``measure="position"``) or whole pose (``"pose"``) at each.
    measure : {"position", "pose"}
        What the instrument measures.
    names : sequence of str, optional
        The parameters to calibrate (default every :func:`geometric_parameters`).
    max_iterations : int
        Of the least-squares solver (in Jacobian evaluations).

    Returns
    -------
    Calibration

    Raises
    ------
    InvalidParameterError
        For poses that cannot determine anything, readings that do not assemble the machine, or fewer measured
        coordinates than parameters to identify.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> from pkmlab.algorithms.calibration import calibrate, perturbed_geometry, predicted_measurements, reachable_poses
    >>> model = pkmlab.load("five_bar")
    >>> built, offsets = perturbed_geometry(model, np.random.default_rng(0))  # the machine as built
    >>> poses, q = reachable_poses(built, 12, np.random.default_rng(1))  # measured exactly
    >>> theta = q[:, :2] - offsets  # what its actuators read
    >>> result = calibrate(model, theta, poses)
    >>> bool(result.rms_before > 1e-4 and result.rms_after < 1e-12), result.fixed
    (True, ('body1_2_tip_y', 'body2_2_tip_y', 'offset1', 'offset2'))
    >>> predicted = predicted_measurements(result.model, theta, poses, offsets=result.offsets)
    >>> bool(np.allclose(predicted, poses, atol=1e-12))
    True
    """
    from scipy.optimize import least_squares

    model = as_model(model)
    refuse_actuation_redundancy(model, "calibration")
    names = _names(model, names)
    max_iterations = as_count("max_iterations", max_iterations, 1, 10_000)
    theta, measured, columns = _inputs(model, theta, measured, measure)
    q = _start_configurations(model, theta, measured, columns)
    predictor = _Predictor(model, names, theta, q, columns)
    target = measured[:, columns].ravel()
    nominal, scales = _nominal(model, names), _scales(model, names)
    before = predictor(nominal).ravel() - target
    _check_units(model, before)
    J = _jacobian(predictor, nominal, scales)
    keep = _independent(J)
    if keep.size == 0:
        raise InvalidParameterError("the poses determine none of the parameters: measure poses that move the "
                                    "platform in the measured coordinates")
    if target.size <= keep.size:
        raise InvalidParameterError(f"too few measurements: {target.size} measured coordinates for {keep.size} "
                                    "identifiable parameters; measure more poses")

    best = [np.inf]

    def residual(x):
        p = nominal.copy()
        p[keep] = nominal[keep] + x * scales[keep]
        r = predictor(p).ravel() - target
        r = np.where(np.isfinite(r), r, 1.0)  # a pose that no longer assembles: far off
        if r @ r < best[0]:
            best[0] = float(r @ r)
            predictor.accept()
        return r

    def jacobian(x):
        p = nominal.copy()
        p[keep] = nominal[keep] + x * scales[keep]
        return _jacobian(predictor, p, scales)[:, keep]

    solution = least_squares(residual, np.zeros(keep.size), jac=jacobian, method="lm",
                             max_nfev=max_iterations * (keep.size + 1))
    if solution.status == 0:
        raise PkmlabError(f"the calibration did not converge in max_iterations = {max_iterations} (RMS residual "
                          f"{np.sqrt(best[0] / target.size):.3g}, from {np.sqrt(np.nanmean(before**2)):.3g}): more "
                          "iterations, or poses nearer the described machine's")
    estimate = nominal.copy()
    estimate[keep] = nominal[keep] + solution.x * scales[keep]
    after = residual(solution.x)
    Jk = jacobian(solution.x)
    dof_res = max(target.size - keep.size, 1)
    s2 = float(after @ after) / dof_res
    sigma = np.zeros(len(names))
    sigma[keep] = np.sqrt(np.clip(np.diag(np.linalg.pinv(Jk.T @ Jk)), 0.0, None) * s2) * scales[keep]
    singular = np.linalg.svd(Jk, compute_uv=False)
    o1 = float(np.exp(np.mean(np.log(singular))) / np.sqrt(len(theta)))
    values = {n: e for n, e in zip(names, estimate, strict=True) if not n.startswith("offset")}
    calibrated = MechanismModel.from_description(_with_geometry(model, values))
    fixed = tuple(n for i, n in enumerate(names) if i not in set(keep.tolist()))
    return Calibration(names, nominal, estimate, sigma, fixed, singular, o1, float(np.sqrt(np.mean(before**2))),
                       float(np.sqrt(np.mean(after**2))), after.reshape(len(theta), -1), calibrated,
                       _aliases(J, keep, names, scales))


def _check_units(model: MechanismModel, before: np.ndarray) -> None:
    """Measurements farther from the described machine's predictions than the machine's size are not of it in
    metres and radians (millimetres, degrees, another machine): refused before anything is fitted to them."""
    size = length_scale(model)
    finite = before[np.isfinite(before)]
    gap = float(np.sqrt(np.mean(finite**2))) if finite.size else math.inf
    if gap > size:
        raise InvalidParameterError(f"the measurements are {gap:.3g} (RMS) from where the described machine puts "
                                    f"them, more than its size ({size:.3g} m): are they in metres and radians, and "
                                    "of this machine?")


def select_poses(model, theta_candidates, measured_candidates, count: int, *, measure: str = "position",
                 names=None) -> np.ndarray:
    """The indices of ``count`` candidate poses that maximise ``log det(Jᵀ J)`` of the identifiable parameters
    (D-optimality), chosen greedily: each next pose the one that raises it most.

    ``theta_candidates`` (M, n) and ``measured_candidates`` (M, ·) as for :func:`calibrate` (the nominal
    machine's poses, e.g. from its inverse kinematics at poses spread over its workspace).

    Parameters
    ----------
    model : MechanismModel
        The machine as described (:func:`pkmlab.load`).
    theta_candidates : array_like, shape (M, n_actuators)
        The actuators' values at each candidate pose (rad, or m for a prismatic actuator).
    measured_candidates : array_like, shape (M, m) or (M, dof)
        The tracked point (``measure="position"``, m) or whole pose (``"pose"``, m and rad) at each.
    count : int
        How many poses to choose (1 to M).
    measure : {"position", "pose"}
        What the instrument measures.
    names : sequence of str, optional
        The parameters to calibrate (default every :func:`geometric_parameters`).

    Returns
    -------
    ndarray of int, shape (count,)
        The chosen candidates' indices, in the order chosen.

    Raises
    ------
    InvalidParameterError
        If ``count`` poses measure too few coordinates for the identifiable parameters, a name is not a geometric
        parameter, or the arguments' shapes do not agree.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> from pkmlab.algorithms.calibration import reachable_poses, select_poses
    >>> model = pkmlab.load("five_bar")
    >>> poses, q = reachable_poses(model, 8, np.random.default_rng(1))
    >>> chosen = select_poses(model, q[:, :2], poses, 6)
    >>> chosen.shape, len(set(chosen.tolist()))
    ((6,), 6)
    """
    model = as_model(model)
    refuse_actuation_redundancy(model, "calibration (its choice of poses)")
    theta, measured, columns = _inputs(model, theta_candidates, measured_candidates, measure)
    count = as_count("count", count, 1, len(theta))
    J = _nominal_jacobian(model, _names(model, names), theta, measured, columns)
    m = len(columns)
    keep = _independent(J)
    rows = J[:, keep].reshape(len(theta), m, keep.size)
    chosen: list[int] = []
    information = np.eye(keep.size) * 1e-9  # a start that makes the first choices' determinants comparable
    for _ in range(count):
        inverse = np.linalg.inv(information)
        # det(A + Bᵀ B) / det(A) = det(1 + B A⁻¹ Bᵀ) per candidate B (m, r)
        gain = np.linalg.slogdet(np.eye(m) + rows @ inverse @ np.swapaxes(rows, 1, 2))[1]
        gain[chosen] = -np.inf
        k = int(np.argmax(gain))
        chosen.append(k)
        information = information + rows[k].T @ rows[k]
    if len(chosen) * m <= keep.size:
        raise InvalidParameterError(f"{count} poses measure {count * m} coordinates, not enough for {keep.size} "
                                    f"parameters: choose at least {keep.size // m + 1}")
    return np.array(chosen)
