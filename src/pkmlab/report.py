"""The paper's reproduction: the three simulated cases, their data, figures and a report.

:func:`reproduce` writes into a folder: ``summary.json``, one CSV per case (conventions §8
columns), a PNG per figure of the paper (3–15), ``REPORT.md`` comparing the cases and ``REPORT.html``
(each case animated beside its time series, :mod:`pkmlab.views`). All files are written into a
temporary folder beside the target and moved into place only when everything succeeded, so an error
or Ctrl-C leaves no half-written results.

:func:`simulation_report` does the same for one scenario (``pkmlab simulate``): ``summary.json``,
``run.csv``, ``plant.toml`` (the real machine's description), its figures, ``REPORT.md`` and
``REPORT.html``.
"""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path

from .control.time_optimal import TimeOptimal
from .errors import PkmlabError
from .formats.scenario import PAPER_CASES, SCENARIO_DIR, paper_scenario
from .outputs import atomic_output_dir
from .simulation import run as simulation
from .simulation.ahead import compile_loop_ahead
from .simulation.result import SimulationResult, actuator_kinds, summary_units
from .simulation.run import prepare_run, run_prepared
from .simulation.scenario import Scenario

#: (file name, paper figure, caption, case, plot kind)
FIGURES = (
    ("fig03_singularity_map.png", "3", "S over the workspace at α = 0 with the desired circle", None, "map"),
    ("fig04_initial_configuration.png", "4", "Initial configuration: x = 0.20, y = 0.21, α = 0", None, "start"),
    ("fig05_singularity_along_path.png", "5", "S along the trajectory (nominal case)", "nominal", "S"),
    ("fig06_nominal_path.png", "6", "Path tracked vs desired (nominal)", "nominal", "path"),
    ("fig07_nominal_path_error.png", "7", "Error in path tracking (nominal)", "nominal", "error"),
    ("fig08_nominal_alpha.png", "8", "Platform orientation α (nominal)", "nominal", "alpha"),
    ("fig09_nominal_torques.png", "9", "Joint torques (nominal)", "nominal", "efforts"),
    ("fig10_disturbed_path.png", "10", "Path tracked vs desired, plant masses and lengths +15 %", "disturbed", "path"),
    ("fig11_disturbed_path_error.png", "11", "Error in path tracking, plant +15 %", "disturbed", "error"),
    ("fig12_disturbed_torques.png", "12", "Joint torques, plant +15 %", "disturbed", "efforts"),
    ("fig12b_disturbed_alpha.png", "—", "Platform orientation α, plant +15 % (not in the paper)", "disturbed", "alpha"),
    ("fig13_fast_path.png", "13", "Path tracked vs desired, v = 0.4 m/s", "fast", "path"),
    ("fig14_fast_path_error.png", "14", "Error in path tracking, v = 0.4 m/s", "fast", "error"),
    ("fig15_fast_torques.png", "15", "Joint torques, v = 0.4 m/s", "fast", "efforts"),
    ("fig15b_fast_alpha.png", "—", "Platform orientation α, v = 0.4 m/s (not in the paper)", "fast", "alpha"),
)

#: Plots of one closed-loop result, by kind: the names of their functions in :mod:`pkmlab.views.plotting`.
_RESULT_PLOTS = {"S": "plot_singularity_along_path", "path": "plot_path", "error": "plot_path_error",
                 "alpha": "plot_alpha", "efforts": "plot_efforts", "machine": "plot_start_configuration",
                 "path3d": "plot_path_3d", "machine3d": "plot_start_configuration"}
#: The plot kinds drawn on 3-D axes.
_SPATIAL_PLOTS = ("path3d", "machine3d")

#: Figures of one scenario's run (``pkmlab simulate``): (file name, caption, plot kind).
RUN_FIGURES = (
    ("path.png", "Path tracked vs desired", "path"),
    ("path_error.png", "Error in path tracking", "error"),
    ("alpha.png", "Platform orientation α, actual and desired", "alpha"),
    ("torques.png", "Joint torques", "efforts"),
    ("singularity_along_path.png", "Singularity measure S of the plant along the run", "S"),
)


