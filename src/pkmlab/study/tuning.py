"""``pkmlab tune``: the gains that minimise the worst-case path error under an effort limit.

The problem. A scenario's controller gains ``kp`` and ``kv = 2 ζ √kp`` (``ζ`` the damping ratio of the
nominal error dynamics; ``ζ = 1`` with ``critical=True``) are chosen to minimise the ``quantile`` (1:
the worst case) of the max path error over an *uncertainty set* — the plants of ``draws`` draws of
:mod:`pkmlab.simulation.uncertainty` around the scenario's plant, the same draws for every candidate (common random
numbers: the objective is a deterministic function of the gains, and two candidates are compared on
the same machines) — subject to every run's peak effort being at most ``max_effort``. A run that fails
(unstable sampled-data loop, lost branch) makes its candidate infeasible.

The optimiser. Optuna's TPE sampler with its constraint handling (``Trial.set_constraint``): a well-kept
library for expensive black-box problems of a few continuous variables, seeded and therefore
reproducible, with an ask-and-tell interface that lets each batch of candidates run as one study on
the cluster. (Nevergrad would do as well; Optuna's constraint support and its study records decided.)
The scenario's own gains are the first candidate (with ``critical=True`` its kp with ``kv = 2√kp``), so the
tuned gains are never worse than them on this objective; gains outside the search box are evaluated beside the
search instead (trial -1: a baseline to compare with, never the answer). ``kp`` is searched on a log scale, ``ζ``
too.

The answer: the best feasible candidate, every candidate evaluated (``trials``), and the trade-off
curve — for each effort limit, the least worst-case error among the candidates within it (the Pareto
front of the evaluated candidates) — and a scenario file of the tuned gains that ``pkmlab simulate``
runs.
"""

from __future__ import annotations

import contextlib
import copy
import json
import math
import warnings
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np

from .._validate import as_count, as_real
from ..errors import InvalidParameterError
from ..outputs import atomic_file
from .definition import Study, scenario_tables
from .engine import dask_client, run_study

#: Default search box: kp (1/s²) and the damping ratio ζ. Under sampled-data control the default kp box ends at
#: the loop's stability limit (:func:`default_kp_range`), when that is lower.
KP_RANGE = (10.0, 1e6)
ZETA_RANGE = (0.3, 3.0)
#: A tuned gain within this fraction of its box's span (in log kp, in log ζ) of one of its ends is said to lie on
#: it: the optimum may be beyond it.
ON_BOUND = 0.02


@dataclass
class TuningResult:
    """What :func:`tune` found. ``trials`` is a ``pandas.DataFrame`` (one row per candidate: ``kp``, ``kv``,
    ``zeta``, ``error`` (the objective, m), ``worst_error``, ``worst_effort``, ``failed`` runs, ``feasible``);
    ``best`` and ``baseline`` are rows of it (the scenario's own gains are the baseline); ``tradeoff`` is the
    Pareto front ``(effort limit, least error)``; ``scenario`` the tuned scenario's tables."""

    max_effort: float
    quantile: float
    trials: object
    best: dict | None
    baseline: dict
    tradeoff: list = field(default_factory=list)
    scenario: dict = field(default_factory=dict)
    uncertainty: dict = field(default_factory=dict)
    draws: int = 0
    kp_range: tuple = KP_RANGE
    zeta_range: tuple | None = ZETA_RANGE
    #: Why the kp box ends where it does (the default box: the sampled-data stability limit...).
    kp_range_reason: str = ""

    @property
    def on_bound(self) -> list[str]:
        """The tuned gains that lie at an end of their search box (within :data:`ON_BOUND` of its span, in log
        scale), each as a sentence: the best gains may lie beyond it, or the box is what limits them."""
        if self.best is None:
            return []
        said = []
        boxes = [("kp", self.best["kp"], self.kp_range)]
        if self.zeta_range is not None:
            boxes.append(("zeta", self.best["zeta"], self.zeta_range))
        for name, value, (lo, hi) in boxes:
            span = math.log(hi / lo)
            for end, which in ((lo, "lower"), (hi, "upper")):
                if abs(math.log(value / end)) <= ON_BOUND * span:
                    said_why = name == "kp" and which == "upper" and self.kp_range_reason
                    why = f": {self.kp_range_reason}" if said_why else ""
                    said.append(f"the tuned {name} = {value:.6g} lies at the {which} end of its search box ({lo:g} to "
                                f"{hi:g}{why}); the best {name} may lie beyond it")
        return said

    def summary(self) -> dict:
        return {"max_effort": self.max_effort, "quantile": self.quantile, "draws": self.draws,
                "uncertainty": dict(self.uncertainty), "best": self.best,
                "baseline": self.baseline, "tradeoff": [{"effort_limit": e, "error": v} for e, v in self.tradeoff],
                "trials": len(self.trials), "kp_range": list(self.kp_range),
                "zeta_range": None if self.zeta_range is None else list(self.zeta_range),
                "kp_range_reason": self.kp_range_reason, "on_bound": self.on_bound}


