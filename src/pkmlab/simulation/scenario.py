"""A scenario: the plain value a simulation runs — the controller's model of the machine, the plant (the real
machine, possibly different), the trajectory, the controller and its gains, the sample time — and the
machines derived from a model for one (scaled, perturbed), and the working mode chosen for its path.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from .._format import apart
from .._validate import as_count, as_real
from ..algorithms.kinematics import as_working_mode
from ..control.controller import (
    ControllerSpec,
)
from ..errors import (
    InvalidParameterError,
    SingularityError,
    UnreachablePoseError,
    shown,
)
from ..model.mechanism_model import MechanismModel
from .realism import Drives, Sensors, check_sizes

#: A scenario of more samples than this is refused. Memory: a three-legged machine's sampled-data run keeps 184 bytes
#: per sample (its result: ``t``, ``q``, the rates, efforts, ``S``, the desired actuators and poses; the pose is a
#: view of ``q``) and makes its desired motion a piece at a time, the CSV written a chunk at a time (``make bench``:
#: ``memory_*``, 186 bytes per sample beyond a fixed base): about 1.9 GB at the cap; sensors add 48 bytes per sample
#: (the readings and their rates), each source of noise 24.
MAX_SAMPLES = 10_000_000


#: Runge–Kutta steps per sample at most (as in scenario files).
MAX_SUBSTEPS = 1000


@dataclass(frozen=True)
class Scenario:
    """Everything that defines one closed-loop run: the plain value :func:`~pkmlab.simulate` takes.

    Every field is checked when the scenario is made (and again by :meth:`replace`); the working mode is
    stored as ``"auto"`` or a tuple of ints.

    Parameters
    ----------
    model : MechanismModel
        The controller's model of the machine (``pkmlab.load("paper")``, any preset or description),
        used for inverse kinematics, the pre-flight check and computed torque.
    trajectory : Trajectory-like
        Gives ``desired(t) -> (pose, pose_dot, pose_ddot)`` (m, rad and their rates) and ``duration`` (s).
    plant : MechanismModel or None
        The real machine, of the model's structure with other numbers; ``None`` means identical to ``model``.
    controller : ControllerSpec
        The control law and its gains (default computed torque, ``kp = 1000``).
    sample_time : float
        ``Ts`` in s (default 1e-3); ``0`` selects continuous-time control.
    working_mode : "auto" or signs
        ``"auto"`` picks the mode maximising ``min |S|`` along the path (conventions §3); else one sign
        per two-branch leg (``"+-+"``, ``(1, -1, 1)``...), stored as a tuple of ints.
    singularity_margin : float
        Paths with ``min |S|`` below this in every admissible mode are refused before simulating (default 0.05).
    singularity_guard : float
        A run stops with an error when the plant's ``|S|`` falls below this (default 0.01).
    substeps : int
        Runge–Kutta steps per sample for the plant (sampled-data control), 1 to :data:`MAX_SUBSTEPS`.
    name : str
        The run's name (a scenario file's stem).
    drives : Drives or None
        The plant's drives: gear, armature, friction, effort limit and noise (:mod:`~pkmlab.simulation.realism`);
        None for ideal drives. Continuous-time control takes smooth friction (``coulomb_rate > 0``, no
        ``stick_slip``) and no effort noise.
    sensors : Sensors or None
        What the controller measures: quantised, noisy, delayed actuator values; None for the plant's exact
        state. Sampled-data control only.
    seed : int
        The seed of the drives' and sensors' noise (non-negative).
    controller_drives : Drives or None
        The controller's model of the drives (e.g. identified): computed torque adds ``Ia v + fv θ̇ + fc φ(θ̇)``
        (``v`` the acceleration it commands) at the rates it uses; its effort limit and noise are not used. None:
        no compensation. Computed torque only.

    Raises
    ------
    InvalidParameterError
        If a field has the wrong type or value: a model that is not a :class:`MechanismModel`, a plant of another
        structure, a trajectory without ``desired`` and a positive ``duration``, poses of the wrong dimension, a
        working mode the machine does not have, sensors or non-smooth friction with continuous-time control,
        ``substeps`` other than 1 with continuous-time control, or a number of samples outside 1 to
        :data:`MAX_SAMPLES`.

    Examples
    --------
    >>> import pkmlab
    >>> from pkmlab.control.trajectory import paper_trajectory
    >>> scenario = pkmlab.Scenario(pkmlab.load("paper"), paper_trajectory(0.4), name="fast")
    >>> scenario.sample_time, scenario.controller.kind, scenario.working_mode
    (0.001, 'computed_torque', 'auto')
    >>> scenario.replace(sample_time=2e-3, working_mode="-+-").working_mode
    (-1, 1, -1)
    """

    model: MechanismModel
    trajectory: object
    plant: MechanismModel | None = None
    controller: ControllerSpec = field(default_factory=ControllerSpec)
    sample_time: float = 1e-3
    working_mode: object = "auto"
    singularity_margin: float = 0.05
    singularity_guard: float = 0.01
    substeps: int = 1
    name: str = "scenario"
    drives: Drives | None = None
    sensors: Sensors | None = None
    seed: int = 0
    controller_drives: Drives | None = None

    def __post_init__(self):
        set_ = object.__setattr__  # a frozen dataclass: the normalised values are stored so
        check_model(self.model, "model")
        if self.plant is not None:
            check_model(self.plant, "plant")
            if self.plant.kernels is not self.model.kernels:
                raise InvalidParameterError(f"the plant ({self.plant.description.notation}) must have the structure "
                                            f"of the controller's model ({self.model.description.notation}): only "
                                            "its numbers may differ")
        if not callable(getattr(self.trajectory, "desired", None)):
            raise InvalidParameterError(
                "trajectory must be a Trajectory or WaypointTrajectory (an object with desired(t) and duration), "
                f"got {type(self.trajectory).__name__} {shown(self.trajectory, 50)}"
            )
        duration = as_real("trajectory duration", getattr(self.trajectory, "duration", None), "positive")
        if not isinstance(self.controller, ControllerSpec):
            raise InvalidParameterError(f"controller must be a ControllerSpec, got {type(self.controller).__name__} "
                                        f"{shown(self.controller, 50)}")
        set_(self, "sample_time", as_real("sample_time", self.sample_time, "non-negative"))
        set_(self, "substeps", as_count("substeps", self.substeps, 1, MAX_SUBSTEPS))
        for name, kind in (("drives", Drives), ("sensors", Sensors), ("controller_drives", Drives)):
            value = getattr(self, name)
            if value is not None and not isinstance(value, kind):
                raise InvalidParameterError(f"{name} must be a {kind.__name__} or None, got {type(value).__name__} "
                                            f"{shown(value, 50)}")
        check_sizes(self.drives, self.sensors, self.model.n_actuators)
        check_sizes(self.controller_drives, None, self.model.n_actuators)
        if self.controller_drives is not None and self.controller.kind != "computed_torque":
            raise InvalidParameterError(f"controller_drives are computed torque's model of the drives; a "
                                        f"{self.controller.kind} controller has no model to add them to")
        set_(self, "seed", as_count("seed", self.seed, 0))
        if self.sample_time == 0:
            _check_continuous_realism(self.drives, self.sensors)
        if self.model.description.actuation_redundancy > 0:
            _check_redundant_run(self)
        elif self.controller.distribution != "minimum_norm":
            raise InvalidParameterError(f"controller distribution '{self.controller.distribution}' shares efforts "
                                        f"among more actuators than degrees of freedom; {self.model.name} has as many "
                                        "as its degrees of freedom, whose efforts are one solution")
        for name in ("singularity_margin", "singularity_guard"):
            set_(self, name, as_real(name, getattr(self, name), "non-negative"))
        _check_pose_dimension(self.model, self.trajectory)
        set_(self, "working_mode", as_working_mode(self.model, self.working_mode))
        if not isinstance(self.name, str):
            raise InvalidParameterError(f"name must be a string, got {shown(self.name)}")
        if self.sample_time == 0 and self.substeps != 1:
            raise InvalidParameterError(f"substeps = {self.substeps} applies to sampled-data control only, but "
                                        "sample_time = 0 selects continuous-time control")
        samples = duration / (self.sample_time or 1e-3)
        if not 1 <= samples <= MAX_SAMPLES:
            count, limit = apart(samples, 1 if samples < 1 else MAX_SAMPLES)
            raise InvalidParameterError(f"sample_time = {self.sample_time:g} s gives {count} samples over the "
                                        f"trajectory's {duration:.4g} s: from 1 to {MAX_SAMPLES} are allowed"
                                        + ("" if samples < 1 else f" (the limit is {limit})"))

    @property
    def plant_model(self) -> MechanismModel:
        """The plant's model: ``plant``, or ``model`` where ``plant`` is None."""
        return self.model if self.plant is None else self.plant

    def replace(self, **changes) -> Scenario:
        """A copy with some fields changed (validated again).

        Parameters
        ----------
        **changes
            New values of fields, by name.

        Returns
        -------
        Scenario

        Raises
        ------
        InvalidParameterError
            If a name is not a field, or a value is refused (as when a scenario is made).

        Examples
        --------
        >>> import pkmlab
        >>> pkmlab.paper_scenario("nominal").replace(sample_time=5e-4).sample_time
        0.0005
        """
        for name in changes:
            if name not in self.__dataclass_fields__:
                raise InvalidParameterError(f"{name} is not a field of Scenario "
                                            f"(fields: {', '.join(self.__dataclass_fields__)})")
        return replace(self, **changes)


