"""Running a chunk of a study's runs, in whatever process: one row per run, failures included.

A chunk is the unit of work of a study: its runs go through :func:`~pkmlab.simulation.run.simulate_batch`
(one compiled call per number of samples, so the compiled loop stays hot), and every run gives one
row — its inputs (grid values, drawn factors), ``status`` (``"ok"`` or ``"failed"``), the ``reason``
of a failure (:data:`REASONS`), the summary's metrics and the error's one-line ``message``. A run
that fails is a result, never an exception: only a bug in pkmlab escapes :func:`run_chunk`.
"""

from __future__ import annotations

import json
import math

from ..errors import (
    AssemblyError,
    BranchFollowingError,
    FileFormatError,
    InvalidParameterError,
    PkmlabError,
    SingularityError,
    UnreachablePoseError,
    UnstableControlError,
)
from .definition import Study
from .jobs import METRICS, calibration_metrics, identification_metrics

#: Why a run failed, by the class of its error (the first match counts: subclasses first).
REASONS = (
    (UnstableControlError, "unstable"),        # the sampled-data loop diverges with these gains
    (BranchFollowingError, "branch_lost"),     # the plant or the model could not follow its assembly mode
    (SingularityError, "singular"),            # the path comes too close to a singularity
    (UnreachablePoseError, "unreachable"),     # the path leaves the workspace
    (AssemblyError, "unassemblable"),
    (InvalidParameterError, "invalid"),        # a combination of values that is no valid scenario
    (FileFormatError, "invalid"),              # ... or that a scenario file could not hold
    (PkmlabError, "error"),
)


def reason_of(exc: PkmlabError) -> str:
    """The ``reason`` column of a run that raised ``exc``."""
    return next(reason for kind, reason in REASONS if isinstance(exc, kind))


def metric_columns(study: Study) -> tuple[str, ...]:
    """The metrics of a study's table, from its base machine: the summary's numbers (one peak effort
    per actuator and their maximum), ``min_abs_S`` and the number of samples, then its job's
    (:data:`~pkmlab.study.jobs.METRICS`); a calibration study's are its job's alone (it simulates nothing)."""
    if study.job == "calibrate":
        return METRICS["calibrate"]
    model = study.base_scenario().model  # not grid point 0's: that one may be a combination that fails
    names = model.pose_names
    orientation = ("max_orientation_error_rad",) if {"alpha", "roll"} & set(names) else ()
    n = model.n_actuators
    return ("max_path_error_m", "rms_path_error_m", *orientation, "max_joint_error", "peak_effort",
            *(f"peak_effort_{i + 1}" for i in range(n)), "min_abs_S", "samples", *METRICS[study.job])


def columns(study: Study) -> tuple[str, ...]:
    """The columns of a study's table, in order."""
    return ("run", "point", "draw", *(key for key, _values in study.axes),
            *(f"plant.{name}" for name in study.factor_names()), "status", "reason", *metric_columns(study),
            "working_mode", "message")


def _cell(value):
    """An axis value as a table cell: numbers and strings as they are, lists as JSON."""
    return json.dumps(value) if isinstance(value, list) else value


def _row(study: Study, run: int, layout: tuple, factors: dict, result=None, error=None, samples=0,
         extra: dict | None = None) -> dict:
    """The row of ``run``; ``layout`` is ``(metric columns, factor names)``; ``extra`` the job's metrics."""
    metrics, factor_names = layout
    point, draw = study.locate(run)
    row = {"run": run, "point": point, "draw": draw}
    row.update({key: _cell(value) for key, value in study.point_values(point).items()})
    row.update({f"plant.{name}": factors.get(name, math.nan) for name in factor_names})
    row["status"] = "ok" if error is None else "failed"
    row["reason"] = "" if error is None else reason_of(error)
    row.update(dict.fromkeys(metrics, math.nan))
    if "samples" in metrics:
        row["samples"] = samples
    row["working_mode"] = ""
    row["message"] = "" if error is None else str(error)
    if result is not None:
        summary = result.summary()
        for key in metrics:
            if key in summary:
                row[key] = summary[key]
        efforts = summary["peak_effort"]
        row["peak_effort"] = max(efforts)
        row.update({f"peak_effort_{i + 1}": v for i, v in enumerate(efforts)})
        row["working_mode"] = "".join("+" if m > 0 else "-" for m in summary["working_mode"])
        row["samples"] = int(result.t.size)
    row.update(extra or {})
    return row