def _objective(errors: np.ndarray, quantile: float) -> float:
    return float(np.quantile(errors, quantile, method="higher"))


def _pareto(trials) -> list[tuple[float, float]]:
    """The least error for each effort limit among the candidates that never failed: ``(effort, error)`` of
    each candidate that improves the error as the limit rises."""
    front, best = [], math.inf
    ok = trials[trials["failed"] == 0].sort_values(["worst_effort", "error"])
    for effort, error in zip(ok["worst_effort"], ok["error"], strict=True):
        if error < best:
            best = error
            front.append((float(effort), float(error)))
    return front


def tune(scenario, max_effort: float, *, uncertainty: float = 0.15, quantities=("mass", "inertia"),
         draws: int = 16, seed: int = 0, quantile: float = 1.0, critical: bool = False, trials: int = 48,
         batch: int = 8, kp_range=None, zeta_range=ZETA_RANGE, workers: int | None = None,
         scheduler: str | None = None, client=None, chunk_size: int | None = None, progress=None) -> TuningResult:
    """Tune the gains of ``scenario`` for a peak effort at most ``max_effort``, against an uncertainty set of plants.

    ``uncertainty`` is the spread of the factors drawn for ``quantities`` (0.15: ±15 %; lengths are left out
    by default: a length the controller's model gets wrong is a kinematic error no gain removes); ``draws``
    plants make the uncertainty set (0: the scenario's plant alone). ``trials`` candidates ``(kp, ζ)`` are
    evaluated in batches of ``batch`` (one study each, on the cluster of ``workers``/``scheduler``/``client``, in
    chunks of ``chunk_size`` runs), searched by Optuna's TPE sampler; the scenario's own gains are the first
    candidate (the baseline). The result says when a tuned gain lies at an end of its box
    (:attr:`TuningResult.on_bound`). Needs the ``study`` extra (Optuna, pandas).

    Parameters
    ----------
    scenario : str, path or dict
        A scenario file or its tables.
    max_effort : float
        The actuators' effort limit (N·m or N), positive.
    uncertainty : float
        The factors' spread (default 0.15).
    quantities : tuple of str
        The drawn quantities (default ``("mass", "inertia")``).
    draws : int
        Plants in the uncertainty set (default 16; 0: the scenario's plant alone).
    seed : int
        The draws' and the sampler's seed.
    quantile : float
        The objective: this quantile of the path error over the set, in (0, 1] (default 1: the worst case).
    critical : bool
        Search ``kp`` alone with critical damping ``kv = 2√kp``.
    trials, batch : int
        Candidates in all, and per batch.
    kp_range, zeta_range : (float, float)
        The search box of ``kp`` and of the damping ratio ``ζ``; ``kp_range`` defaults to
        :func:`default_kp_range`: 10 to the sampled-data loop's stability limit (at most 1e6).
    workers, scheduler, client, chunk_size : optional
        Where the runs execute (as :func:`~pkmlab.sweep`).
    progress : callable, optional
        ``progress(done, total)``, called after each batch.

    Returns
    -------
    TuningResult
        ``trials`` (a ``pandas.DataFrame``, one row per candidate: ``kp``, ``kv``, ``zeta``, ``error`` (m),
        ``worst_error``, ``worst_effort``, ``failed``, ``feasible``), ``best`` and ``baseline`` (rows of it),
        ``tradeoff`` (the Pareto front ``(effort limit, least error)``), ``scenario`` (the tuned scenario's tables).

    Raises
    ------
    InvalidParameterError
        If an argument is refused (``max_effort`` not positive, ``quantile`` outside (0, 1], a count or a box
        that is not valid, a scenario that is refused).
    StudyError
        Without the ``study`` extra installed, saying how to install it.

    Examples
    --------
    >>> import pkmlab
    >>> from pkmlab.formats.scenario import SCENARIO_DIR
    >>> result = pkmlab.tune(SCENARIO_DIR / "fast.toml", 2.0, draws=0, trials=2, batch=2, workers=0)
    >>> len(result.trials), result.baseline["kp"], result.best["feasible"]
    (2, 1000.0, True)
    """
    from .engine import require_module

    optuna = require_module("optuna")
    require_module("pandas")
    base = scenario_tables(scenario)
    max_effort = as_real("max_effort", max_effort, "positive")
    if not 0.0 < quantile <= 1.0:
        raise InvalidParameterError(f"quantile must be in (0, 1], got {quantile!r}")
    for name, value, low in (("trials", trials, 1), ("batch", batch, 1), ("draws", draws, 0)):
        as_count(name, value, low)
    bounds = {q: uncertainty for q in quantities} if draws else {}
    reason = ""
    if kp_range is None:
        kp_range, reason = default_kp_range(base, uncertainty if draws and {"mass", "inertia"} & set(quantities)
                                            else 0.0)
    kp_lo, kp_hi = _box("kp_range", kp_range)
    z_lo, z_hi = _box("zeta_range", zeta_range)
    controller = base.get("controller", {})
    kp0 = float(controller.get("kp", 1000.0))
    kv0 = float(controller.get("kv", 2.0 * math.sqrt(kp0)))
    zeta0 = 1.0 if critical else kv0 / (2.0 * math.sqrt(kp0))
    # the scenario's own gains are the first candidate: searched from where they lie in the box, else evaluated
    # beside the search (a baseline to compare with, not a point the optimiser may use)
    inside = kp_lo <= kp0 <= kp_hi and (critical or z_lo <= zeta0 <= z_hi)
    optuna.logging.set_verbosity(optuna.logging.WARNING)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", optuna.exceptions.ExperimentalWarning)
        sampler = optuna.samplers.TPESampler(seed=seed, n_startup_trials=min(10, trials))
    search = optuna.create_study(direction="minimize", sampler=sampler)
    if inside:
        search.enqueue_trial({"log10_kp": math.log10(kp0), **({} if critical else {"zeta": zeta0})})
    rows: list[dict] = []
    in_process = workers == 0 and not scheduler and client is None
    with contextlib.nullcontext() if in_process else dask_client(workers, scheduler, client) as dask:

        def evaluate(gains) -> list[dict]:
            study = Study.create(base, {"controller.kp": [g[0] for g in gains], "controller.kv": [g[1] for g in gains]},
                                 bounds, draws, seed, "tune", combine="zip")
            table, _stats = run_study(study, workers=workers if dask is None else None, client=dask,
                                      chunk_size=chunk_size)
            frame = table.to_pandas()
            out = []
            for point, (kp, kv, zeta) in enumerate(gains):
                runs = frame[frame["point"] == point]
                failed = int((runs["status"] != "ok").sum())
                errors = runs["max_path_error_m"].to_numpy()
                worst_effort = math.inf if failed else float(runs["peak_effort"].to_numpy().max())
                out.append({"kp": kp, "kv": kv, "zeta": zeta,
                            "error": math.inf if failed else _objective(errors, quantile),
                            "worst_error": math.inf if failed else float(errors.max()),
                            "worst_effort": worst_effort, "failed": failed,
                            "feasible": not failed and worst_effort <= max_effort})
            return out

        if not inside:
            rows += [{"trial": -1, **row} for row in evaluate([(kp0, 2.0 * zeta0 * math.sqrt(kp0), zeta0)])]
        searched = 0
        while searched < trials:
            asked = [search.ask() for _ in range(min(batch, trials - searched))]
            gains = []
            for trial in asked:
                kp = 10.0 ** trial.suggest_float("log10_kp", math.log10(kp_lo), math.log10(kp_hi))
                zeta = 1.0 if critical else trial.suggest_float("zeta", z_lo, z_hi, log=True)
                gains.append((kp, 2.0 * zeta * math.sqrt(kp), zeta))
            for trial, row in zip(asked, evaluate(gains), strict=True):
                failed = row["failed"]
                trial.set_constraint("effort", 1.0 if failed else row["worst_effort"] - max_effort)
                search.tell(trial, 1.0 if failed else row["error"])  # a failed candidate: infeasible, a poor value
                rows.append({"trial": trial.number, **row})
            searched += len(asked)
            if progress is not None:
                progress(searched, trials)
    import pandas as pd

    frame = pd.DataFrame(rows)
    searched = frame[frame["trial"] >= 0]  # the answer lies in the box
    feasible = searched[searched["feasible"]]
    best = None
    if not feasible.empty:
        best = _plain(feasible.sort_values(["error", "trial"]).iloc[0].to_dict())
    tuned = copy.deepcopy(base)
    if best is not None:
        tuned.setdefault("controller", {}).update(kp=best["kp"], kv=best["kv"])
    return TuningResult(max_effort, quantile, frame, best, _plain(frame.iloc[0].to_dict()), _pareto(searched), tuned,
                        bounds, draws, (kp_lo, kp_hi), None if critical else (z_lo, z_hi), reason)