def run_figures(scenario: Scenario) -> tuple[tuple[str, str, str], ...]:
    """The figures of one run: a drawing of the machine at the start, then :data:`RUN_FIGURES`, its efforts
    named as they are, without the orientation for a machine whose pose has no ``alpha``, the path in space
    for a spatial machine."""
    kinds = actuator_kinds(scenario.model)
    m = scenario.model.description
    spatial = getattr(m, "spatial", False)
    out = [("machine.png", "The machine at the start of the run", "machine3d" if spatial else "machine")]
    for fname, caption, kind in RUN_FIGURES:
        if kind == "alpha" and "alpha" not in m.pose_names:
            continue
        if kind == "path" and spatial:
            caption, kind = "Path tracked vs desired, in space", "path3d"
        if kind == "efforts" and kinds != {"R"}:
            fname, caption = "efforts.png", "Actuator efforts (forces of prismatic actuators in N)"
        out.append((fname, caption, kind))
    return tuple(out)


def case_scenarios(control: str = "sampled", mechanism=None) -> dict[str, Scenario]:
    """The paper's three cases (conventions §7), with sampled-data or continuous-time control.

    ``mechanism`` (anything :func:`pkmlab.load` takes; default the paper's) puts the cases on another
    machine whose pose is ``(x, y, alpha)``: it becomes the controller's model, and the plant of each case
    is derived from it as the case's scenario file says (``disturbed``: masses and lengths ×1.15).
    """
    from ._files import read_toml
    from .model.mechanism_model import load
    from .simulation.scenario import scaled_model

    if control not in ("sampled", "continuous"):
        raise PkmlabError(f"control must be 'sampled' or 'continuous', got {control!r}")
    model = None if mechanism is None else load(mechanism)
    scenarios = {}
    for name in PAPER_CASES:
        scenario = paper_scenario(name)
        if model is not None:
            plant = read_toml(SCENARIO_DIR / f"{name}.toml").get("plant", {})
            mass, length = plant.get("mass_scale", 1.0), plant.get("length_scale", 1.0)
            try:
                scenario = scenario.replace(model=model, plant=None if mass == length == 1.0 else
                                            scaled_model(model, mass, length))
            except PkmlabError as exc:
                raise type(exc)(f"case {name} on {model.name}: {exc}") from None
        if control == "continuous":
            scenario = scenario.replace(sample_time=0.0)
        scenarios[name] = scenario
    return scenarios


def run_cases(scenarios: dict[str, Scenario]) -> dict[str, SimulationResult]:
    """Simulate the paper's three cases (as :func:`case_scenarios` gives them); an error names the case.

    Every case is prepared before the first runs: from an empty kernel cache, their preparation (the disturbed
    plant's forward kinematics among it) compiles while a second process compiles their loop
    (:mod:`pkmlab.simulation.ahead`)."""
    def of_case(name, step, *args):
        try:
            return step(*args)
        except PkmlabError as exc:
            raise type(exc)(f"case {name}: {exc}") from None

    for scenario in scenarios.values():
        compile_loop_ahead(scenario)
    prepared = {name: of_case(name, prepare_run, scenario) for name, scenario in scenarios.items()}
    return {name: of_case(name, run_prepared, scenario, prepared[name]) for name, scenario in scenarios.items()}


def provenance(control: str, sample_time: float, mechanism_source: str) -> dict:
    """How a result was made: pkmlab's version, the control mode, the machine, the software."""
    import platform

    import numpy as np
    import scipy

    from ._version import __version__

    return {
        "pkmlab_version": __version__,
        "control": control,
        "sample_time_s": sample_time if control == "sampled" else None,
        "mechanism": mechanism_source,
        "python": platform.python_version(),
        "numpy": np.__version__,
        "scipy": scipy.__version__,
    }