def _check_redundant_run(scenario: Scenario) -> None:
    """Refuse, in one line, what a redundantly actuated machine's run does not model: its loop is in the controlled
    pose (the compiled core's independent coordinates), its controller reads the plant's pose (or estimates it from
    its actuators' readings) and distributes its efforts over the actuators, and its drives act at the actuators,
    where stick-slip friction would hold an actuator by a constraint on the pose: refused. The least peak and the
    effort limits move the efforts along the machine's internal effort: with more than one, they are refused."""
    model = scenario.model
    what = (f"{model.name} has {model.n_actuators} actuators for its {model.dof} degrees of freedom (redundant "
            "actuation)")
    spec = scenario.controller
    for name in ("weights", "preload"):
        value = getattr(spec, name)
        if value is not None and len(value) != model.n_actuators:
            raise InvalidParameterError(f"controller {name} must be {model.n_actuators} numbers, one per actuator of "
                                        f"{model.name}, got {len(value)}")
    drives = scenario.drives
    internal = model.description.actuation_redundancy
    if internal > 1:  # the loop's least peak and its limits move the efforts along one internal effort
        if spec.distribution == "minimum_peak":
            raise InvalidParameterError(f"{what}: the least peak is solved in a run for one internal effort, and it "
                                        f"has {internal}; use 'minimum_norm', 'weighted' or 'preload' "
                                        "(pkmlab.distribute_efforts gives the least peak at a pose)")
        if drives is not None and np.isfinite(np.asarray(drives.effort_limit, dtype=float)).any():
            raise InvalidParameterError(f"{what}: its controller holds effort limits for one internal effort, and it "
                                        f"has {internal}; remove effort_limit (pkmlab.distribute_efforts holds them at "
                                        "a pose)")
    if drives is not None and drives.stick_slip:  # (computed torque's model of it is only friction to add)
        raise InvalidParameterError(f"{what}: stick-slip friction of its drives (an actuator held by it constrains "
                                    "the pose's accelerations) is not modelled; give stick_slip = false (smooth or "
                                    "exact-sign Coulomb friction)")