def default_kp_range(base: dict, spread: float = 0.0) -> tuple[tuple[float, float], str]:
    """The default kp box of a scenario (its tables ``base``) and why it ends there: :data:`KP_RANGE`, its upper
    end lowered, under sampled-data computed torque, to the largest critically damped kp whose loop is stable
    (rounded down to three digits) — beyond it every candidate's run is refused as unstable. ``spread``, the
    uncertainty of the drawn masses and inertias, raises the loop's modal gains to ``1 / (1 - spread)`` (a plant
    lighter than the model). Continuous-time control and the PD law keep :data:`KP_RANGE`."""
    from ..control.controller import largest_stable_kp
    from ..formats.scenario import scenario_from_dict

    scenario = scenario_from_dict(copy.deepcopy(base), "<tune>")
    ts = scenario.sample_time
    if not ts > 0 or scenario.controller.kind != "computed_torque":
        return KP_RANGE, ""
    mu = 1.0 / (1.0 - min(spread, 0.5))
    limit = largest_stable_kp(ts, [mu])
    if limit is None or not limit < KP_RANGE[1]:
        return KP_RANGE, ""
    digit = 10.0 ** (math.floor(math.log10(limit)) - 2)
    limit = float(f"{math.floor(limit / digit) * digit:.3g}")
    drawn = "" if spread == 0 else f" for plants drawn within {spread:g} of the model"
    return (KP_RANGE[0], limit), f"the sampled-data stability limit at Ts = {ts * 1e3:g} ms{drawn}"


