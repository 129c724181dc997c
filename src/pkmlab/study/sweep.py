"""``pkmlab.sweep``: a whole study — its runs, its table, its summary and its figures."""

from __future__ import annotations

import json
import math
from pathlib import Path

from ..errors import InvalidParameterError
from ..outputs import atomic_file
from .definition import Study, load_study, study_from_dict
from .engine import run_study
from .jobs import HEADLINE, METRICS


def _study(study) -> Study:
    if isinstance(study, Study):
        return study
    if isinstance(study, dict):
        return study_from_dict(study)
    if isinstance(study, (str, Path)):
        return load_study(study)
    raise InvalidParameterError(f"study must be a Study, a study file or its tables, got {type(study).__name__}")


def _statistics(values) -> dict:
    values = values.dropna()
    if values.empty:
        return {}
    return {"min": float(values.min()), "median": float(values.median()), "p95": float(values.quantile(0.95)),
            "max": float(values.max())}


def summarize(study: Study, frame, stats: dict | None = None) -> dict:
    """The study's ``summary.json``: counts, failures by reason, statistics of every metric over the runs that
    finished, the grid point with the least worst-case headline metric (the path error; a job's own,
    :data:`~pkmlab.study.jobs.HEADLINE`) among those where no run failed, and how the study ran (``stats``)."""
    ok = frame[frame["status"] == "ok"]
    metrics = [c for c in ("max_path_error_m", "rms_path_error_m", "max_orientation_error_rad", "max_joint_error",
                           "peak_effort", "min_abs_S", *METRICS[study.job]) if c in frame]
    (first, *_), (second, *_) = HEADLINE[study.job]
    summary = {
        "study": study.name, "digest": study.digest, "runs": int(len(frame)), "ok": int(len(ok)),
        "failed": int(len(frame) - len(ok)),
        "failures": {str(k): int(v) for k, v in frame.loc[frame["status"] != "ok", "reason"].value_counts().items()},
        "grid": {key: list(values) for key, values in study.axes}, "draws": study.draws, "seed": study.seed,
        "uncertainty": {k: list(v) for k, v in study.uncertainty.items()},
        "metrics": {m: _statistics(ok[m]) for m in metrics},
    }
    per_point = frame.groupby("point").agg(worst_first=(first, "max"), worst_second=(second, "max"),
                                           failed=("status", lambda s: int((s != "ok").sum())))
    clean = per_point[per_point["failed"] == 0].dropna()
    if not clean.empty:
        point = int(clean["worst_first"].idxmin())
        summary["best_point"] = {"point": point, "values": study.point_values(point),
                                 f"worst_{first}": float(clean.loc[point, "worst_first"]),
                                 f"worst_{second}": float(clean.loc[point, "worst_second"])}
    if stats is not None:
        summary["execution"] = {k: (float(v) if isinstance(v, float) and math.isfinite(v) else v)
                                for k, v in stats.items()}
    return summary


def sweep(study, out=None, *, workers: int | None = None, scheduler: str | None = None, client=None,
          chunk_size: int | None = None, resume: bool = False, csv: bool = False, figures: bool = True,
          heatmap: tuple[str, str] | None = None, progress: bool = False, on_chunk=None, note=None):
    """Run a study and return its table, one row per run.

    The table is the same, bit for bit, however the study is run, and each row is what
    :func:`~pkmlab.simulation.run.simulate` gives for ``study.scenario(run)``. With ``out`` the study's folder
    receives the chunks as they finish, then ``runs.parquet`` (and ``runs.csv`` with ``csv``),
    ``summary.json`` and ``figures/`` (heat maps over ``heatmap``'s two axes, distributions, failures).
    Needs the ``study`` extra (pandas, PyArrow; Dask to run on several workers).

    Parameters
    ----------
    study : Study, str, path or dict
        A :class:`~pkmlab.study.Study`, a study file or its tables.
    out : str or path, optional
        The study's folder for its files; nothing is written without it.
    workers, scheduler, client : optional
        Where the runs execute (:mod:`pkmlab.study.engine`): ``workers=0`` in this process, else a local Dask
        cluster of ``workers`` processes, the Dask ``scheduler`` at an address, or a Dask ``client``.
    chunk_size : int, optional
        Runs per chunk (a task of the cluster, a file of the folder).
    resume : bool
        Finish a study that ``out`` holds.
    csv : bool
        Also write ``runs.csv``.
    figures : bool
        Write the figures (with ``out``; default True).
    heatmap : (str, str), optional
        The two axes of the heat maps.
    progress : bool
        Show the progress on the terminal.
    on_chunk, note : callable, optional
        Called as chunks finish, and with notes for the user.

    Returns
    -------
    pandas.DataFrame
        Columns ``run``, ``point``, ``draw``, each axis, each drawn factor ``plant.*``, ``status``, ``reason``,
        the metrics (``max_path_error_m``...), ``working_mode``, ``message``; ``table.attrs["summary"]`` is the
        summary.

    Raises
    ------
    InvalidParameterError
        If the study is refused, or ``heatmap`` names a key that is not an axis.
    StudyError
        If ``out`` holds other files or a study another process is running, or without the ``study`` extra
        installed, saying how to install it.

    Examples
    --------
    >>> import pkmlab
    >>> from pkmlab.formats.scenario import SCENARIO_DIR
    >>> study = pkmlab.Study.create(SCENARIO_DIR / "fast.toml", grid={"controller.kp": [500.0, 1000.0]})
    >>> table = pkmlab.sweep(study, workers=0)
    >>> table[["controller.kp", "status"]].values.tolist()
    [[500.0, 'ok'], [1000.0, 'ok']]
    """
    from .engine import require_module

    for module in ("pandas", "pyarrow"):
        require_module(module)
    study = _study(study)
    for key in heatmap or ():
        if key not in dict(study.axes):
            raise InvalidParameterError(f"heatmap: '{key}' is not an axis of the study "
                                        f"({', '.join(k for k, _ in study.axes) or 'it has none'})")
    table, stats = run_study(study, out, workers=workers, scheduler=scheduler, client=client, chunk_size=chunk_size,
                             resume=resume, progress=progress, on_chunk=on_chunk, note=note)
    frame = table.to_pandas()
    summary = summarize(study, frame, stats)
    frame.attrs["summary"] = summary
    if out is not None:
        write_outputs(study, table, frame, summary, Path(out), csv=csv, figures=figures, heatmap=heatmap)
    return frame


def write_outputs(study: Study, table, frame, summary: dict, out: Path, *, csv: bool, figures: bool,
                  heatmap=None) -> None:
    """The finished study's files, each written whole or not at all."""
    import pyarrow.parquet as pq

    with atomic_file(out / "runs.parquet") as tmp:
        pq.write_table(table, tmp)
    if csv:
        with atomic_file(out / "runs.csv") as tmp:
            frame.to_csv(tmp, index=False, float_format=None)
    with atomic_file(out / "summary.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=1, allow_nan=False, default=_jsonable))
    if figures and len(frame):
        from .figures import study_figures

        for name, fig in study_figures(frame, [k for k, _ in study.axes], study.name, heatmap,
                                       HEADLINE[study.job]).items():
            with atomic_file(out / "figures" / name) as tmp:
                fig.savefig(tmp, dpi=130, format="png")


def _jsonable(value):
    if hasattr(value, "item"):  # NumPy scalars
        return value.item()
    raise TypeError(f"not JSON: {type(value).__name__}")