def _check_continuous_realism(drives: Drives | None, sensors: Sensors | None) -> None:
    """Continuous-time control integrates a smooth plant with an adaptive integrator: its drives' friction must be
    smooth, and noise and sensors, drawn or read once per sample, have no samples to belong to."""
    if sensors is not None:
        raise InvalidParameterError("sensors read the plant once per sample: they apply to sampled-data control "
                                    "(give sample_time > 0)")
    if drives is None:
        return
    friction = any(c > 0 for c in np.atleast_1d(drives.coulomb))
    if friction and (drives.stick_slip or drives.coulomb_rate == 0):
        law = "stick-slip" if drives.stick_slip else "exact (coulomb_rate = 0)"
        raise InvalidParameterError(f"continuous-time control integrates a smooth plant; its drives' {law} Coulomb "
                                    "friction switches within a step: give coulomb_rate > 0 without stick_slip, "
                                    "or sample_time > 0")
    if any(v > 0 for v in np.atleast_1d(drives.effort_noise)):
        raise InvalidParameterError("effort_noise is drawn once per sample: it applies to sampled-data control "
                                    "(give sample_time > 0)")


def _check_pose_dimension(model: MechanismModel, trajectory) -> None:
    """The trajectory's poses are the machine's: a spatial machine's path is given in its own coordinates
    (:class:`~pkmlab.control.trajectory.TimedWaypoints` of ``(x, y, z[, roll, pitch, yaw])``); a planar path
    ``(x, y, alpha)`` serves a planar machine."""
    from ..control.trajectory import FourierTrajectory, Spline, TimedWaypoints

    m = model.description
    in_pose = (isinstance(trajectory, TimedWaypoints | Spline | FourierTrajectory)
               or getattr(trajectory, "spatial", False))
    width = trajectory.dimension if in_pose else 3
    spatial = getattr(m, "spatial", False)
    if spatial and not in_pose:
        raise InvalidParameterError(f"the {m.name} is spatial (pose {', '.join(m.pose_names)}): give its path as "
                                    "waypoints or a spline in those coordinates with durations, or a circle of "
                                    "center [x, y, z] (a planar path of (x, y, alpha) does not apply)")
    if getattr(trajectory, "spatial", False) and tuple(m.pose_names[:3]) != ("x", "y", "z"):
        raise InvalidParameterError(f"a circle moves the platform's point in x, y and z, which the {m.name} does not "
                                    f"all control (its pose is {', '.join(m.pose_names)}): give waypoints or a "
                                    "spline")
    if getattr(trajectory, "orientation_path", None) == "geodesic" and tuple(m.pose_names) != (
            "x", "y", "z", "roll", "pitch", "yaw"):
        raise InvalidParameterError(f"orientation_path = \"geodesic\" turns a rigid platform's whole orientation, "
                                    f"which the {m.name} does not control (its pose is {', '.join(m.pose_names)})")
    # a planar path (x, y, alpha) serves a point platform too, whose alpha must then stay 0 (checked on the path)
    if width != m.dof and not (not spatial and m.dof == 2 and width == 3):
        raise InvalidParameterError(f"the trajectory's poses have {width} coordinates, but the {m.name}'s pose is "
                                    f"({', '.join(m.pose_names)})")


