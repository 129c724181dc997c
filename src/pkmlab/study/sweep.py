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
    """Run a study and return its table, a ``pandas.DataFrame`` with one row per run (columns: ``run``,
    ``point``, ``draw``, each axis, each drawn factor ``plant.*``, ``status``, ``reason``, the metrics,
    ``working_mode``, ``message``); ``table.attrs["summary"]`` is the summary.

    ``study`` is a :class:`~pkmlab.study.Study`, a study file or its tables. With ``out`` the study's folder
    receives the chunks as they finish, then ``runs.parquet`` (and ``runs.csv`` with ``csv``),
    ``summary.json`` and ``figures/`` (heat maps over ``heatmap``'s two axes, distributions, failures);
    ``resume`` finishes a study that folder holds. Where the runs execute: see :mod:`pkmlab.study.engine`
    (``workers``, ``scheduler``, ``client``; ``workers=0`` in this process). The table is the same, bit
    for bit, however the study is run, and each row is what :func:`~pkmlab.simulation.run.simulate` gives for
    ``study.scenario(run)``.
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