def _draw(kind: str, results: dict, case: str | None):
    import matplotlib.pyplot as plt

    from .algorithms.analysis import singularity_map
    from .views import plotting

    nominal = results["nominal"]
    model = nominal.scenario.model
    fig, ax = plt.subplots(figsize=(6.4, 4.8) if kind in ("error", "alpha", "efforts", "S") else (6.0, 5.2),
                           layout="constrained")
    if kind == "map":
        smap = singularity_map(model, alpha=0.0, mode=nominal.working_mode, resolution=241)
        plotting.plot_singularity_map(smap, ax=ax, model=model, path_xy=nominal.pose_d[:, :2])
    elif kind == "start":
        plotting.plot_configuration(model, nominal.q[0], ax=ax,
                                    title="initial configuration: x = 0.20 m, y = 0.21 m, α = 0")
    else:
        getattr(plotting, _RESULT_PLOTS[kind])(results[case], ax=ax)
    return fig


def _provenance_lines(prov: dict) -> list[str]:
    control = ("sampled-data, Ts = " f"{prov['sample_time_s'] * 1e3:g} ms (zero-order hold)"
               if prov["control"] == "sampled" else "continuous-time (torque re-evaluated at every integrator stage)")
    return [
        "| how this was made | |",
        "| --- | --- |",
        f"| control | {control} |",
        f"| mechanism | {prov['mechanism']} |",
        *([f"| scenario | {prov['scenario']} |"] if "scenario" in prov else []),
        *([f"| plant | {prov['plant']} |"] if "plant" in prov else []),
        f"| software | pkmlab {prov['pkmlab_version']}, Python {prov['python']}, NumPy {prov['numpy']}, "
        f"SciPy {prov['scipy']} |",
        "",
    ]


def _report(results: dict, summary: dict, figures: bool, prov: dict) -> str:
    nominal = summary["nominal"]
    paper = prov["mechanism"] == PAPER_MECHANISM
    lines = [
        "# pkmlab: reproduction of the paper's simulated cases" if paper
        else "# pkmlab: the paper's simulated cases on another machine",
        "",
        "Planar 3-RRR, computed-torque control (kp = 1000, kv = 2√kp), the circle of conventions §4. "
        "Path error: distance between the plant's actual centroid (its own geometry) and the desired one.",
        "",
        *([] if paper else ["**These are not the paper's numbers**: the cases run on the machine of "
                            f"{prov['mechanism']} (`mechanism.toml`; each case's plant in "
                            "`<case>_plant.toml`).", ""]),
        *_provenance_lines(prov),
        "| case | speed (m/s) | max path error (mm) | rms path error (mm) | max α error (rad) | "
        "peak torques (N·m) | peak torque / nominal | min abs(S) | working mode |",
        "| --- | --- | --- | --- | --- | --- | --- | --- | --- |",
    ]
    for name in PAPER_CASES:
        s = summary[name]
        speed = results[name].scenario.trajectory.speed
        ratio = max(s["peak_torque_Nm"]) / max(nominal["peak_torque_Nm"])
        lines.append(
            f"| {name} | {speed:g} | {s['max_path_error_m'] * 1e3:.4g} | {s['rms_path_error_m'] * 1e3:.4g} | "
            f"{s['max_alpha_error_rad']:.3g} | {', '.join(f'{v:.3f}' for v in s['peak_torque_Nm'])} | "
            f"{ratio:.2f} | {s['min_abs_S']:.3f} | {tuple(s['working_mode'])} |"
        )
    lines += ["", "Data: `summary.json`, `nominal.csv`, `disturbed.csv`, `fast.csv` (one row per sample); the "
              "controller's model in `mechanism.toml` and each case's plant in `<case>_plant.toml`.", ""]
    if figures:
        lines += ["## Figures", "", "[`REPORT.html`](REPORT.html): the three runs interactive — each machine animated "
                  "beside its time series (open it in a browser; it works offline).", ""]
        for fname, number, caption, _case, _kind in FIGURES:
            label = f"Figure {number}" if number != "—" else "Extra figure"
            lines += [f"### {label}: {caption}", "", f"![{caption}]({fname})", ""]
    return "\n".join(lines) + "\n"


#: How the report names the paper's own machine.
PAPER_MECHANISM = "the paper's (its section 5)"


