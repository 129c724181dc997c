"""``pkmlab sweep`` (a study over a grid of values and drawn plants) and ``pkmlab tune`` (gains for an effort
limit)."""

from __future__ import annotations

import math

from ..errors import InvalidParameterError
from ._common import notes


def _execution(args) -> dict:
    """Where a study's runs execute: ``--workers``, ``--scheduler``, ``--chunk-size`` (pkmlab.study.engine)."""
    if args.scheduler is not None and args.workers is not None:
        raise InvalidParameterError("--workers sizes the local cluster; with --scheduler the cluster's own workers "
                                    "run the study: give one of them")
    for name in ("workers", "chunk_size"):
        value = getattr(args, name)
        least = 0 if name == "workers" else 1
        if value is not None and value < least:
            raise InvalidParameterError(f"--{name.replace('_', '-')} must be {least} or more, got {value}")
    return {"workers": args.workers, "scheduler": args.scheduler, "chunk_size": args.chunk_size}


def cmd_sweep(args) -> dict:
    """A study file: every run on a Dask cluster (local by default), its table, summary.json and figures."""
    from ..study import StudyInterrupted, load_study, sweep
    from ..study.jobs import HEADLINE

    study = load_study(args.study)
    if args.heatmap is not None:
        args.heatmap = tuple(args.heatmap)
    quiet = args.quiet or args.json
    note = None if quiet else notes(args)
    try:
        frame = sweep(study, args.out, resume=args.resume, csv=args.csv, figures=not args.no_figures,
                      heatmap=args.heatmap, progress=not quiet, note=note, **_execution(args))
    except StudyInterrupted as exc:
        raise StudyInterrupted(f"{exc}: pkmlab sweep {args.study} --out {args.out} --resume") from None
    summary = frame.attrs["summary"]
    if not args.json:
        run = summary["execution"]
        print(f"{study.name}: {summary['runs']} runs, {summary['ok']} ok, {summary['failed']} failed"
              + (f" ({', '.join(f'{k} {v}' for k, v in summary['failures'].items())})" if summary["failed"] else ""))
        (first, first_label, _), (second, second_label, _) = HEADLINE[study.job]
        error = summary["metrics"].get(first)
        if error:
            print(f"{first_label}: median {error['median']:.3e}, worst {error['max']:.3e}")
        best = summary.get("best_point")
        if best:
            values = ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}"
                               for k, v in best["values"].items())
            print(f"best point ({values or 'the base'}): worst {first_label} {best[f'worst_{first}']:.3e}, "
                  f"{second_label} {best[f'worst_{second}']:.4g}")
        print(f"{run['runs_run']} runs in {run['wall_time_s']:.1f} s ({run['runs_per_s']:.1f} runs/s on "
              f"{run['workers']} worker{'s' if run['workers'] != 1 else ''}); table in {args.out}/runs.parquet")
    return summary


def _effort_unit(scenario_file) -> str:
    """The unit of the efforts of the scenario's machine: N m (revolute actuators), N (prismatic), or both."""
    from ..formats.scenario import load_scenario
    from ..simulation.result import actuator_kinds

    kinds = actuator_kinds(load_scenario(scenario_file).model)
    return "N m" if kinds == {"R"} else ("N" if kinds == {"P"} else "N m or N")


def cmd_tune(args) -> dict:
    """A scenario's gains tuned for an effort limit over an uncertainty set: tuned.toml, trials.csv, tuning.json
    and tradeoff.png in --out."""
    from ..outputs import atomic_output_dir
    from ..study.tuning import ZETA_RANGE, tune, write_tuning

    for ok, option, value, rule in ((args.trials >= 1, "--trials", args.trials, "a positive number of candidates"),
                                    (args.draws >= 0, "--draws", args.draws, "0 or more plants"),
                                    (0 <= args.uncertainty < 1, "--uncertainty", args.uncertainty, "in [0, 1)"),
                                    (0 < args.quantile <= 1, "--quantile", args.quantile, "in (0, 1]")):
        if not ok:
            raise InvalidParameterError(f"{option} must be {rule}, got {value:g}")
    for option, box in (("--kp-range", args.kp_range), ("--zeta-range", args.zeta_range)):
        if box is not None and not 0 < box[0] < box[1]:
            raise InvalidParameterError(f"{option} {box[0]:g} {box[1]:g}: give LO then HI, both positive, LO below HI")
    if args.critical and args.zeta_range is not None:
        raise InvalidParameterError("--critical tunes kp alone with zeta = 1 (kv = 2 sqrt(kp)): --zeta-range does not "
                                    "apply; give one of them")
    execution = _execution(args)
    quiet = args.quiet or args.json
    from ..progress import Progress

    bar = Progress(args.trials, "candidates", enabled=not quiet, unit="candidates")
    # the folder is checked before the work, and receives the trials even when no gains keep within the limit
    with atomic_output_dir(args.out, "tune", inputs=[args.scenario], note=notes(args)) as folder:
        with bar:
            result = tune(args.scenario, args.max_effort, uncertainty=args.uncertainty,
                          quantities=tuple(args.uncertain), draws=args.draws, seed=args.seed, quantile=args.quantile,
                          critical=args.critical, trials=args.trials,
                          kp_range=None if args.kp_range is None else tuple(args.kp_range),
                          zeta_range=tuple(args.zeta_range or ZETA_RANGE), workers=execution["workers"],
                          scheduler=execution["scheduler"], chunk_size=execution["chunk_size"],
                          progress=lambda done, _total: bar.update(done - bar.count))
        summary = write_tuning(result, folder, args.scenario)
    unit = _effort_unit(args.scenario)
    if result.best is None:
        raise InvalidParameterError(f"no gains tried keep the peak effort within {args.max_effort:g} {unit} on every "
                                    f"plant (the least reached: {result.trials['worst_effort'].min():.4g} {unit}); the "
                                    f"trials are in {args.out}/")
    if not args.json:
        best, base = result.best, result.baseline
        what = "worst-case" if args.quantile == 1 else f"{args.quantile:g}-quantile"
        print(f"tuned: kp = {best['kp']:.6g}, kv = {best['kv']:.6g} (zeta = {best['zeta']:.3g}): {what} max path "
              f"error {best['error']:.4e} m, peak effort {best['worst_effort']:.4g} {unit} (limit "
              f"{args.max_effort:g} {unit})")
        which = "the scenario's kp, critically damped" if args.critical else "the scenario's gains"
        if math.isfinite(base["error"]):
            print(f"{which} (kp = {base['kp']:.6g}, kv = {base['kv']:.6g}): {base['error']:.4e} m, "
                  f"peak effort {base['worst_effort']:.4g} {unit}")
        else:
            print(f"{which} (kp = {base['kp']:.6g}, kv = {base['kv']:.6g}): some run failed")
        print(f"{len(result.trials)} candidates x {max(args.draws, 1)} plants; pkmlab simulate {args.out}/tuned.toml "
              "runs the tuned scenario")
    say = notes(args)
    for sentence in result.on_bound:  # the optimum may lie beyond the box: the user decides whether to widen it
        say(f"{sentence}: {'widen --kp-range' if sentence.startswith('the tuned kp') else 'widen --zeta-range'} "
            "if the machine allows")
    return summary