def _without_batch_prefix(exc: PkmlabError, index: int, name: str) -> PkmlabError:
    """``exc`` without the ``run i (name): `` that :func:`simulate_batch` puts before the message."""
    prefix = f"run {index} ({name}): "
    text = str(exc)
    return type(exc)(text[len(prefix):]) if text.startswith(prefix) else exc


def run_chunk(study: Study, runs, threads: int | None = None) -> list[dict]:
    """Run ``runs`` (run numbers of ``study``) and return their rows, in the order given.

    ``threads`` sets how many cores the compiled batch uses in this process (default: Numba's)."""
    from ..simulation.run import sample_times, simulate, simulate_batch

    if threads is not None:
        import numba

        numba.set_num_threads(max(1, min(int(threads), numba.config.NUMBA_NUM_THREADS)))
    layout = (metric_columns(study), study.factor_names())
    if study.job == "calibrate":
        return [_calibration_row(study, int(run), layout) for run in runs]
    rows: dict[int, dict] = {}
    nominal: dict[int, object] = {}
    scenarios: dict[int, tuple] = {}
    for run in runs:
        run = int(run)
        point, _draw = study.locate(run)
        factors: dict = {}
        try:
            if point not in nominal:
                try:
                    nominal[point] = study.nominal_scenario(point)
                except PkmlabError as exc:
                    nominal[point] = exc
            if isinstance(nominal[point], PkmlabError):
                raise nominal[point]
            factors = study.factors(run, nominal[point])
            try:
                scenario = study.scenario(run, nominal[point], factors)
            except InvalidParameterError as exc:  # the plant drawn cannot be assembled
                raise AssemblyError(f"the plant drawn cannot be assembled: {exc}") from None
        except PkmlabError as exc:
            rows[run] = _row(study, run, layout, factors, error=exc)
            continue
        scenarios[run] = (scenario, factors)
    groups: dict[int, list[int]] = {}
    for run, (scenario, _factors) in scenarios.items():
        samples = sample_times(scenario).size if scenario.sample_time > 0 else 0  # 0: continuous time
        groups.setdefault(samples, []).append(run)
    for samples, members in groups.items():
        batch = [scenarios[run][0] for run in members]
        if samples:
            outcome = simulate_batch(batch, on_error="return")
        else:
            outcome = []
            for scenario in batch:
                try:
                    outcome.append(simulate(scenario))
                except PkmlabError as exc:
                    outcome.append(exc)
        for index, (run, result) in enumerate(zip(members, outcome, strict=True)):
            factors = scenarios[run][1]
            if isinstance(result, PkmlabError):
                error = _without_batch_prefix(result, index, batch[index].name) if samples else result
                rows[run] = _row(study, run, layout, factors, error=error, samples=samples)
            elif study.job == "identify":
                try:
                    extra = identification_metrics(batch[index], result, study.point_options(study.locate(run)[0]))
                except PkmlabError as exc:
                    rows[run] = _row(study, run, layout, factors, error=exc, samples=samples)
                else:
                    rows[run] = _row(study, run, layout, factors, result=result, extra=extra)
            else:
                rows[run] = _row(study, run, layout, factors, result=result)
    return [rows[int(run)] for run in runs]


def _calibration_row(study: Study, run: int, layout: tuple) -> dict:
    """The row of ``run`` of a calibration study: the machine of its grid point, calibrated (no simulation)."""
    point, draw = study.locate(run)
    try:
        model = study.nominal_scenario(point).model
        extra = calibration_metrics(model, study.point_options(point), study.seed, draw)
    except PkmlabError as exc:
        return _row(study, run, layout, {}, error=exc)
    return _row(study, run, layout, {}, extra=extra)
