"""Measurement logs: what a user records from a real machine (or a pkmlab run writes) for identification.

A log is a CSV file with a header row and one row per sample, at a fixed rate::

    t,theta1,theta2,theta3,tau1,tau2,tau3
    0.0,0.52,1.93,3.87,0.012,-0.004,0.020
    ...

``t`` in seconds, ``theta<j>`` the measured actuator values (rad, or m for a prismatic actuator), ``tau<j>``
the efforts (N·m, or N). Other columns are ignored, except the pose's (``x``, ``y``, ``alpha``, … as the
machine names them): when a log has them all, their first row chooses the assembly mode the log starts in. The
``run.csv`` of ``pkmlab simulate`` is such a log; when its run had sensors, their readings ``theta<j>_m`` are
read instead of the plant's exact ``theta<j>`` (a real machine logs what its encoders read).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np

from ..algorithms.identification import sampling_step
from ..algorithms.kinematics import length_scale
from ..errors import FileFormatError, InvalidParameterError
from .params import read_result_csv

__all__ = ["MeasurementLog", "read_measurement_log"]

#: A revolute actuator's logged values beyond this (rad) cannot be radians of a machine's joint: degrees or
#: encoder counts, more likely.
MAX_ANGLE = 50.0
#: A prismatic actuator's values beyond this many machine sizes cannot be metres: millimetres, more likely.
MAX_LENGTHS = 100.0


@dataclass(frozen=True)
class MeasurementLog:
    """A log read by :func:`read_measurement_log`: ``t`` (N,), ``theta`` and ``tau`` (N, n_actuators) and the
    pose at the first row (or None when the log has no pose columns)."""

    t: np.ndarray
    theta: np.ndarray
    tau: np.ndarray
    pose: np.ndarray | None


def read_measurement_log(path: str | Path, model) -> MeasurementLog:
    r"""The log at ``path`` of ``model``'s actuators and efforts.

    The columns are those of the module's text: ``t`` (s), ``theta<j>`` (rad, or m for a prismatic actuator),
    ``tau<j>`` (N·m, or N), and optionally the pose's; a run's sensor readings ``theta<j>_m``, when it has them
    all, are read in place of ``theta<j>``.

    Parameters
    ----------
    path : str or Path
        The CSV file.
    model : MechanismModel
        The machine the log is of (:func:`pkmlab.load`): its number of actuators, their kinds and its pose's
        names.

    Returns
    -------
    MeasurementLog
        ``t`` (N,) in s, ``theta`` and ``tau`` (N, n_actuators), and ``pose`` (dof,) at the first row (m and
        rad), or None when the log has no pose columns.

    Raises
    ------
    FileFormatError
        In one line naming the file and the column or row: a missing column, a value that is not a finite
        number, time that does not increase or a rate that changes, values that cannot be in the machine's
        units, fewer than two rows.

    Examples
    --------
    >>> import tempfile
    >>> from pathlib import Path
    >>> import pkmlab
    >>> from pkmlab.formats.measurements import read_measurement_log
    >>> model = pkmlab.load("five_bar")
    >>> folder = tempfile.TemporaryDirectory()
    >>> path = Path(folder.name) / "log.csv"
    >>> _ = path.write_text("t,theta1,theta2,tau1,tau2\n0.00,1.0,2.0,0.1,0.2\n0.01,1.1,2.1,0.1,0.2\n")
    >>> log = read_measurement_log(path, model)
    >>> log.t.tolist(), log.theta.tolist(), log.pose is None
    ([0.0, 0.01], [[1.0, 2.0], [1.1, 2.1]], True)
    >>> _ = path.write_text("t,theta1,theta2,tau1,tau2\n0.00,57.3,2.0,0.1,0.2\n0.01,57.4,2.1,0.1,0.2\n")
    >>> read_measurement_log(path, model)  # degrees
    Traceback (most recent call last):
        ...
    pkmlab.errors.FileFormatError: .../log.csv: column theta1 reaches 57.4, which cannot be radians of a revolute ...
    >>> folder.cleanup()
    """
    path = Path(path)
    n = model.n_actuators
    theta_names = [f"theta{j + 1}" for j in range(n)]
    tau_names = [f"tau{j + 1}" for j in range(n)]
    measured = [f"theta{j + 1}_m" for j in range(n)]
    data = read_result_csv(path, ["t", *theta_names, *tau_names], optional=(*model.pose_names, *measured))
    if all(c in data for c in measured):  # a pkmlab run with sensors: what they read, as a machine logs it
        theta_names = measured
    t = data["t"]
    if len(t) < 2:
        raise FileFormatError(f"{path}: too few samples ({len(t)} row): a log needs many rows at a fixed rate")
    try:
        sampling_step(t, first_row=1)
    except InvalidParameterError as exc:
        raise FileFormatError(f"{path}: {exc}") from None
    theta = np.column_stack([data[c] for c in theta_names])
    for j, kind in enumerate(model.description.actuator_kinds):
        size = np.abs(theta[:, j]).max()
        if kind == "R" and size > MAX_ANGLE:
            raise FileFormatError(f"{path}: column {theta_names[j]} reaches {size:g}, which cannot be radians of a "
                                  "revolute actuator (degrees or encoder counts?): log radians")
        if kind == "P" and size > MAX_LENGTHS * length_scale(model):
            raise FileFormatError(f"{path}: column {theta_names[j]} reaches {size:g}, which cannot be metres of this "
                                  f"machine's slide (it is {length_scale(model):.3g} m across; millimetres?): log "
                                  "metres")
    # the first sample's pose, where the log has the platform's (a kinematically redundant machine's base actuators,
    # controlled coordinates too, are their actuator columns)
    columns = {c: data[c] if c in data else None for c in model.description.platform.pose_names}
    m = model.description
    columns.update({c: theta[:, k] for c, k in zip(m.redundancy_names, m.redundancy_actuators, strict=True)})
    pose = (np.array([columns[c][0] for c in model.pose_names])
            if all(columns.get(c) is not None for c in model.pose_names) else None)
    return MeasurementLog(t, theta, np.column_stack([data[c] for c in tau_names]), pose)