def _box(name: str, value) -> tuple[float, float]:
    """A search box ``(low, high)``: two positive numbers, the first below the second."""
    try:
        lo, hi = value
    except (TypeError, ValueError):
        raise InvalidParameterError(f"{name} must be two positive numbers (low, high), got {value!r}") from None
    lo, hi = as_real(name, lo, "positive"), as_real(name, hi, "positive")
    if not lo < hi:
        raise InvalidParameterError(f"{name} = ({lo:g}, {hi:g}) is no box: its low end must be below its high end")
    return lo, hi


def _plain(row: dict) -> dict:
    return {k: (v.item() if hasattr(v, "item") else v) for k, v in row.items()}


def write_tuning(result: TuningResult, out, source: str) -> dict:
    """``tuned.toml`` (the scenario with the tuned gains), ``trials.csv``, ``tuning.json`` and ``tradeoff.png``
    in ``out``, each written whole or not at all. Returns the summary."""
    from ..formats.scenario import scenario_to_toml

    out = Path(out)
    summary = result.summary()
    best, base = result.best, result.baseline
    if best is not None:
        what = "worst-case" if result.quantile == 1 else f"{result.quantile:g}-quantile"
        comment = (f"Tuned by pkmlab tune from {Path(source).name}: kp = {best['kp']:.6g}, kv = {best['kv']:.6g} "
                   f"(zeta = {best['zeta']:.3g})\nminimise the {what} "
                   f"max path error over {result.draws} plants drawn around the scenario's, peak effort <= "
                   f"{result.max_effort:g}:\n{best['error']:.4e} m at peak effort {best['worst_effort']:.4g}; the "
                   f"first candidate, kp = {base['kp']:.6g}, kv = {base['kv']:.6g}, gave {base['error']:.4e} m at "
                   f"{base['worst_effort']:.4g}")
        with atomic_file(out / "tuned.toml") as tmp:
            tmp.write_text(scenario_to_toml(result.scenario, comment))
    with atomic_file(out / "trials.csv") as tmp:
        result.trials.to_csv(tmp, index=False)
    with atomic_file(out / "tuning.json") as tmp:
        tmp.write_text(json.dumps(summary, indent=1, default=str).replace("Infinity", "null"))
    fig = plot_tradeoff(result)
    with atomic_file(out / "tradeoff.png") as tmp:
        fig.savefig(tmp, dpi=130, format="png")
    return summary