def check_model(model, name: str):
    if not isinstance(model, MechanismModel):
        hint = (" (the paper's machine is pkmlab.load('paper'))" if type(model).__name__ == "Planar3RRR" else
                " (e.g. pkmlab.load('paper'), pkmlab.load('five_bar'), pkmlab.load('my_machine.toml'))")
        raise InvalidParameterError(f"{name} must be a MechanismModel{hint}, got {type(model).__name__} "
                                    f"{shown(model, 50)}")


def scaled_model(model: MechanismModel, mass: float = 1.0, length: float = 1.0) -> MechanismModel:
    """A machine whose bodies' masses are ×``mass``, their lengths (tips, mass centres, the platform's
    attachments) ×``length`` and inertias ×``mass·length²`` (I ∝ m L²); the base points, rail directions and
    strokes are unchanged: the paper's disturbed plant (its section 5) for any machine."""
    from ..description.mechanism import scaled_mechanism
    from ..description.spatial import scaled_spatial_mechanism

    check_model(model, "model")
    mass, length = as_real("mass", mass, "positive"), as_real("length", length, "positive")
    scale = scaled_spatial_mechanism if getattr(model.description, "spatial", False) else scaled_mechanism
    return MechanismModel.from_description(scale(model.description, mass, length))


def perturbed_model(model: MechanismModel, rng: np.random.Generator, spread: float = 0.15) -> MechanismModel:
    """A machine whose every body's mass, inertia and lengths are multiplied by its own random factor.

    Each factor is drawn uniformly from ``[1 - spread, 1 + spread]`` — one draw of an uncertainty study. The base
    points are unchanged. The factors are drawn quantity by quantity (lengths, masses, inertias), and within a
    quantity body by body from the base (every leg's first body, then every leg's second...), the platform last.

    Parameters
    ----------
    model : MechanismModel
        The nominal machine.
    rng : numpy.random.Generator
        The random generator (``np.random.default_rng(seed)``; a ``RandomState`` is accepted too).
    spread : float
        The largest relative change, in ``[0, 1)`` (default 0.15: ±15 %).

    Returns
    -------
    MechanismModel
        The perturbed machine, of ``model``'s structure (a plant for :class:`Scenario`).

    Raises
    ------
    InvalidParameterError
        If an argument is refused, or the machine drawn cannot be assembled.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> plant = pkmlab.perturbed_model(pkmlab.load("paper"), np.random.default_rng(0))
    >>> f"{plant.description.platform.mass:.4f}"
    '0.2013'
    """
    check_model(model, "model")
    if not isinstance(rng, (np.random.Generator, np.random.RandomState)):
        raise InvalidParameterError(f"rng must be a numpy.random.Generator (np.random.default_rng(seed)), "
                                    f"got {type(rng).__name__} {shown(rng, 50)}")
    spread = as_real("spread", spread)
    if not 0.0 <= spread < 1.0:
        raise InvalidParameterError(f"spread must be in [0, 1), got {spread!r}")

    from .uncertainty import perturbed_plant

    bodies = [len(leg.bodies) for leg in model.description.legs]
    factors = {}
    for quantity in ("length", "mass", "inertia"):
        for j in range(max(bodies)):
            legs = [i for i, count in enumerate(bodies) if count > j]
            for i, f in zip(legs, rng.uniform(1.0 - spread, 1.0 + spread, len(legs)), strict=True):
                factors[f"leg{i + 1}.body{j + 1}.{quantity}"] = f
        factors[f"platform.{quantity}"] = rng.uniform(1.0 - spread, 1.0 + spread)
    try:
        return perturbed_plant(model, factors)
    except InvalidParameterError as exc:
        raise InvalidParameterError(f"the machine drawn with spread = {spread:g} is impossible: {exc}") from None


