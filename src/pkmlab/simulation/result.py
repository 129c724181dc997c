"""What a simulation returns: :class:`SimulationResult`, every time series of a run (conventions §8), its
summary and the units of the summary's keys, and the path and orientation errors it is made of.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..errors import PkmlabError
from ..model.mechanism_model import MechanismModel
from ..numerics.angles import wrapped_angle, wrapped_where
from ..outputs import atomic_file
from .scenario import Scenario, check_model

#: Columns of the per-sample time series (conventions §8).
COLUMNS = ("t", "theta1", "theta2", "theta3", "theta1_d", "theta2_d", "theta3_d", "tau1", "tau2", "tau3",
           "x", "y", "alpha", "x_d", "y_d", "alpha_d", "S")


# ------------------------------------------------------------------ results
#: Rows of a run's table that :meth:`SimulationResult.to_csv` turns into text at once.
CSV_CHUNK = 8192


@dataclass(frozen=True)
class SimulationResult:
    """Every time series of a run, one row per sample ``t = 0 … T`` (inclusive).

    What :func:`~pkmlab.simulate` returns (conventions §8).

    Attributes
    ----------
    scenario : Scenario
        The scenario that was run.
    working_mode : tuple of int
        The working mode the run followed (one sign per two-branch leg).
    t : ndarray, shape (N,)
        The sample times (s).
    q : ndarray, shape (N, n)
        The plant's configuration (rad or m per entry).
    theta_dot : ndarray, shape (N, n_actuators)
        The plant's actuator rates (rad/s or m/s).
    theta_d : ndarray, shape (N, n_actuators)
        The desired actuator values (the controller's model; rad or m), on the side of 2π of ``theta``.
    tau : ndarray, shape (N, n_actuators)
        The actuator efforts (N·m, or N for prismatic actuators).
    pose : ndarray, shape (N, dof)
        The plant's pose from its own geometry (``(x, y, alpha)``, or ``(x, y)`` for a 2-DOF machine; m, rad): the
        last columns of ``q`` (a view of them after a run of the compiled loop), its angles on the desired ones'
        side of 2π.
    pose_d : ndarray, shape (N, dof)
        The desired pose (m, rad).
    S : ndarray, shape (N,)
        The plant's singularity measure.
    closure_violation : ndarray, shape (N,), or None
        A MuJoCo plant's loop-closure violation (m), per sample; None for pkmlab's plant.
    theta_measured : ndarray, shape (N, n_actuators), or None
        What the controller's sensors read (rad or m), when it had sensors.

    Examples
    --------
    >>> import numpy as np
    >>> import pkmlab
    >>> result = pkmlab.simulate(pkmlab.paper_scenario("fast"))
    >>> result.q.shape, result.theta.shape, result.pose_names
    ((787, 9), (787, 3), ('x', 'y', 'alpha'))
    >>> result.table().shape == (787, len(result.columns))
    True
    """

    scenario: Scenario
    working_mode: tuple[int, ...]
    t: np.ndarray
    q: np.ndarray
    theta_dot: np.ndarray
    theta_d: np.ndarray
    tau: np.ndarray
    pose: np.ndarray
    pose_d: np.ndarray
    S: np.ndarray
    closure_violation: np.ndarray | None = None  # a MuJoCo plant's loop-closure violation (m), per sample
    theta_measured: np.ndarray | None = None  # what the controller's sensors read (N, n), when it had sensors

    @property
    def theta(self) -> np.ndarray:
        """The plant's actuator values ``θ`` (N, n_actuators): the first columns of ``q`` (rad, or m if prismatic)."""
        return self.q[:, :self.tau.shape[1]]

    @property
    def columns(self) -> tuple[str, ...]:
        """Names of the columns of :meth:`table`: ``t``, ``theta1..n``, ``theta1_d..``, ``tau1..n``, the pose's
        coordinates, their desired values (``x_d``...), ``S`` (for the paper's machine :data:`COLUMNS`), then a
        MuJoCo plant's ``closure_violation_m`` and the sensors' readings ``theta1_m..n`` when there are."""
        n = self.tau.shape[1]
        extra = ("closure_violation_m",) if self.closure_violation is not None else ()
        if self.theta_measured is not None:
            extra += tuple(f"theta{i + 1}_m" for i in range(n))
        names = self.pose_names
        return ("t", *(f"theta{i + 1}" for i in range(n)), *(f"theta{i + 1}_d" for i in range(n)),
                *(f"tau{i + 1}" for i in range(n)), *names, *(f"{v}_d" for v in names), "S", *extra)

    @property
    def path_error(self) -> np.ndarray:
        """Euclidean distance (m) between the actual and the desired tracked point."""
        return path_error(self.pose, self.pose_d, self.pose_names)

    @property
    def orientation_error(self) -> np.ndarray | None:
        """The angle (rad) between the actual and the desired orientation of the platform, None where the pose
        has no orientation (:func:`orientation_error`)."""
        return orientation_error(self.pose, self.pose_d, self.pose_names)

    @property
    def pose_names(self) -> tuple[str, ...]:
        """The names of the pose's coordinates."""
        return self.scenario.model.pose_names

    @property
    def internal_effort_error(self) -> np.ndarray | None:
        """A redundantly actuated machine's internal efforts the plant carries beyond those its controller meant
        (N, n_actuators; N·m or N): ``N_p τ - N_c τ``, with ``N = I - W (WᵀW)⁻¹ Wᵀ`` the projection on the internal
        efforts (the null space of ``Wᵀ``) of the plant at its configurations and of the controller's model at the
        plant's poses (where it reads them; with sensors it reads an estimate near them). The controller never
        observes them: they are what its model's geometry gets wrong, zero when its model is the plant. None for a
        machine of as many actuators as degrees of freedom, which has no internal efforts."""
        plant, model = self.scenario.plant_model, self.scenario.model
        if not model.description.actuation_redundancy:
            return None
        if plant is model or plant == model:
            return np.zeros_like(self.tau)
        from ..algorithms.redundancy import internal_efforts
        from ..model.mechanism_model import path_inverse_kinematics, pose_jacobians

        n, out = self.tau.shape[1], np.empty_like(self.tau)
        for k0 in range(0, len(self.t), INTERNAL_PIECE):  # a piece of rows at a time: a long run's memory
            rows = slice(k0, k0 + INTERNAL_PIECE)
            q_model = path_inverse_kinematics(model, np.ascontiguousarray(self.pose[rows]), self.working_mode,
                                              follow=True)[0]
            plant_part, model_part = (internal_efforts(pose_jacobians(machine, q)[0][:, :n, :], self.tau[rows])
                                      for machine, q in ((plant, self.q[rows]), (model, q_model)))
            out[rows] = plant_part - model_part
        return out

    def summary(self) -> dict:
        """The run's summary, one key set for every machine (:func:`summary_units` gives each key's unit).

        Returns
        -------
        dict
            ``max_path_error_m``, ``rms_path_error_m``; ``max_orientation_error_rad`` where the pose has an
            orientation, and ``max_alpha_error_rad`` (the same value) where it is the planar angle ``alpha``;
            ``max_joint_error`` and ``peak_effort`` (one per actuator) in the actuators' units, also named with
            their unit where every actuator has the same kind: ``max_joint_error_rad`` and ``peak_torque_Nm`` for
            revolute actuators, ``max_joint_error_m`` and ``peak_force_N`` for prismatic ones; ``min_abs_S``;
            ``working_mode``; ``max_closure_violation_m`` for a MuJoCo plant; ``max_internal_effort_error`` for a
            redundantly actuated machine (:attr:`internal_effort_error`, in the actuators' effort units).

        Examples
        --------
        >>> import pkmlab
        >>> summary = pkmlab.simulate(pkmlab.paper_scenario("fast")).summary()
        >>> list(summary)
        ['max_path_error_m', 'rms_path_error_m', 'max_orientation_error_rad', 'max_alpha_error_rad', 'max_joint_error',
        'peak_effort', 'max_joint_error_rad', 'peak_torque_Nm', 'min_abs_S', 'working_mode']
        >>> f"{summary['min_abs_S']:.3f}"
        '1.080'
        """
        err = self.path_error
        joint = actuator_errors(self.scenario.plant_model, self.theta, self.theta_d)
        out = {
            "max_path_error_m": float(err.max()),
            "rms_path_error_m": float(np.sqrt(np.mean(err**2))),
        }
        orientation = self.orientation_error
        if orientation is not None:
            out["max_orientation_error_rad"] = float(orientation.max())
            if "alpha" in self.pose_names:
                out["max_alpha_error_rad"] = out["max_orientation_error_rad"]
        out["max_joint_error"] = float(np.abs(joint).max())
        out["peak_effort"] = np.abs(self.tau).max(axis=0).tolist()
        kinds = set(self.scenario.model.description.actuator_kinds)
        if kinds == {"R"}:
            out["max_joint_error_rad"], out["peak_torque_Nm"] = out["max_joint_error"], out["peak_effort"]
        elif kinds == {"P"}:
            out["max_joint_error_m"], out["peak_force_N"] = out["max_joint_error"], out["peak_effort"]
        out["min_abs_S"] = float(np.abs(self.S).min())
        out["working_mode"] = list(self.working_mode)
        if self.closure_violation is not None:
            out["max_closure_violation_m"] = float(self.closure_violation.max())
        internal = self.internal_effort_error
        if internal is not None:
            out["max_internal_effort_error"] = float(np.abs(internal).max())
        return out

    def table(self, rows: slice = slice(None)) -> np.ndarray:
        """The time series as one array, columns :attr:`columns`.

        Parameters
        ----------
        rows : slice
            The samples to include (default all).

        Returns
        -------
        ndarray, shape (N, len(columns))
            In the columns' units (s, rad or m, N·m or N, m and rad of the pose, ``S`` dimensionless).
        """
        extra = [] if self.closure_violation is None else [self.closure_violation[rows]]
        if self.theta_measured is not None:
            extra.append(self.theta_measured[rows])
        return np.column_stack([self.t[rows], self.theta[rows], self.theta_d[rows], self.tau[rows], self.pose[rows],
                                self.pose_d[rows], self.S[rows], *extra])

    def to_dataframe(self):
        """The time series as a pandas ``DataFrame`` (columns :attr:`columns`, indexed by sample), for the users
        of pandas; pandas is an optional dependency (``pip install 'pkmlab[study]'``).

        Raises
        ------
        PkmlabError
            Without pandas installed, saying how to install it.
        """
        try:
            import pandas as pd
        except ImportError:
            raise PkmlabError("to_dataframe needs pandas: pip install 'pkmlab[study]' (or pandas)") from None
        return pd.DataFrame(self.table(), columns=list(self.columns))

    def to_csv(self, path) -> Path:
        """Write the time series (columns :attr:`columns`) atomically, as CSV.

        Every value is written as the shortest text that reads back to the same float.

        Parameters
        ----------
        path : str or path
            The file to write; its folder must exist.

        Returns
        -------
        pathlib.Path
            ``path``.

        Raises
        ------
        OutputFileError
            Naming the path, when its folder does not exist or it is a folder.
        """
        # every value as the shortest text that reads back to the same float (repr); no value needs quoting; a
        # chunk of rows at a time, so that a long run's text is never all in memory
        with atomic_file(path, make_folder=False) as tmp, open(tmp, "w") as f:
            f.write(",".join(self.columns) + "\n")
            for start in range(0, self.t.size, CSV_CHUNK):
                rows = self.table(slice(start, start + CSV_CHUNK)).tolist()
                f.write("".join(",".join(map(repr, row)) + "\n" for row in rows))
        return Path(path)

    def to_json(self, path) -> Path:
        """Write the summary and the time series as JSON, atomically.

        Parameters
        ----------
        path : str or path
            The file to write; its folder must exist.

        Returns
        -------
        pathlib.Path
            ``path``, holding ``{"summary": ..., "columns": [...], "rows": [[...], ...]}``.

        Raises
        ------
        OutputFileError
            Naming the path, when its folder does not exist or it is a folder.
        """
        data = {"summary": self.summary(), "columns": list(self.columns), "rows": self.table().tolist()}
        return _write_atomic(path, json.dumps(data))


#: :attr:`SimulationResult.internal_effort_error` is computed this many samples at a time.
INTERNAL_PIECE = 10_000


def summary_units(model: MechanismModel) -> dict[str, str]:
    """The unit of every key of a run's summary (:meth:`SimulationResult.summary`) for ``model``'s machine:
    ``"m"``, ``"rad"``, ``"N*m"``, ``"N"``, ``""`` (``S`` and the working mode have none); a mixed machine's
    ``max_joint_error`` is ``"rad|m"`` and its ``peak_effort`` lists one unit per actuator."""
    check_model(model, "model")
    kinds = tuple(model.description.actuator_kinds)
    units = {"max_path_error_m": "m", "rms_path_error_m": "m"}
    names = model.pose_names
    if "alpha" in names or "roll" in names:
        units["max_orientation_error_rad"] = "rad"
        if "alpha" in names:
            units["max_alpha_error_rad"] = "rad"
    joint = {"R": "rad", "P": "m"}
    effort = {"R": "N*m", "P": "N"}
    same = len(set(kinds)) == 1
    units["max_joint_error"] = joint[kinds[0]] if same else "rad|m"
    units["peak_effort"] = effort[kinds[0]] if same else ",".join(effort[k] for k in kinds)
    if set(kinds) == {"R"}:
        units.update(max_joint_error_rad="rad", peak_torque_Nm="N*m")
    elif set(kinds) == {"P"}:
        units.update(max_joint_error_m="m", peak_force_N="N")
    units.update(min_abs_S="", working_mode="", max_closure_violation_m="m")  # the last: MuJoCo plants' runs
    if model.description.actuation_redundancy:
        units["max_internal_effort_error"] = units["peak_effort"]
    return units


def path_error(pose: np.ndarray, pose_d: np.ndarray, names) -> np.ndarray:
    """Euclidean distance (m) between the actual and the desired tracked point of poses (N, dof) whose
    coordinates are ``names``, over the point's coordinates among them (x, y[, z]; only z for a 3-PRS, whose x
    and y are parasitic)."""
    position = [k for k, n in enumerate(names) if n in ("x", "y", "z")]
    return np.linalg.norm(pose[:, position] - pose_d[:, position], axis=1)


def orientation_error(pose: np.ndarray, pose_d: np.ndarray, names) -> np.ndarray | None:
    """The angle (rad) between the actual and the desired orientation of poses (N, dof) whose coordinates are
    ``names``, None where the pose has no orientation: ``|alpha - alpha_d|`` wrapped in the plane; in space the
    angle of the rotation ``R_dᵀ R`` (from the roll, pitch and yaw of docs/conventions.md)."""
    names = tuple(names)
    if "alpha" in names:
        k = names.index("alpha")
        return np.abs(wrapped_angle(pose[:, k] - pose_d[:, k]))
    turns = [k for k, n in enumerate(names) if n in ("roll", "pitch", "yaw")]
    if turns and len(turns) < 3:  # a platform of lower mobility controls some of its angles: the largest error
        return np.abs(wrapped_angle(pose[:, turns] - pose_d[:, turns])).max(axis=1)
    if "roll" in names:
        from ..description.spatial import orientations

        # the angle of E = R_dᵀ R: cos from its trace (1 + 2 cos), sin from its skew part (|E - Eᵀ| = 2 sin·√2),
        # together by atan2 — exact to round-off for small angles too, where arccos of the trace is not
        e = np.einsum("kji,kjl->kil", orientations(pose_d[:, turns]), orientations(pose[:, turns]))
        skew = np.stack([e[:, 2, 1] - e[:, 1, 2], e[:, 0, 2] - e[:, 2, 0], e[:, 1, 0] - e[:, 0, 1]], axis=1)
        return np.arctan2(np.linalg.norm(skew, axis=1) / 2, (np.trace(e, axis1=1, axis2=2) - 1) / 2)
    return None


def _write_atomic(path, text: str) -> Path:
    """Write ``text`` to the caller's ``path`` in one step; its folder must exist (none is made)."""
    with atomic_file(path, make_folder=False) as tmp:
        tmp.write_text(text)
    return Path(path)


def actuator_kinds(model: MechanismModel) -> frozenset[str]:
    """The kinds of the machine's actuators: ``{"R"}`` (angles in rad, torques in N·m), ``{"P"}`` (lengths in
    m, forces in N), or both."""
    return frozenset(model.description.actuator_kinds)


def actuator_errors(model, theta: np.ndarray, theta_d: np.ndarray) -> np.ndarray:
    """``θ - θ_d``, angles wrapped to (-π, π] (a prismatic actuator's error is a length)."""
    return wrapped_where(theta - theta_d, model.kernels.ANGLES[:model.n_actuators])
