"""``pkmlab simulate``: one scenario file, its summary, time series, figures and report."""

from __future__ import annotations

from pathlib import Path

from ..errors import InvalidParameterError, PkmlabError
from ._common import loop_closures, model_of, notes, signs, status_messages


def _effort_unit(scenario) -> str:
    from ..simulation.result import actuator_kinds

    kinds = actuator_kinds(scenario.model)
    return "N m" if kinds == {"R"} else ("N" if kinds == {"P"} else "N m or N")


def cmd_simulate(args) -> dict:
    """One scenario file: summary.json, run.csv, plant.toml, figures and REPORT.md in --out."""
    from ..formats.params import read_text
    from ..formats.scenario import scenario_from_text
    from ..report import simulation_report

    text = read_text(Path(args.scenario))  # once: what is simulated is what is kept as scenario.toml
    scenario = scenario_from_text(text, args.scenario)
    if args.mechanism:  # another machine on the same scenario: the plant is that machine too
        args.params = None
        model = model_of(args)
        scenario = scenario.replace(model=model, plant=None, working_mode="auto")
    progress = status_messages(args)
    mujoco = None
    if args.plant == "mujoco":
        closures = loop_closures(args, "--mujoco-closures", args.mujoco_closures, "--mujoco-stiff", args.mujoco_stiff)
        mujoco = {"timestep": args.mujoco_timestep, "integrator": args.mujoco_integrator, "closures": closures}
        try:
            import mujoco as _mujoco  # noqa: F401
        except ImportError:
            raise PkmlabError("--plant mujoco needs MuJoCo: pip install 'pkmlab[mujoco]'") from None
    elif (args.mujoco_timestep is not None or args.mujoco_closures is not None or args.mujoco_stiff
          or args.mujoco_integrator != "RK4"):
        raise InvalidParameterError("--mujoco-timestep, --mujoco-integrator and --mujoco-closures (or the deprecated "
                                    "--mujoco-stiff) go with --plant mujoco")
    summary = simulation_report(scenario, args.out, figures=not args.no_figures, progress=progress,
                                source=args.scenario, source_text=text, note=notes(args), mujoco=mujoco)
    if not args.json:
        s = summary
        print(f"scenario {s['scenario']}: max path error {s['max_path_error_m']:.4e} m, "
              f"rms path error {s['rms_path_error_m']:.4e} m, peak effort {max(s['peak_effort']):.4f} "
              f"{_effort_unit(scenario)}, "
              f"min |S| {s['min_abs_S']:.4f}, working mode {signs(s['working_mode'])}"
              + (f", MuJoCo's max loop-closure violation {s['max_closure_violation_m']:.3e} m" if mujoco else ""))
        print(f"results in {args.out}/")
    return summary