# ------------------------------------------------------------------ pre-flight
def choose_working_mode(scenario: Scenario, t: np.ndarray) -> tuple[tuple[int, ...], float]:
    """The working mode of docs/conventions.md §3 and its ``min |S|`` along the desired path at times ``t``.

    Every admissible mode's inverse kinematics along the path: the mode with the largest ``min |S|`` (a tie
    within 1e-9 goes to the first in lexicographic order, ``+1`` before ``-1``). Raises a one-line error naming
    the time and pose where the path leaves the workspace or comes within ``singularity_margin`` of ``S = 0``
    in every admissible mode.
    """
    pose = np.asarray(scenario.trajectory.desired(t)[0], dtype=float)
    mode, min_s, _q = best_working_mode(scenario, t, pose)
    return mode, min_s


def best_working_mode(scenario: Scenario, t: np.ndarray, pose, piece: int | None = None):
    """:func:`choose_working_mode` of the desired poses ``pose`` (N, ≥ dof) at ``t``, and the inverse kinematics
    of the path in that mode (N, n_coordinates), which the desired motion goes on from.

    ``pose`` may instead be a function of a slice of the samples that returns their poses: the path is then taken
    ``piece`` samples at a time and none of it is kept (a long run's memory), and the inverse kinematics returned
    is None unless the path is one piece."""
    from ..model.mechanism_model import (
        checks_platform_joints,
        configuration_measures,
        path_configurations,
        working_modes,
    )

    model = scenario.model
    count = t.size
    step = piece or count
    pieces = [slice(k0, min(count, k0 + step)) for k0 in range(0, count, step)]
    poses_of = pose if callable(pose) else (lambda rows: pose[rows])

    def poses(rows: slice) -> np.ndarray:
        return np.ascontiguousarray(np.asarray(poses_of(rows), dtype=float)[:, :model.dof])

    modes = working_modes(model) if scenario.working_mode == "auto" else [scenario.working_mode]
    # a path of one piece: each leg's branches solved once for all the modes (a long run's are not kept), and every
    # mode's configurations at its sparse samples first, so that the modes are measured in the order of those
    # samples' min |S| (the likely best first: the others then stop at their sparse samples, below, and only the
    # modes measured whole have all their configurations put together; a single mode's at once, and every mode's of a
    # machine whose inverse kinematics checks its platform joints on the whole path anyway)
    branches, path = ({}, poses(pieces[0])) if len(pieces) == 1 else (None, None)
    sampled = len(modes) > 1 and not checks_platform_joints(model)
    solved = {mode: path_configurations(model, path, mode, follow=True, branches=branches,
                                        rows=slice(None, None, SPARSE) if sampled else None)
              for mode in modes} if path is not None else {}
    # (q of the sparse samples only, or of the whole path)
    sparse = {mode: _min_measure(model, q if sampled else q[::SPARSE]) for mode, (q, _failure) in solved.items()}
    order = sorted(modes, key=lambda mode: -sparse[mode]) if sparse else modes
    # (mode, min |S|, its sample, max |S|, q) of the modes reaching the whole path that may still be the best: those
    # whose min |S| is within 1e-9 of the largest; the others' paths are dropped at once (a long run's memory). The
    # choice is the first of them in the modes' order, whatever order they were measured in.
    failures, candidates, top = [], [], -np.inf
    for mode in order:
        lowest, closest, highest, failure, q, dropped = np.inf, 0, 0.0, None, None, False
        for rows in pieces:
            q, failure = solved[mode] if solved else path_configurations(model, poses(rows), mode, follow=True)
            if failure is not None:
                failure = (failure[0] + rows.start, failure[1])
                break
            # min |S| of the whole path is at most that of every SPARSE-th sample (the same numbers: each sample's
            # S is its own): below the best mode's less the tie's 1e-9, the mode cannot be chosen — exact, not a guess
            if (sparse[mode] if solved else _min_measure(model, q[::SPARSE])) < top - 1e-9:
                dropped = True
                break
            if solved and sampled:  # the whole path's configurations in this mode, its legs' branches known
                q, _failure = path_configurations(model, path, mode, follow=True, branches=branches)
            a = np.abs(configuration_measures(model, q))
            k = int(np.argmin(a))
            if a[k] < lowest:  # the first sample of the smallest |S|
                lowest, closest = float(a[k]), k + rows.start
            highest = max(highest, float(a.max()))
        if dropped:
            continue
        if failure is not None:
            failures.append((mode, failure))
            continue
        top = max(top, lowest)
        kept = q if len(pieces) == 1 else None
        candidates = [c for c in [*candidates, (mode, lowest, closest, highest, kept)] if c[1] >= top - 1e-9]
    candidates.sort(key=lambda c: modes.index(c[0]))
    if not candidates:  # the mode that gets furthest names the problem (the first in the modes' order, of a tie)
        k, exc = max(failures, key=lambda f: (f[1][0], -modes.index(f[0])))[1]
        raise UnreachablePoseError(f"the path leaves the workspace at t = {t[k]:.4f} s, pose "
                                   f"{pose_text(poses(slice(k, k + 1))[0])}: {exc}") from None
    best, best_min, closest, highest, best_q = candidates[0]
    if best_min < scenario.singularity_margin:
        near, margin = apart(best_min, scenario.singularity_margin)
        every = "in every admissible working mode" if len(modes) > 1 else "in its working mode"
        if highest < scenario.singularity_margin:
            raise SingularityError(f"the whole path lies within |S| < {margin} of a gain-type singularity {every} "
                                   f"(max |S| = {highest:.3g}, at pose {pose_text(poses(slice(0, 1))[0])} and on)")
        raise SingularityError(
            f"the path comes within {near} of a gain-type singularity (margin {margin}) {every}; closest at "
            f"t = {t[closest]:.4f} s, pose {pose_text(poses(slice(closest, closest + 1))[0])}")
    return tuple(best), best_min, best_q


#: :func:`best_working_mode` measures every SPARSE-th sample of a path first.
SPARSE = 16


def _min_measure(model, q: np.ndarray) -> float:
    """min |S| over the configurations ``q`` (a path's every :data:`SPARSE`-th; NaN where one is NaN: no bound
    then)."""
    from ..model.mechanism_model import configuration_measures

    return float(np.abs(configuration_measures(model, np.ascontiguousarray(q))).min())


def pose_text(pose) -> str:
    """A pose to four decimals (a machine's poses), a huge coordinate in exponent form: the message stays short."""
    return "(" + ", ".join(f"{v:.4f}" if abs(v) < 1e6 else f"{v:.4g}" for v in pose) + ")"