def reproduce(out: str | os.PathLike = "out", control: str = "sampled", figures: bool = True,
              progress: Callable[[str], None] | None = None, mechanism=None,
              note: Callable[[str], None] | None = None, source: str | os.PathLike | None = None) -> dict:
    """Run the three cases and write their results into ``out``; return the summary dict.

    ``mechanism`` (a preset's name, a description file, a description or a model: :func:`pkmlab.load`) runs
    the cases on that machine instead of the paper's; the report says so in its title. ``summary.json``
    records how the results were made (``"provenance"``: control mode, sample time, mechanism, versions).
    ``note`` is told when an earlier result is replaced (:func:`~pkmlab.outputs.atomic_output_dir`).
    ``source``, the file the machine was read from (by default ``mechanism`` when it is a file's name), is
    named in the provenance and may not lie inside ``out``.
    """
    from .description.files import mechanism_to_toml

    say = progress or (lambda _msg: None)
    scenarios = case_scenarios(control, mechanism)  # a bad machine is refused before anything is written
    if source is None and isinstance(mechanism, str | os.PathLike) and Path(mechanism).suffix == ".toml":
        source = mechanism
    from .model.mechanism_model import load

    given = scenarios["nominal"].model != load("paper")  # the paper's own machine, however it was given
    name = f"your file {source}" if source is not None else f"the {scenarios['nominal'].model.name} preset"
    prov = provenance(control, scenarios["nominal"].sample_time or 1e-3, name if given else PAPER_MECHANISM)
    inputs = [source] if source is not None else []
    with atomic_output_dir(out, "reproduce", inputs=inputs, provenance=prov, note=note) as tmp:
        say(f"simulating the paper's cases ({control} control) ...")
        results = run_cases(scenarios)
        cases = {name: results[name].summary() for name in PAPER_CASES}
        summary = {"cases": cases, "units": _units_of(cases["nominal"], scenarios["nominal"].model), "provenance": prov}
        (tmp / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        (tmp / "mechanism.toml").write_text(mechanism_to_toml(
            scenarios["nominal"].model.description, "The controller's model of the paper's cases, written by pkmlab."))
        for name, result in results.items():
            result.to_csv(tmp / f"{name}.csv")
            (tmp / f"{name}_plant.toml").write_text(mechanism_to_toml(
                result.scenario.plant_model.description,
                f"The plant (the real machine) of case {name!r}, written by pkmlab."))
        if figures:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt

            for fname, _number, _caption, case, kind in FIGURES:
                fig = _draw(kind, results, case)
                fig.savefig(tmp / fname, dpi=150)
                plt.close(fig)
            say(f"drew {len(FIGURES)} figures")
        (tmp / "REPORT.md").write_text(_report(results, summary["cases"], figures, prov))
        if figures:
            from .views.html import write_html
            from .views.run import RunView

            write_html(tmp / "REPORT.html", [RunView.from_result(results[name], name, (
                SCENARIO_DIR / f"{name}.toml").read_text()) for name in PAPER_CASES],
                "pkmlab reproduce: the paper's three cases", note=f"Mechanism: {prov['mechanism']}; "
                f"{prov['control']} control.")
            say("wrote the interactive report")
    say(f"wrote {out}/")
    return summary


# ------------------------------------------------------------------ one scenario
def _describe(scenario: Scenario) -> list[tuple[str, str]]:
    traj = scenario.trajectory
    retimed = traj if isinstance(traj, TimeOptimal) else None
    traj = traj.original if retimed else traj
    path = getattr(traj, "path", None)
    timing = f"average speed {getattr(traj, 'speed', 0.0):g} m/s, {getattr(traj, 'law', '')} time law"
    if path is not None and hasattr(path, "radius"):
        shape = (f"circle, centre ({path.center[0]:g}, {path.center[1]:g}) m, radius {path.radius:g} m, "
                 f"{path.turns:g} turn(s)")
    elif path is not None:
        shape = f"line from {list(path.start)} to {list(path.end)}"
    elif hasattr(traj, "harmonics"):
        shape = (f"Fourier series of {traj.harmonics} harmonics about {[float(v) for v in traj.center]}, "
                 f"period {traj.period:g} s, {traj.periods} period(s)")
        timing = "periodic, at rest at the start and end of each period"
    elif hasattr(traj, "durations"):
        shape = (f"{len(traj.points)} waypoints from {list(traj.points[0])}, segment times "
                 f"{', '.join(f'{d:g}' for d in traj.durations)} s")
        timing = (f"{traj.law} time law per segment" if hasattr(traj, "law")
                  else "a cubic spline through them, at rest at its ends")
    else:
        shape = f"{len(traj.segments) + 1} waypoints"
    if retimed is not None:
        limits = "; ".join(f"{kind} {', '.join(f'{v:g}' for v in value)}" for kind, value in retimed.limits.items())
        timing = (f"time-optimal under the actuators' limits ({limits}); the path's own timing {traj.duration:.4g} s, "
                  f"{timing}")
        traj = retimed
    spec = scenario.controller
    machine = scenario.model.description
    return [
        ("machine", f"{machine.name} ({machine.notation}), pose ({', '.join(machine.pose_names)})"),
        ("trajectory", f"{shape}; {timing}, duration {traj.duration:.4g} s"),
        ("controller", f"{spec.kind}, kp = {spec.kp:g}, kv = {spec.velocity_gain:.4g}"),
        ("plant", "identical to the controller's model" if scenario.plant is None
         else "its own parameters, see `plant.toml`"),
        ("working mode", "chosen automatically (max min abs(S) along the path)"
         if scenario.working_mode == "auto" else str(tuple(scenario.working_mode))),
    ]


def _units_of(summary: dict, model) -> dict[str, str]:
    """The unit of each key of a run's ``summary`` on ``model``'s machine (``summary.json``'s ``"units"``)."""
    units = summary_units(model)
    return {key: units.get(key, "") for key in summary}


def _summary_table(result: SimulationResult, s: dict) -> list[str]:
    """The summary as a Markdown table (units as the machine's: rad or m, N·m or N)."""
    kinds = actuator_kinds(result.scenario.model)
    joint_unit = "rad" if kinds == {"R"} else ("m" if kinds == {"P"} else "rad or m")
    effort = ("peak torques (N·m)" if kinds == {"R"} else "peak forces (N)" if kinds == {"P"}
              else "peak efforts (N·m or N)")
    alpha = "max_orientation_error_rad" in s
    spatial = getattr(result.scenario.model.description, "spatial", False)
    turn = "max orientation error (rad)" if spatial else "max α error (rad)"
    head = (["max path error (mm)", "rms path error (mm)"] + ([turn] if alpha else [])
            + [f"max joint error ({joint_unit})", effort, "min abs(S)", "working mode"])
    row = ([f"{s['max_path_error_m'] * 1e3:.4g}", f"{s['rms_path_error_m'] * 1e3:.4g}"]
           + ([f"{s['max_orientation_error_rad']:.3g}"] if alpha else [])
           + [f"{s['max_joint_error']:.3g}", ", ".join(f"{v:.3f}" for v in s["peak_effort"]), f"{s['min_abs_S']:.3f}",
              str(tuple(s["working_mode"]))])
    return ["| " + " | ".join(head) + " |", "|" + " --- |" * len(head), "| " + " | ".join(row) + " |"]


def _run_report(result: SimulationResult, summary: dict, figures: bool) -> str:
    s = summary
    lines = [f"# pkmlab: scenario `{result.scenario.name}`", "", "| | |", "| --- | --- |"]
    lines += [f"| {key} | {value} |" for key, value in _describe(result.scenario)]
    lines += ["", *_provenance_lines(summary["provenance"])]
    lines += [
        "",
        "## Summary",
        "",
        *_summary_table(result, s),
        "",
        "Data: `summary.json`, `run.csv` (one row per sample), `plant.toml` (the plant's parameters)"
        + (", `scenario.toml` (the scenario file, as it was read)." if "scenario" in s["provenance"] else "."),
        "",
    ]
    if figures:
        lines += ["## Figures", "", "[`REPORT.html`](REPORT.html): the run interactive — the machine animated beside "
                  "its time series (open it in a browser; it works offline).", ""]
        for fname, caption, _kind in run_figures(result.scenario):
            lines += [f"### {caption}", "", f"![{caption}]({fname})", ""]
    return "\n".join(lines) + "\n"


def simulation_report(scenario: Scenario, out: str | os.PathLike, figures: bool = True,
                      progress: Callable[[str], None] | None = None,
                      source: str | os.PathLike | None = None, source_text: str | None = None,
                      note: Callable[[str], None] | None = None, mujoco: dict | None = None) -> dict:
    """Simulate ``scenario`` and write its results into the folder ``out``; return the summary.

    ``out`` receives ``summary.json`` (conventions §8 fields, ``"scenario"``, the name, and
    ``"provenance"``), ``run.csv``, ``plant.toml``, the figures of :data:`RUN_FIGURES`, ``REPORT.md`` and
    ``REPORT.html`` (:mod:`pkmlab.views`) — all at once, when everything succeeded. ``mujoco`` (the options of
    :func:`~pkmlab.interop.mujoco_plant.simulate_mujoco`) makes MuJoCo the plant: the run then also records its
    loop-closure violation
    (:func:`~pkmlab.outputs.atomic_output_dir`, which tells ``note`` when an earlier result is
    replaced). ``source``, the scenario file the scenario was read from, may not lie inside
    ``out``; its text (``source_text``, as it was read, else read again) is kept as ``scenario.toml``.
    """
    from ._files import read_text
    from .description.files import mechanism_to_toml

    text = source_text if source_text is not None or source is None else read_text(Path(source))
    control = "sampled" if scenario.sample_time > 0 else "continuous"
    prov = {**provenance(control, scenario.sample_time, "the scenario's [mechanism]; the plant in plant.toml"),
            **({"scenario": str(source)} if source is not None else {})}
    if mujoco is not None:
        prov["plant"] = (f"MuJoCo, time step {mujoco.get('timestep') or min(scenario.sample_time, 1e-3):g} s, "
                         f"{mujoco.get('integrator', 'RK4')}, "
                         + ("stiffest" if mujoco.get("closures", "stiff") == "stiff" else "MuJoCo's default (soft)")
                         + " loop-closure constraints")
    say = progress or (lambda _msg: None)
    with atomic_output_dir(out, "simulate", inputs=[source] if source else [], provenance=prov, note=note) as tmp:
        say(f"simulating {scenario.name}{' on MuJoCo' if mujoco is not None else ''} ...")
        if mujoco is not None:
            from .interop.mujoco_plant import simulate_mujoco

            result = simulate_mujoco(scenario, **mujoco)
        else:
            result = simulation.simulate(scenario)
        numbers = result.summary()
        summary = {"scenario": scenario.name, **numbers, "units": _units_of(numbers, result.scenario.model),
                   "provenance": prov}
        (tmp / "summary.json").write_text(json.dumps(summary, indent=2) + "\n")
        if text is not None:
            (tmp / "scenario.toml").write_text(text)
        result.to_csv(tmp / "run.csv")
        comment = f"The plant (the real machine) of scenario {scenario.name!r}, written by pkmlab."
        (tmp / "plant.toml").write_text(mechanism_to_toml(scenario.plant_model.description, comment))
        if figures:
            import matplotlib

            matplotlib.use("Agg")
            import matplotlib.pyplot as plt

            from .views import plotting

            for fname, _caption, kind in run_figures(scenario):
                size = (6.0, 5.2) if kind in ("path", "machine") else (6.0, 5.6) if kind in _SPATIAL_PLOTS \
                    else (6.4, 4.8)
                if kind in _SPATIAL_PLOTS:
                    fig = plt.figure(figsize=size, layout="constrained")
                    ax = fig.add_subplot(projection="3d")
                else:
                    fig, ax = plt.subplots(figsize=size, layout="constrained")
                try:
                    getattr(plotting, _RESULT_PLOTS[kind])(result, ax=ax)
                    fig.savefig(tmp / fname, dpi=150)
                finally:
                    plt.close(fig)
            say(f"drew {len(run_figures(scenario))} figures")
        (tmp / "REPORT.md").write_text(_run_report(result, summary, figures))
        if figures:
            from .views.html import write_html
            from .views.run import RunView

            write_html(tmp / "REPORT.html", [RunView.from_result(result, scenario.name, text or "")],
                       f"pkmlab simulate: {scenario.name}")
    say(f"wrote {out}/")
    return summary