def plot_tradeoff(result: TuningResult):
    """Every candidate's worst peak effort against its error, the trade-off curve (least error for each effort
    limit), the limit, the scenario's own gains and the tuned ones."""
    from matplotlib.figure import Figure  # not pyplot: a notebook's own figures and backend are left alone

    trials = result.trials
    ok = trials[trials["failed"] == 0]
    fig = Figure(figsize=(6.5, 4.5), layout="constrained")
    ax = fig.subplots()
    points = ax.scatter(ok["worst_effort"], ok["error"], c=np.log10(ok["kp"]), cmap="viridis", s=18,
                        label="candidates")
    fig.colorbar(points, ax=ax, label="log10 kp")
    right = max(result.max_effort, float(ok["worst_effort"].max()) if len(ok) else result.max_effort)
    if result.tradeoff:
        e, v = np.array(result.tradeoff).T
        ax.step(np.append(e, right * 1.02), np.append(v, v[-1]), where="post", color="k", lw=1.2,
                label="trade-off: least error within the effort limit")
    ax.axvline(result.max_effort, color="tab:red", ls="--", lw=1, label=f"effort limit {result.max_effort:g}")
    base = result.baseline
    if math.isfinite(base["error"]):
        ax.plot(base["worst_effort"], base["error"], "s", mfc="none", mec="tab:orange", ms=10,
                label=f"scenario's gains (kp = {base['kp']:.4g})")
    if result.best is not None:
        best = result.best
        ax.plot(best["worst_effort"], best["error"], "*", color="tab:red", ms=14,
                label=f"tuned: kp = {best['kp']:.4g}, kv = {best['kv']:.4g}")
    ax.set_yscale("log")  # efforts stay within a few per cent of the feed-forward's: a linear axis
    ax.set_xlabel("worst peak effort over the uncertainty set (N·m or N)")
    what = "worst-case" if result.quantile == 1 else f"{result.quantile:g}-quantile"
    ax.set_ylabel(f"{what} max path error (m)")
    ax.set_title(f"gain tuning: {len(trials)} candidates × {max(result.draws, 1)} plants", fontsize=10)
    ax.legend(fontsize=7, loc="upper right")
    return fig
