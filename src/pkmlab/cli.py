"""The ``pkmlab`` command line: a thin layer over the library.

Exit codes: 0 success; 1 a problem with the input (unreachable pose, invalid parameter,
unreadable file, ...), reported as one line on stderr (or as ``{"error": ...}`` on stdout
with ``--json``); 2 a malformed command line; 130 interrupted.
"""

from __future__ import annotations

import sys

try:  # Ctrl-C while the command line itself loads (its own imports): a quiet exit, as anywhere later
    import argparse
    import json
    import math
    import re
    from pathlib import Path

    from ._version import __version__
    from .errors import AssemblyError, InvalidParameterError, PkmlabError, SingularityError
except KeyboardInterrupt:
    print("pkmlab: interrupted", file=sys.stderr)
    raise SystemExit(130) from None


def _model(args):
    from .geometry import Planar3RRR
    from .io import load_manipulator

    return load_manipulator(args.params) if args.params else Planar3RRR.paper()


def _signs(mode) -> str:
    return "(" + ", ".join("+" if m > 0 else "-" for m in mode) + ")"


def _table(header: list[str], rows: list[list]) -> str:
    cells = [header] + [[f"{v:+.6f}" if isinstance(v, float) else str(v) for v in row] for row in rows]
    widths = [max(len(r[i]) for r in cells) for i in range(len(header))]
    return "\n".join("  ".join(c.rjust(w) for c, w in zip(r, widths, strict=True)) for r in cells)


def _mechanism(args):
    """The machine of ``--mechanism``: a preset name or a description file (``[mechanism]`` table)."""
    from .mechanism_model import MechanismModel
    from .mechanisms.description import load_mechanism
    from .mechanisms.presets import PRESETS

    if args.params:
        raise InvalidParameterError("--params describes the paper's 3-RRR; with --mechanism, give a description "
                                    "file instead")
    if args.mechanism in PRESETS:
        return MechanismModel.from_preset(args.mechanism)
    if not Path(args.mechanism).suffix:
        raise InvalidParameterError(f"--mechanism {args.mechanism}: not a preset ({', '.join(PRESETS)}) nor a "
                                    ".toml file")
    return MechanismModel.from_description(load_mechanism(args.mechanism))


def _count(args, values, n: int, what: str) -> None:
    """As many numbers as the machine needs, or a malformed command line (usage, exit code 2)."""
    if len(values) != n:
        args.parser.error(f"{what}: {n} numbers for this machine, got {len(values)}")


def cmd_ik_mechanism(args) -> dict:
    """``ik --mechanism M POSE...``: ``{"solutions": [{"mode", "actuators", "S"}, ...]}``, one per working mode
    that reaches the pose (one contract for every machine)."""
    from . import mechanism_model as mm
    from .errors import UnreachablePoseError

    model = _mechanism(args)
    names = model.description.pose_names
    _count(args, args.pose, len(names), f"the pose ({', '.join(names)})")
    modes = mm.working_modes(model)
    if args.mode is not None:
        if args.mode not in modes:
            raise InvalidParameterError(f"--mode must be one of {', '.join(_signs(m) for m in modes)} for a "
                                        f"{model.description.notation}, got {_signs(args.mode)}")
        modes = [args.mode]
    solutions, reasons = [], []
    for mode in modes:
        try:
            q = mm.inverse_kinematics(model, args.pose, mode)
        except UnreachablePoseError as exc:
            reasons.append(str(exc))
            continue
        solutions.append({"mode": list(mode), "actuators": q[:model.n_actuators].tolist(),
                          "S": mm.singularity_measure(model, q)})
    if not solutions:
        where = f"in working mode {_signs(args.mode)}" if args.mode is not None else "in every working mode"
        raise UnreachablePoseError(f"pose {args.pose} is out of reach {where}: {reasons[0]}")
    if not args.json:
        print(f"inverse kinematics of the {model.description.name} ({model.description.notation}) at "
              + ", ".join(f"{n} = {v:g}" for n, v in zip(names, args.pose, strict=True)))
        header = ["mode", *(f"actuator{i + 1}" for i in range(model.n_actuators)), "S"]
        print(_table(header, [[_signs(s["mode"]) if s["mode"] else "-", *s["actuators"], s["S"]] for s in solutions]))
    return {"solutions": solutions}


def cmd_fk_mechanism(args) -> dict:
    """``fk --mechanism M ACTUATORS...``: ``{"solutions": [{"pose", "S"}, ...]}``, every assembly mode."""
    from . import mechanism_model as mm

    model = _mechanism(args)
    _count(args, args.actuators, model.n_actuators, "the actuator values")
    found = mm.forward_kinematics(model, args.actuators)
    dof = model.description.dof
    solutions = [{"pose": q[-dof:].tolist(), "S": s} for q, s in found]
    if not args.json:
        print(f"forward kinematics of the {model.description.name} ({model.description.notation}) at actuators "
              f"{' '.join(f'{v:g}' for v in args.actuators)}: {len(solutions)} assembly mode(s)")
        rows = [[str(j + 1), *sol["pose"], sol["S"]] for j, sol in enumerate(solutions)]
        print(_table(["#", *model.description.pose_names, "S"], rows))
    return {"solutions": solutions}


def cmd_ik(args) -> dict:
    import numpy as np

    from .kinematics import inverse_kinematics

    if args.mechanism is not None:
        return cmd_ik_mechanism(args)
    _count(args, args.pose, 3, "ik of the paper's 3-RRR (x y alpha)")
    args.x, args.y, args.alpha = args.pose
    model = _model(args)
    pose = [args.x, args.y, args.alpha]
    ik = inverse_kinematics(model, pose, mode=args.mode)
    q = ik.q[None] if args.mode else ik.q
    modes = ik.modes[None] if args.mode else ik.modes
    svals = np.atleast_1d(ik.S)
    solutions = [
        {"mode": [int(v) for v in m], "theta": qi[:3].tolist(), "phi": qi[3:6].tolist()}
        for m, qi in zip(modes, q, strict=True)
    ]
    if not args.json:
        print(f"inverse kinematics of x = {args.x:g} m, y = {args.y:g} m, alpha = {args.alpha:g} rad")
        rows = [[_signs(m), *qi[:6].tolist(), float(s)] for m, qi, s in zip(modes, q, svals, strict=True)]
        print(_table(["mode", "theta1", "theta2", "theta3", "phi1", "phi2", "phi3", "S"], rows))
    return {"solutions": solutions}


def cmd_fk(args) -> dict:
    from .kinematics import forward_kinematics

    if args.mechanism is not None:
        return cmd_fk_mechanism(args)
    _count(args, args.actuators, 3, "fk of the paper's 3-RRR (theta1 theta2 theta3)")
    args.t1, args.t2, args.t3 = args.actuators
    model = _model(args)
    theta = [args.t1, args.t2, args.t3]
    fk = forward_kinematics(model, theta)
    if len(fk) == 0:
        raise AssemblyError(f"theta = {theta} cannot be assembled: forward kinematics has no real solution")
    solutions = [
        {"x": float(s.pose[0]), "y": float(s.pose[1]), "alpha": float(s.pose[2]),
         "phi": s.q[3:6].tolist(), "S": s.S}
        for s in fk
    ]
    if not args.json:
        print(f"forward kinematics of theta = ({args.t1:g}, {args.t2:g}, {args.t3:g}) rad: "
              f"{len(fk)} assembly mode(s)")
        rows = [[str(j + 1), d["x"], d["y"], d["alpha"], *d["phi"], d["S"]] for j, d in enumerate(solutions)]
        print(_table(["#", "x", "y", "alpha", "phi1", "phi2", "phi3", "S"], rows))
    return {"solutions": solutions}


def cmd_demo(args) -> dict:
    """Kinematics demo on the paper's circle: IK, FK, branch following and figure 3."""
    import matplotlib

    from .outputs import atomic_output_dir

    matplotlib.use("Agg")

    def say(text: str) -> None:  # progress report, kept off stdout with --json
        if not args.json:
            print(text)

    model = _model(args)
    _resolution(args.resolution)  # refused before anything is computed or printed
    out_dir = Path(args.out)
    provenance = {"pkmlab_version": __version__, "resolution": args.resolution,
                  "manipulator": f"your parameter file {args.params}" if args.params else "the paper's"}
    with atomic_output_dir(out_dir, "demo", inputs=[args.params] if args.params else [], provenance=provenance,
                           note=_note(args)) as tmp:
        mode = _demo(args, model, say, tmp)
    out = out_dir / "fig03_singularity_map.png"
    say(f"wrote {out}")
    return {"working_mode": list(mode), "figure": str(out)}


def _demo(args, model, say, folder: Path) -> tuple:
    import matplotlib.pyplot as plt
    import numpy as np

    from .analysis import singularity_map
    from .kinematics import branch_following, forward_kinematics, inverse_kinematics
    from .plotting import plot_singularity_map

    start = np.array([0.20, 0.21, 0.0])
    s_path = np.linspace(0.0, 2 * np.pi, 721)
    path = np.stack([0.25 + 0.05 * np.cos(np.pi + s_path), 0.21 + 0.05 * np.sin(np.pi + s_path),
                     np.zeros_like(s_path)], axis=-1)
    ik_path = inverse_kinematics(model, path, on_unreachable="nan")
    min_s = np.nanmin(np.abs(ik_path.S), axis=0)
    best = int(np.nanargmax(min_s))
    mode = tuple(int(m) for m in ik_path.modes[best])
    say("paper circle: min |S| along the path per working mode: "
        + ", ".join(f"{_signs(m)} {v:.3f}" for m, v in zip(ik_path.modes, min_s, strict=True)))
    say(f"working mode maximising min |S|: {_signs(mode)}")
    ik = inverse_kinematics(model, start, mode=mode)
    fk = forward_kinematics(model, ik.theta)
    say(f"start pose {start.tolist()}: theta = {np.round(ik.theta, 6).tolist()}, "
        f"{len(fk)} assembly modes:")
    for j, sol in enumerate(fk):
        say(f"  {j + 1}: x = {sol.pose[0]:+.6f}  y = {sol.pose[1]:+.6f}  alpha = {sol.pose[2]:+.6f}  "
            f"S = {sol.S:+.4f}")
    # Branch following around the circle, driven by the IK of the chosen working mode.
    q = fk.nearest(start).q
    worst = 0.0
    for k in range(1, len(path)):
        q = branch_following(model, q, ik_path.q[k, best, :3])
        worst = max(worst, float(np.max(np.abs(q[3:] - ik_path.q[k, best, 3:]))))
    say(f"branch following around the circle: largest deviation from IK passive angles {worst:.2e} rad")
    smap = singularity_map(model, alpha=0.0, mode=mode, resolution=args.resolution)
    ax = plot_singularity_map(smap, model=model, path_xy=path[:, :2])
    try:
        ax.figure.savefig(folder / "fig03_singularity_map.png", dpi=150)
    finally:
        plt.close(ax.figure)
    return mode



# argparse reads only "-1" and "-1.5" as negative numbers: "-1e-3", "-1.2E+00" or "-inf" would be
# taken for unknown options and the positional argument reported missing. Widen its matcher (a
# private attribute of the parser) so every negative float is read as a value — and a working
# mode written as one word that starts with a minus ("-+-", "--+").
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)(e[+-]?\d+)?$|^-(inf|infinity|nan)$|^-[+-]{2}$", re.IGNORECASE)


def _accept_negative_numbers(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    parser._negative_number_matcher = _NEGATIVE_NUMBER
    return parser


#: Below this |S| the actuator-space model is refused. Near a singularity two assembly modes
#: merge into a double root of the forward-kinematics polynomial, found only to about √ε ≈ 1e-8
#: (measured: S = 2e-8 where inverse kinematics gives 9e-11); Mθ grows as 1/S², so below 1e-6 its
#: numbers are off by more than 1 % — and a change of θ in the 7th digit changes them completely.
SINGULAR_S = 1e-6
#: ``--near`` farther than this (metres and radians, as ``nearest`` measures) from every assembly
#: mode is said: the mode reported is not the one asked for.
NEAR_TOLERANCE = 1e-3
#: Below this |S| (the default run-time singularity guard) the model is reported with a warning.
NEAR_SINGULAR_S = 1e-2


def _screen_model(where: str, s: float, values, flag: str, rates) -> None:
    """Refuse an actuator-space model that means nothing: at a singularity (``|S| < SINGULAR_S``) or
    overflowed (``values`` not finite, for the rates given with ``flag``)."""
    import numpy as np

    if abs(s) < SINGULAR_S:
        raise SingularityError(f"{where} is at a gain-type singularity (S = {s:.3g}): the actuator-space model "
                               "(eq. 35) does not exist there")
    if not all(np.all(np.isfinite(v)) for v in values):
        raise InvalidParameterError(f"{where}: the dynamic model overflows at {flag} "
                                    f"{' '.join(f'{w:g}' for w in rates)} (beyond floating-point range)")


def _near_singularity(where: str, s: float, grows: str) -> str | None:
    """The warning for ``|S| < NEAR_SINGULAR_S`` (also said on stderr), or None."""
    from ._format import apart

    if abs(s) >= NEAR_SINGULAR_S:
        return None
    shown, limit = apart(abs(s), NEAR_SINGULAR_S)
    warning = (f"near a gain-type singularity (|S| = {shown} < {limit}): {grows} grow as 1/S^2 and are very "
               "sensitive to the actuators")
    print(f"pkmlab dynamics: warning: {where} is {warning}", file=sys.stderr)
    return warning


def _far_from_near(near, pose) -> None:
    """Say on stderr that the assembly mode reported is not near the pose ``--near`` asked for."""
    print(f"pkmlab dynamics: warning: no assembly mode is within {NEAR_TOLERANCE:g} of --near "
          f"{' '.join(f'{v:g}' for v in near)}; the nearest, reported, is at pose "
          f"({', '.join(f'{v:.6f}' for v in pose)})", file=sys.stderr)


def _dynamics_record(model, sol_q, theta_dot) -> dict:
    import numpy as np

    from . import dynamics
    from .kinematics import coordinate_rates, platform_pose, singularity_measure

    x, y, alpha = platform_pose(model, sol_q).tolist()
    where = f"the assembly mode at pose ({x:.6f}, {y:.6f}, {alpha:.6f})"
    s = float(singularity_measure(model, sol_q))
    _screen_model(where, s, (), "--theta-dot", theta_dot)
    with np.errstate(all="ignore"):
        q_dot = coordinate_rates(model, sol_q, theta_dot)
        m_theta, c_theta = dynamics.actuator_space_model(model, sol_q, theta_dot)
        _qdd, lam = dynamics.constrained_accelerations(model, sol_q, q_dot, [0.0, 0.0, 0.0])
        record = {
            "pose": {"x": x, "y": y, "alpha": alpha},
            "S": s,
            "q": sol_q.tolist(),
            "q_dot": q_dot.tolist(),
            "M_theta": m_theta.tolist(),
            "c_theta": c_theta.tolist(),
            "C_theta": dynamics.actuator_space_coriolis_matrix(model, sol_q, theta_dot).tolist(),
            "M": dynamics.mass_matrix(model, sol_q).tolist(),
            "lambda": lam.tolist(),
            "kinetic_energy": float(dynamics.kinetic_energy(model, sol_q, q_dot)),
        }
    _screen_model(where, s, [v for v in record.values() if not isinstance(v, dict)], "--theta-dot", theta_dot)
    warning = _near_singularity(where, s, "M_theta and lambda")
    if warning:
        record["warning"] = warning
    return record


def _pose_gap(pose, other, names) -> float:
    """How far apart two poses are, metres and radians together (angles the short way round), as
    ``--near`` measures it."""
    import math

    return math.hypot(*[math.remainder(a - b, 2 * math.pi) if name == "alpha" else a - b
                        for a, b, name in zip(pose, other, names, strict=True)])


def cmd_dynamics_mechanism(args) -> dict:
    """``dynamics --mechanism M ACTUATORS... [--rates W...] [--near POSE...]``: ``{"M", "c", "g", "S", "pose"}``
    of ``M θ̈ + c + g = τ`` (eq. 35 with gravity) for the assembly mode nearest ``--near`` (else every mode,
    under ``"solutions"``)."""

    import numpy as np

    from . import mechanism_model as mm

    model = _mechanism(args)
    n, names = model.n_actuators, model.description.pose_names
    _count(args, args.actuators, n, "the actuator values")
    rates = [0.0] * n if args.theta_dot is None else args.theta_dot
    _count(args, rates, n, "--rates")
    found = mm.forward_kinematics(model, args.actuators)
    if not found:
        raise AssemblyError(f"actuators {args.actuators} cannot be assembled: forward kinematics has no real solution")
    if args.near is not None:
        _count(args, args.near, len(names), f"--near ({', '.join(names)})")
        gaps = [_pose_gap(q[-len(names):], args.near, names) for q, _s in found]
        found = [found[int(np.argmin(gaps))]]
        if min(gaps) > NEAR_TOLERANCE:
            _far_from_near(args.near, found[0][0][-len(names):])
    records = []
    for q, s in found:
        pose = q[-len(names):].tolist()
        where = f"the assembly mode at pose ({', '.join(f'{v:.6f}' for v in pose)})"
        _screen_model(where, s, (), "--rates", rates)
        with np.errstate(all="ignore"):
            m_theta, c_theta, g_theta = mm.actuator_space_model(model, q, rates)
        _screen_model(where, s, (m_theta, c_theta, g_theta), "--rates", rates)
        record = {"M": m_theta.tolist(), "c": c_theta.tolist(), "g": g_theta.tolist(), "S": s, "pose": pose}
        warning = _near_singularity(where, s, "M and c")
        if warning:
            record["warning"] = warning
        records.append(record)
    if not args.json:
        for rec in records:
            print(f"assembly mode at {', '.join(f'{k} = {v:+.6f}' for k, v in zip(names, rec['pose'], strict=True))}, "
                  f"S = {rec['S']:+.6f}")
            print("  M (actuator space):")
            for row in rec["M"]:
                print("    " + "  ".join(f"{v:+.6e}" for v in row))
            print("  c = C rates: " + "  ".join(f"{v:+.6e}" for v in rec["c"]))
            print("  g (gravity): " + "  ".join(f"{v:+.6e}" for v in rec["g"]))
    return records[0] if args.near is not None else {"solutions": records}


def cmd_dynamics(args) -> dict:
    from .kinematics import forward_kinematics

    if args.mechanism is not None:
        return cmd_dynamics_mechanism(args)
    _count(args, args.actuators, 3, "dynamics of the paper's 3-RRR (theta1 theta2 theta3)")
    args.t1, args.t2, args.t3 = args.actuators
    args.theta_dot = [0.0, 0.0, 0.0] if args.theta_dot is None else args.theta_dot
    _count(args, args.theta_dot, 3, "--theta-dot")
    if args.near is not None:
        _count(args, args.near, 3, "--near (x y alpha)")
    model = _model(args)
    theta = [args.t1, args.t2, args.t3]
    theta_dot = args.theta_dot
    fk = forward_kinematics(model, theta)
    if len(fk) == 0:
        raise AssemblyError(f"theta = {theta} cannot be assembled: forward kinematics has no real solution")
    chosen = [fk.nearest(args.near)] if args.near else list(fk)
    if args.near and _pose_gap(chosen[0].pose, args.near, ("x", "y", "alpha")) > NEAR_TOLERANCE:
        _far_from_near(args.near, chosen[0].pose)
    records = [_dynamics_record(model, sol.q, theta_dot) for sol in chosen]
    if not args.json:
        for rec in records:
            p = rec["pose"]
            print(f"assembly mode at x = {p['x']:+.6f} m, y = {p['y']:+.6f} m, alpha = {p['alpha']:+.6f} rad, "
                  f"S = {rec['S']:+.6f}")
            print("  M_theta (kg m^2):")
            for row in rec["M_theta"]:
                print("    " + "  ".join(f"{v:+.6e}" for v in row))
            print("  C_theta theta_dot (N m): " + "  ".join(f"{v:+.6e}" for v in rec["c_theta"]))
            print("  lambda at zero torque (N): " + "  ".join(f"{v:+.6e}" for v in rec["lambda"]))
    return records[0] if args.near else {"solutions": records}


def _status_messages(args):
    """Progress messages on stderr, only for a person watching: not with --json, --quiet or a pipe."""
    if args.json or args.quiet or not sys.stderr.isatty():
        return None
    return lambda msg: print(msg, file=sys.stderr)


def cmd_reproduce(args) -> dict:
    """The paper's three cases: summary.json, CSVs, figures 3-15 and REPORT.md in --out."""
    from .report import reproduce

    progress = _status_messages(args)
    summary = reproduce(args.out, control=args.control, figures=not args.no_figures, progress=progress,
                        params=args.params, note=_note(args))
    if not args.json:
        print(f"{'case':<10} {'max path error (m)':>19} {'rms path error (m)':>19} {'peak torque (N m)':>18}")
        for name, s in summary["cases"].items():
            print(f"{name:<10} {s['max_path_error_m']:>19.4e} {s['rms_path_error_m']:>19.4e} "
                  f"{max(s['peak_torque_Nm']):>18.4f}")
        prov = summary["provenance"]
        print(f"results in {args.out}/ ({prov['control']} control, manipulator: {prov['manipulator']})")
    return summary


def _effort_unit(scenario) -> str:
    from .simulation import actuator_kinds

    kinds = actuator_kinds(scenario.model)
    return "N m" if kinds == {"R"} else ("N" if kinds == {"P"} else "N m or N")


def cmd_simulate(args) -> dict:
    """One scenario file: summary.json, run.csv, plant.toml, figures and REPORT.md in --out."""
    from .io import read_text
    from .report import simulation_report
    from .scenario_io import scenario_from_text

    text = read_text(Path(args.scenario))  # once: what is simulated is what is kept as scenario.toml
    scenario = scenario_from_text(text, args.scenario)
    if args.mechanism:  # another machine on the same scenario: the plant is that machine too
        args.params = None
        machine = _mechanism(args)
        if machine.description.name == "paper" and args.mechanism == "paper":
            from .geometry import Planar3RRR

            machine = Planar3RRR.paper()
        scenario = scenario.replace(model=machine, plant=None, working_mode="auto")
    progress = _status_messages(args)
    mujoco = None
    if args.plant == "mujoco":
        closures = _closures(args, "--mujoco-closures", args.mujoco_closures, "--mujoco-stiff", args.mujoco_stiff)
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
                                source=args.scenario, source_text=text, note=_note(args), mujoco=mujoco)
    if not args.json:
        s = summary
        print(f"scenario {s['scenario']}: max path error {s['max_path_error_m']:.4e} m, "
              f"rms path error {s['rms_path_error_m']:.4e} m, peak effort {max(s['peak_effort']):.4f} "
              f"{_effort_unit(scenario)}, "
              f"min |S| {s['min_abs_S']:.4f}, working mode {_signs(s['working_mode'])}"
              + (f", MuJoCo's max loop-closure violation {s['max_closure_violation_m']:.3e} m" if mujoco else ""))
        print(f"results in {args.out}/")
    return summary


# ------------------------------------------------------------------ maps, workspace, animation
MAX_RESOLUTION = 2001
ANIMATION_COLUMNS = ("t", "theta1", "theta2", "theta3", "x", "y", "alpha", "x_d", "y_d")


def _progress(args, total: int, label: str):
    """A progress bar on stderr; silent with --quiet or when stderr is not a terminal."""
    from .progress import Progress

    return Progress(total, label, enabled=not args.quiet)


def _resolution(value: int) -> int:
    from .errors import InvalidParameterError

    if not 2 <= value <= MAX_RESOLUTION:
        raise InvalidParameterError(f"--resolution must be between 2 and {MAX_RESOLUTION} grid points per axis, "
                                    f"got {value}")
    return value


def _figure_suffixes() -> set[str]:
    from matplotlib.backend_bases import FigureCanvasBase

    return {"." + ext for ext in FigureCanvasBase.get_supported_filetypes()} - {".raw", ".rgba"}


def _output_path(path, flag: str, suffixes: set[str] | None = None) -> Path:
    """``path`` as a ``Path``, refused before any computation when it cannot be written."""
    import os

    out = Path(path)
    if out.is_dir():
        raise PkmlabError(f"cannot write {out}: it is a folder")
    if suffixes is not None and out.suffix.lower() not in suffixes:
        shown = ", ".join(sorted(suffixes)) if len(suffixes) <= 4 else ", ".join(sorted(suffixes)[:6]) + ", ..."
        what = f"'{out.suffix}'" if out.suffix else "no suffix"
        raise PkmlabError(f"{flag} {out}: unsupported file type ({what}); use {shown}")
    parent = out.parent
    while not parent.exists():
        parent = parent.parent
    if not parent.is_dir():
        raise PkmlabError(f"cannot write {out}: {parent} is not a folder")
    if not os.access(parent, os.W_OK | os.X_OK):
        raise PkmlabError(f"cannot write {out}: {parent} is not writable")
    return out


class _NewFolders:
    """Remembers which parent folders of ``paths`` do not exist yet; if the ``with`` block fails,
    removes those of them that were created (and are still empty), so an error leaves nothing."""

    def __init__(self, *paths: Path):
        self.missing: list[Path] = []
        for path in paths:
            parent = path.parent
            while not parent.exists() and parent not in self.missing:
                self.missing.append(parent)
                parent = parent.parent

    def __enter__(self) -> _NewFolders:
        return self

    def __exit__(self, exc_type, exc, tb) -> None:
        if exc_type is not None:
            for folder in sorted(self.missing, key=lambda f: len(f.parts), reverse=True):
                try:
                    folder.rmdir()
                except OSError:
                    pass


class _Staged:
    """Temporary files beside ``paths``, moved into place together when the ``with`` block succeeds.

    On any error (or Ctrl-C) the temporary files, and the folders made for them, are removed and no
    output file is touched.
    """

    def __init__(self, *paths: Path):
        self.paths = paths
        self.temps: list[Path] = []
        self.folders = _NewFolders(*paths)

    def __enter__(self) -> list[Path]:
        import os
        import tempfile

        try:
            for path in self.paths:
                path.parent.mkdir(parents=True, exist_ok=True)
                fd, tmp = tempfile.mkstemp(dir=path.parent, prefix=".tmp-", suffix=path.suffix)
                os.close(fd)
                self.temps.append(Path(tmp))
        except OSError as exc:
            self._clean(failed=True)
            raise PkmlabError(f"cannot write {path}: {exc.strerror or exc}") from None
        return self.temps

    def __exit__(self, exc_type, exc, tb) -> None:
        import os

        failed = exc_type is not None
        try:
            if exc_type is None:
                umask = os.umask(0)
                os.umask(umask)
                for tmp, path in zip(self.temps, self.paths, strict=True):
                    try:
                        os.chmod(tmp, 0o666 & ~umask)
                        os.replace(tmp, path)
                    except OSError as err:
                        failed = True
                        raise PkmlabError(f"cannot write {path}: {err.strerror or err}") from None
            elif issubclass(exc_type, OSError):
                raise PkmlabError(f"cannot write {', '.join(map(str, self.paths))}: {exc.strerror or exc}") from None
        finally:
            self._clean(failed)

    def _clean(self, failed: bool) -> None:
        for tmp in self.temps:
            tmp.unlink(missing_ok=True)
        if failed:
            self.folders.__exit__(RuntimeError, None, None)


def _nothing_reachable(x, y, alpha: float) -> PkmlabError:
    return PkmlabError(f"no pose of the region x = {x[0]:g}..{x[-1]:g} m, y = {y[0]:g}..{y[-1]:g} m is reachable "
                       f"at alpha = {alpha:g} rad: nothing to draw")


def cmd_singularity_map(args) -> dict:
    """S over x-y at one orientation and working mode (paper figure 3), with the singular contour S = 0."""
    import io

    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    import numpy as np

    from .analysis import singularity_map
    from .plotting import plot_singularity_map

    model = _mechanism(args) if args.mechanism else _model(args)
    if getattr(getattr(model, "description", None), "spatial", False):
        raise InvalidParameterError(f"singularity-map draws a planar machine's S over x-y; the "
                                    f"{model.description.name} is spatial: `pkmlab workspace --mechanism ... --z Z...` "
                                    "draws its S and S = 0 in horizontal slices")
    out = _output_path(args.out, "--out", _figure_suffixes() | {".html"})
    csv_path = _output_path(args.csv, "--csv", {".csv"}) if args.csv else None
    resolution = _resolution(args.resolution)
    with _progress(args, resolution, "singularity map") as bar:
        smap = singularity_map(model, args.alpha, args.mode, args.x_range, args.y_range, resolution,
                               progress=bar.update)
    reachable = smap.reachable
    if not reachable.any():
        raise _nothing_reachable(smap.x, smap.y, smap.alpha)
    finite = smap.S[reachable]
    result = {"alpha": smap.alpha, "mode": list(smap.mode), "min_S": float(finite.min()),
              "max_S": float(finite.max()), "reachable_fraction": float(reachable.mean()), "figure": str(out),
              "csv": str(csv_path) if csv_path else None}
    ax = plot_singularity_map(smap, model=model)
    try:
        with _Staged(out, *([csv_path] if csv_path else [])) as temps:
            if out.suffix.lower() == ".html":  # interactive: hover shows the pose, the working mode and S
                from .views.maps import singularity_map_figure, write_map

                write_map(temps[0], singularity_map_figure(smap), f"S at alpha = {smap.alpha:g}")
            else:
                ax.figure.savefig(temps[0], dpi=150)
            if csv_path:
                xx, yy = np.meshgrid(smap.x, smap.y)
                buf = io.StringIO()
                np.savetxt(buf, np.column_stack([xx.ravel(), yy.ravel(), smap.S.ravel()]), fmt="%.17g",
                           delimiter=",", header="x,y,S", comments="")
                temps[1].write_text(buf.getvalue())
    finally:
        plt.close(ax.figure)
    if not args.json:
        print(f"S at alpha = {smap.alpha:g} rad, working mode {_signs(smap.mode)}, {resolution} x {resolution} grid: "
              f"min S = {result['min_S']:+.4f}, max S = {result['max_S']:+.4f}, "
              f"reachable {100 * result['reachable_fraction']:.1f} % of the grid")
        print(f"wrote {out}" + (f" and {csv_path}" if csv_path else ""))
    return result


def cmd_workspace(args) -> dict:
    """The reachable region at one orientation for each of the 8 working modes, with their S = 0 curves."""
    import matplotlib

    matplotlib.use("Agg")

    from .analysis import workspace
    from .plotting import plot_workspace

    model = _mechanism(args) if args.mechanism else _model(args)
    out = _output_path(args.out, "--out", _figure_suffixes() | {".html"})
    if getattr(getattr(model, "description", None), "spatial", False):
        if out.suffix.lower() == ".html":
            raise InvalidParameterError("--out: a spatial machine's slices are drawn as an image (PNG, SVG, PDF); "
                                        "the interactive .html map is a planar machine's")
        return _spatial_workspace(args, model, out)
    if args.z is not None or args.mode is not None:
        raise InvalidParameterError("--z and --mode are for a spatial machine's slices; a planar machine's workspace "
                                    "shows every working mode at one --alpha")
    resolution = _resolution(args.resolution)
    with _progress(args, resolution, "workspace") as bar:
        ws = workspace(model, args.alpha, resolution, args.x_range, args.y_range, progress=bar.update)
    if not ws.reachable.any():
        raise _nothing_reachable(ws.x, ws.y, ws.alpha)
    fig = plot_workspace(ws, model=model)
    if out.suffix.lower() == ".html":  # interactive: hover shows the pose, the working mode and S
        import matplotlib.pyplot as plt

        from .views.maps import workspace_figure, write_map

        plt.close(fig)
        with _Staged(out) as temps:
            write_map(temps[0], workspace_figure(ws), f"workspace at alpha = {ws.alpha:g}")
    else:
        _save_figure(fig, out)
    areas = [{"mode": [int(v) for v in m], "area_m2": float(a), "area_cm2": float(a) * 1e4}
             for m, a in zip(ws.modes, ws.area, strict=True)]
    if not args.json:
        print(f"reachable workspace at alpha = {ws.alpha:g} rad ({resolution} x {resolution} grid, "
              f"cell {ws.cell_area * 1e4:.4g} cm^2)")
        print(_table(["mode", "area (cm^2)"], [[_signs(a["mode"]), f"{a['area_cm2']:.2f}"] for a in areas]))
        print(f"wrote {out}")
    return {"alpha": ws.alpha, "resolution": resolution, "cell_area_m2": ws.cell_area, "areas": areas,
            "figure": str(out)}


def _save_figure(fig, out: Path) -> None:
    """Write ``fig`` to ``out`` whole or not at all, and close it."""
    import matplotlib.pyplot as plt

    try:
        with _Staged(out) as temps:
            fig.savefig(temps[0], dpi=150)
    finally:
        plt.close(fig)


def _spatial_workspace(args, model, out: Path) -> dict:
    """``workspace`` of a spatial machine: horizontal slices of its reachable region with ``S`` and ``S = 0``."""

    from .analysis import spatial_workspace
    from .plotting import plot_spatial_workspace

    if args.alpha != 0.0:
        raise InvalidParameterError("--alpha is a planar platform's orientation; a spatial machine's slices are at "
                                    "--z heights")
    resolution = _resolution(args.resolution)
    mode = tuple(args.mode) if getattr(args, "mode", None) is not None else None
    levels = args.z
    with _progress(args, len(levels) if levels else 6, "slices") as bar:
        ws = spatial_workspace(model, mode, levels, resolution, args.x_range, args.y_range, progress=bar.update)
    if not ws.reachable.any():
        raise PkmlabError(f"nothing is reachable at z = {', '.join(f'{z:g}' for z in ws.z)} m over the region asked")
    fig = plot_spatial_workspace(ws, model=model)
    _save_figure(fig, out)
    slices = [{"z": float(z), "area_m2": float(a), "area_cm2": float(a) * 1e4} for z, a in zip(ws.z, ws.area,
                                                                                            strict=True)]
    if not args.json:
        print(f"reachable workspace of the {model.description.name} in working mode {_signs(ws.mode)}, "
              f"{resolution} x {resolution} grid per slice")
        print(_table(["z (m)", "area (cm^2)"], [[f"{s['z']:.4f}", f"{s['area_cm2']:.1f}"] for s in slices]))
        print(f"wrote {out}")
    return {"mode": list(ws.mode), "resolution": resolution, "slices": slices, "figure": str(out)}


def _closures(args, option: str, value: str | None, deprecated: str, deprecated_given: bool) -> str:
    """The loop closures ``option`` asks for: ``stiff`` (the default) or ``soft``, anything else refused in one
    line. ``deprecated``, the old flag for stiff closures (now the default), does nothing but say so on stderr."""
    closures = "stiff" if value is None else value
    if closures not in ("stiff", "soft"):
        raise InvalidParameterError(f"{option} must be stiff or soft, got {value!r}")
    if deprecated_given:
        if closures == "soft":
            raise InvalidParameterError(f"{deprecated} (stiff closures) contradicts {option} soft: give {option} only")
        print(f"pkmlab {args.command}: note: {deprecated} is deprecated and does nothing: stiff loop closures are "
              f"now the default ({option} soft for MuJoCo's own)", file=sys.stderr)
    return closures


def cmd_export_mjcf(args) -> dict:
    """``export-mjcf``: the machine as a MuJoCo model (MJCF), at the pose ``--pose`` (its configuration in
    ``--mode``) or at its home configuration (:func:`pkmlab.mujoco_export.home_configuration`)."""
    from . import mechanism_model as mm
    from . import mujoco_export as mx
    from .mechanism_model import MechanismModel

    closures = _closures(args, "--closures", args.closures, "--stiff", args.stiff)
    if args.mechanism:
        model = _mechanism(args)
    else:
        model = MechanismModel.from_3rrr(_model(args))
    out = _output_path(args.out, "--out", {".xml"})
    q = None
    if args.pose is not None:
        names = model.description.pose_names
        _count(args, args.pose, len(names), f"--pose ({', '.join(names)})")
        modes = mm.working_modes(model)
        mode = tuple(args.mode) if args.mode is not None else modes[0]
        if mode not in modes:
            raise InvalidParameterError(f"--mode must be one of {', '.join(_signs(m) for m in modes)} for a "
                                        f"{model.description.notation}, got {_signs(mode)}")
        q = mm.inverse_kinematics(model, args.pose, mode)
    options = {"timestep": args.timestep, "integrator": args.integrator, "closures": closures}
    q = mx.home_configuration(model) if q is None else q
    text = mx.mjcf(model, q, **options)
    with _Staged(out) as temps:
        temps[0].write_text(text)
    approximations = [line[5:-4] for line in text.splitlines() if line.startswith("<!-- Principal")]
    if not args.json:
        print(f"wrote {out}: the {model.description.name} ({model.description.notation}) for MuJoCo, keyframe "
              f"\"pkmlab\" at pose {', '.join(f'{v:.6g}' for v in q[-model.description.dof:])}")
        for note in approximations:
            print(f"note: {note}")
    return {"mjcf": str(out), "pose": q[-model.description.dof:].tolist(), "qpos": mx.qpos_from_q(model, q).tolist(),
            "joints": list(mx.joint_names(model)), "approximations": approximations}


def _animation_model(args, folder: Path, case: str):
    """The 3-RRR that produced the run: --params, else the folder's own
    (:func:`~pkmlab.views.folder.result_manipulator`)."""
    from .io import load_manipulator
    from .views.folder import result_manipulator

    if args.params:
        return load_manipulator(args.params), Path(args.params).name
    return result_manipulator(folder, case)


def _animation_machine(args, folder: Path):
    """The described machine of a run — ``--mechanism``, else the run's plant.toml when it holds a
    ``[mechanism]`` table — or None for the paper's 3-RRR."""
    from .views.folder import result_mechanism

    if getattr(args, "mechanism", None):
        return _mechanism(args), args.mechanism  # refuses --params, which describes the paper's 3-RRR
    return result_mechanism(folder)


def _animate_machine(args, machine, folder: Path, csv_path: Path, out: Path) -> dict:
    """``pkmlab animate`` of a described machine's run: rebuilt by branch following, drawn as it is."""
    import numpy as np

    from .animation import rebuild_machine_configurations, write_machine_gif, write_spatial_gif
    from .io import read_result_csv

    model, source = machine
    n_act, names = len(model.description.legs), model.description.pose_names
    position = ("x", "y", "z") if getattr(model.description, "spatial", False) else ("x", "y")
    columns = ("t", *(f"theta{i + 1}" for i in range(n_act)), *names, *(f"{c}_d" for c in position))
    data = read_result_csv(csv_path, columns)
    theta = np.column_stack([data[f"theta{i + 1}"] for i in range(n_act)])
    pose = np.column_stack([data[v] for v in names])
    q = rebuild_machine_configurations(model, theta, pose[0])
    tracked = q[:, -len(names):][:, :len(position)]
    desired = np.column_stack([data[f"{c}_d"] for c in position])
    title = f"{folder.name}/{csv_path.name}, {model.description.name} ({model.description.notation})"
    writer = write_spatial_gif if len(position) == 3 else write_machine_gif
    return _write_animation(args, data, tracked, source, csv_path, out, title, "--mechanism",
                            lambda frames, bar: writer(model, data["t"], q, desired, out, frames, fps=args.fps,
                                                       title=title, on_frame=bar.update))


def _write_animation(args, data: dict, tracked, source: str, csv_path: Path, out: Path, title: str, option: str,
                     write) -> dict:
    """The part of ``pkmlab animate`` every machine shares: warn when the machine rebuilt from the recorded
    actuators does not put the tracked point ``tracked`` (N, 2 or 3) where the CSV says, then draw about 100
    frames with ``write(frames, bar)`` and report."""
    import math

    import numpy as np

    recorded = np.column_stack([data[c] for c in ("x", "y", "z")[:tracked.shape[1]]])
    deviation = float(np.max(np.linalg.norm(tracked - recorded, axis=1)))
    if deviation > 1e-3:
        print(f"pkmlab animate: warning: the machine rebuilt from the recorded actuators puts the tracked point up "
              f"to {deviation * 1e3:.3g} mm from the CSV's; is the machine ({source}) the one that produced "
              f"this run? ({option})", file=sys.stderr)
    count = tracked.shape[0]
    stride = args.stride or max(1, math.ceil(count / 100))
    frames = range(0, count, stride)
    with _progress(args, len(frames), "frames") as bar, _NewFolders(out):
        try:
            write(frames, bar)
        except OSError as exc:
            raise PkmlabError(f"cannot write {out}: {exc.strerror or exc}") from None
    if not args.json:
        print(f"wrote {out}: {len(frames)} frames (one every {stride} of {count} samples) at {args.fps} fps "
              f"from {csv_path}, machine: {source}")
    return {"gif": str(out), "csv": str(csv_path), "frames": len(frames), "stride": stride, "fps": args.fps,
            "samples": count, "manipulator": source, "max_centroid_deviation_m": deviation}


def cmd_animate(args) -> dict:
    """A GIF of a recorded run: the machine rebuilt from its recorded actuators, the desired path, the trail."""
    import numpy as np

    from .animation import rebuild_configurations, write_gif
    from .errors import InvalidParameterError
    from .io import read_result_csv
    from .kinematics import platform_pose

    folder = Path(args.result_dir)
    if not folder.exists():
        raise PkmlabError(f"result folder {folder} does not exist")
    if not folder.is_dir():
        raise PkmlabError(f"{folder} is not a folder (expected one written by pkmlab reproduce or pkmlab simulate)")
    out = _output_path(args.out, "--out", {".gif"})
    if args.fps < 1:
        raise InvalidParameterError(f"--fps must be a positive number of frames per second, got {args.fps}")
    if args.stride is not None and args.stride < 1:
        raise InvalidParameterError(f"--stride must be a positive number of samples, got {args.stride}")
    case = args.case
    if case is None:
        case = "run" if (folder / "run.csv").is_file() else "nominal"
    case = case.removesuffix(".csv")
    if not re.fullmatch(r"[\w][\w.-]*", case):
        raise InvalidParameterError(f"--case must be the name of a CSV file in {folder} without '.csv', got {case!r}")
    csv_path = folder / f"{case}.csv"
    if not csv_path.is_file():
        found = sorted(p.stem for p in folder.glob("*.csv"))
        hint = (f"cases found: {', '.join(found)}" if found else
                "expected nominal.csv, disturbed.csv, fast.csv (pkmlab reproduce) or run.csv (pkmlab simulate)")
        raise PkmlabError(f"no {csv_path.name} in {folder} ({hint})")
    machine = _animation_machine(args, folder)
    if machine is not None:
        return _animate_machine(args, machine, folder, csv_path, out)
    data = read_result_csv(csv_path, ANIMATION_COLUMNS)
    model, source = _animation_model(args, folder, case)
    theta = np.column_stack([data["theta1"], data["theta2"], data["theta3"]])
    q = rebuild_configurations(model, theta, [data["x"][0], data["y"][0], data["alpha"][0]])
    centroid = platform_pose(model, q)[:, :2]
    title = f"{folder.name}/{csv_path.name}, manipulator: {source}"
    return _write_animation(args, data, centroid, source, csv_path, out, title, "--params",
                            lambda frames, bar: write_gif(model, data["t"], q, np.column_stack(
                                [data["x_d"], data["y_d"]]), out, frames, fps=args.fps, title=title,
                                on_frame=bar.update))


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
    from .study import StudyInterrupted, load_study, sweep

    study = load_study(args.study)
    if args.heatmap is not None:
        args.heatmap = tuple(args.heatmap)
    quiet = args.quiet or args.json
    note = None if quiet else _note(args)
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
        error = summary["metrics"].get("max_path_error_m")
        if error:
            print(f"max path error: median {error['median']:.3e} m, worst {error['max']:.3e} m")
        best = summary.get("best_point")
        if best:
            values = ", ".join(f"{k} = {v:g}" if isinstance(v, float) else f"{k} = {v}"
                               for k, v in best["values"].items())
            print(f"least worst-case error: {values or 'the base'}: {best['worst_max_path_error_m']:.3e} m, "
                  f"peak effort {best['worst_peak_effort']:.4g}")
        print(f"{run['runs_run']} runs in {run['wall_time_s']:.1f} s ({run['runs_per_s']:.1f} runs/s on "
              f"{run['workers']} worker{'s' if run['workers'] != 1 else ''}); table in {args.out}/runs.parquet")
    return summary


def cmd_tune(args) -> dict:
    """A scenario's gains tuned for an effort limit over an uncertainty set: tuned.toml, trials.csv, tuning.json
    and tradeoff.png in --out."""
    from .outputs import atomic_output_dir
    from .study.tuning import tune, write_tuning

    if args.trials < 1 or args.draws < 0 or not 0 <= args.uncertainty < 1 or not 0 < args.quantile <= 1:
        raise InvalidParameterError("--trials must be positive, --draws 0 or more, --uncertainty in [0, 1) and "
                                    f"--quantile in (0, 1]; got {args.trials}, {args.draws}, {args.uncertainty:g}, "
                                    f"{args.quantile:g}")
    execution = _execution(args)
    quiet = args.quiet or args.json
    from .progress import Progress

    bar = Progress(args.trials, "candidates", enabled=not quiet, unit="candidates")
    # the folder is checked before the work, and receives the trials even when no gains keep within the limit
    with atomic_output_dir(args.out, "tune", inputs=[args.scenario], note=_note(args)) as folder:
        with bar:
            result = tune(args.scenario, args.max_effort, uncertainty=args.uncertainty,
                          quantities=tuple(args.uncertain), draws=args.draws, seed=args.seed, quantile=args.quantile,
                          critical=args.critical, trials=args.trials, kp_range=tuple(args.kp_range),
                          zeta_range=tuple(args.zeta_range), workers=execution["workers"],
                          scheduler=execution["scheduler"], chunk_size=execution["chunk_size"],
                          progress=lambda done, _total: bar.update(done - bar.count))
        summary = write_tuning(result, folder, args.scenario)
    if result.best is None:
        raise InvalidParameterError(f"no gains tried keep the peak effort within {args.max_effort:g} on every plant "
                                    f"(the least reached: {result.trials['worst_effort'].min():.4g}); the trials are "
                                    f"in {args.out}/")
    if not args.json:
        best, base = result.best, result.baseline
        what = "worst-case" if args.quantile == 1 else f"{args.quantile:g}-quantile"
        print(f"tuned: kp = {best['kp']:.6g}, kv = {best['kv']:.6g} (zeta = {best['zeta']:.3g}): {what} max path "
              f"error {best['error']:.4e} m, peak effort {best['worst_effort']:.4g} (limit {args.max_effort:g})")
        which = "the scenario's kp, critically damped" if args.critical else "the scenario's gains"
        if math.isfinite(base["error"]):
            print(f"{which} (kp = {base['kp']:.6g}, kv = {base['kv']:.6g}): {base['error']:.4e} m, "
                  f"peak effort {base['worst_effort']:.4g}")
        else:
            print(f"{which} (kp = {base['kp']:.6g}, kv = {base['kv']:.6g}): some run failed")
        print(f"{len(result.trials)} candidates x {max(args.draws, 1)} plants; pkmlab simulate {args.out}/tuned.toml "
              "runs the tuned scenario")
    return summary


def cmd_view(args) -> dict:
    """The interactive HTML view of a result folder: RESULT_DIR/REPORT.html (listed in its manifest) or --out."""
    from .views.folder import read_result_views
    from .views.html import write_html

    folder = Path(args.result_dir)
    out = _output_path(args.out, "--out", {".html", ".htm"}) if args.out else folder / "REPORT.html"
    views = read_result_views(folder)  # every file checked before anything is written
    title = f"pkmlab view: {folder.resolve().name}"
    if args.out:
        try:
            with _NewFolders(out):
                write_html(out, views, title)
        except OSError as exc:
            raise PkmlabError(f"cannot write {out}: {exc.strerror or exc}") from None
    else:
        from .outputs import OutputFolderError, add_to_result
        from .views.html import page

        text = page(views, title)
        try:
            add_to_result(folder, "REPORT.html", lambda tmp: tmp.write_text(text, encoding="utf-8"))
        except OutputFolderError as exc:
            raise PkmlabError(f"{exc}; write the view elsewhere with --out FILE.html") from None
        except OSError as exc:  # a read-only result, a full disk
            raise PkmlabError(f"cannot write {out}: {exc.strerror or exc}; write the view elsewhere with --out "
                              "FILE.html") from None
    size = out.stat().st_size
    result = {"html": str(out), "runs": [v.name for v in views], "bytes": size}
    if not args.json:
        print(f"wrote {out} ({size / 1e6:.1f} MB, {len(views)} run{'s' if len(views) > 1 else ''}: "
              f"{', '.join(v.name for v in views)}); open it in a browser, it works offline")
    return result


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="pkmlab", description="Kinematics, dynamics and control of "
                                     "parallel manipulators (planar 3-RRR). Angles in radians, lengths in metres.")
    _accept_negative_numbers(parser)
    parser.add_argument("--version", action="version", version=f"pkmlab {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    def common(p):
        _accept_negative_numbers(p)
        p.add_argument("--params", metavar="FILE.toml", help="manipulator parameters (default: the paper preset)")
        p.add_argument("--json", action="store_true", help="machine-readable output")

    def mechanism(p):
        p.add_argument("--mechanism", metavar="NAME|FILE.toml", help="another machine: a preset (paper, five_bar, "
                       "3rpr, 3prr, delta, stewart) or a description file; default: the paper's 3-RRR as today")

    p = sub.add_parser("ik", help="inverse kinematics: every working mode of a platform pose")
    p.add_argument("pose", nargs="+", type=float, metavar="POSE",
                   help="the platform pose: x y alpha (the paper's 3-RRR, a planar rigid platform), x y (a point), "
                   "x y z (the Delta), x y z roll pitch yaw (a six-DOF platform; R = Rz(yaw) Ry(pitch) Rx(roll))")
    p.add_argument("--mode", nargs="+", metavar="SIGN", help="one working mode: signs (+ - +) or one word (+-+)")
    mechanism(p)
    common(p)
    p.set_defaults(func=cmd_ik)

    p = sub.add_parser("fk", help="forward kinematics: every assembly mode of actuated angles")
    p.add_argument("actuators", nargs="+", type=float, metavar="T1 T2 T3",
                   help="the actuator values (angles in rad, slides in m)")
    mechanism(p)
    common(p)
    p.set_defaults(func=cmd_fk)

    p = sub.add_parser("dynamics", help="actuator-space and full dynamic model at a state (paper eq. 26, 35)")
    p.add_argument("actuators", nargs="+", type=float, metavar="T1 T2 T3",
                   help="the actuator values (angles in rad, slides in m)")
    p.add_argument("--theta-dot", "--rates", dest="theta_dot", nargs="+", type=float, metavar="W",
                   help="actuator rates (rad/s or m/s), default 0")
    p.add_argument("--near", nargs="+", type=float, metavar="POSE",
                   help="only the assembly mode whose platform pose is nearest to this pose (as ik takes it)")
    mechanism(p)
    common(p)
    p.set_defaults(func=cmd_dynamics)

    p = sub.add_parser("reproduce", help="the paper's three simulated cases with every figure (paper §5)")
    p.add_argument("--out", default="out", help="output folder (default: out)")
    p.add_argument("--control", choices=("sampled", "continuous"), default="sampled",
                   help="sampled-data control at 1 ms (default) or continuous-time")
    p.add_argument("--no-figures", action="store_true", help="skip the figures")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    common(p)
    p.set_defaults(func=cmd_reproduce)


    p = sub.add_parser("simulate", help="simulate a scenario file: summary, time series, figures, REPORT.md")
    p.add_argument("scenario", metavar="SCENARIO.toml", help="the scenario (format: README, 'Scenario files')")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder: new, empty, or an earlier result of "
                   "pkmlab simulate (replaced when the run succeeds; anything else in it is refused, never deleted)")
    p.add_argument("--no-figures", action="store_true", help="skip the figures")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--plant", choices=("pkmlab", "mujoco"), default="pkmlab", help="the plant the controller runs "
                   "against: pkmlab's exact reduced model (default) or MuJoCo's integration of the exported machine")
    p.add_argument("--mujoco-timestep", type=float, metavar="DT", help="MuJoCo's time step (s), dividing the sample "
                   "time; default the sample time or 1 ms, whichever is smaller")
    p.add_argument("--mujoco-integrator", choices=("RK4", "implicitfast", "implicit", "Euler"), default="RK4",
                   help="MuJoCo's integrator, default RK4")
    p.add_argument("--mujoco-closures", metavar="stiff|soft", help="MuJoCo's loop closures: stiff (default: "
                   "solimp 0.9999, solref 2 ms, they behave like the rigid machine) or soft (MuJoCo's defaults: the "
                   "loops open by up to a few mm)")
    p.add_argument("--mujoco-stiff", action="store_true", help="deprecated, does nothing: stiff closures are the "
                   "default")
    mechanism(p)
    p.set_defaults(func=cmd_simulate)

    def execution(p):  # a study's: where its runs execute, and what it says
        p.add_argument("--quiet", action="store_true", help="no progress bar or notes")
        p.add_argument("--json", action="store_true", help="print the summary as JSON")
        p.add_argument("--workers", type=int, metavar="N", help="worker processes of the local Dask cluster started "
                       "for the study (default: one per core; 0 runs in this process)")
        p.add_argument("--scheduler", metavar="tcp://HOST:PORT", help="run on an existing Dask cluster instead")
        p.add_argument("--chunk-size", type=int, metavar="K", help="runs per task (default: enough tasks to keep "
                       "every worker busy, at most 64 runs each)")

    p = sub.add_parser("sweep", help="a study: a scenario over a grid of values and drawn plants, on a Dask "
                       "cluster; its table (Parquet), summary.json and figures")
    p.add_argument("study", metavar="SWEEP.toml", help="the study (format: README, 'Studies')")
    p.add_argument("--out", required=True, metavar="DIR", help="the study's folder: new or empty, or this study's "
                   "(with --resume)")
    p.add_argument("--resume", action="store_true", help="finish the study DIR holds, running only what is missing")
    p.add_argument("--csv", action="store_true", help="also write the table as runs.csv")
    p.add_argument("--heatmap", nargs=2, metavar=("Y", "X"), help="the two axes of the maps (default: the first "
                   "two that vary)")
    p.add_argument("--no-figures", action="store_true", help="skip the figures")
    execution(p)
    p.set_defaults(func=cmd_sweep)

    p = sub.add_parser("tune", help="the gains (kp, kv) minimising the worst-case path error over uncertain plants "
                       "with the peak effort within a limit; writes a scenario of the tuned gains")
    p.add_argument("scenario", metavar="SCENARIO.toml", help="the scenario whose gains are tuned")
    p.add_argument("--max-effort", type=float, required=True, metavar="TAU", help="the limit on every actuator's "
                   "peak effort (N m, or N for prismatic actuators) on every plant of the uncertainty set")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder: tuned.toml, trials.csv, tuning.json, "
                   "tradeoff.png")
    p.add_argument("--uncertainty", type=float, default=0.15, metavar="SPREAD", help="factors drawn in "
                   "[1 - SPREAD, 1 + SPREAD] (default 0.15)")
    p.add_argument("--uncertain", nargs="+", choices=("mass", "length", "inertia"), default=["mass", "inertia"],
                   help="the quantities drawn per body (default: mass inertia)")
    p.add_argument("--draws", type=int, default=16, metavar="N", help="plants in the uncertainty set (default 16; "
                   "0: the scenario's plant alone)")
    p.add_argument("--quantile", type=float, default=1.0, metavar="Q", help="minimise this quantile of the max path "
                   "error over the plants (default 1: the worst case)")
    p.add_argument("--critical", action="store_true", help="tune kp alone, kv = 2 sqrt(kp) (critical damping)")
    p.add_argument("--kp-range", type=float, nargs=2, default=[10.0, 1e6], metavar=("LO", "HI"),
                   help="the search box of kp, 1/s^2 (default 10 1e6): bound it by what the machine's sensors and "
                   "drives allow, which the model does not know")
    p.add_argument("--zeta-range", type=float, nargs=2, default=[0.3, 3.0], metavar=("LO", "HI"),
                   help="the search box of the damping ratio, kv = 2 zeta sqrt(kp) (default 0.3 3)")
    p.add_argument("--trials", type=int, default=48, metavar="N", help="candidate gains to evaluate (default 48)")
    p.add_argument("--seed", type=int, default=0, help="seed of the draws and the optimiser (default 0)")
    execution(p)
    p.set_defaults(func=cmd_tune)

    p = sub.add_parser("view", help="an interactive HTML view of a result folder: the machine animated in sync "
                       "with its time series, offline")
    p.add_argument("result_dir", metavar="RESULT_DIR", help="a folder of pkmlab simulate or pkmlab reproduce")
    p.add_argument("--out", metavar="FILE.html", help="where to write it (default RESULT_DIR/REPORT.html, added to "
                   "the folder's manifest)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=cmd_view)

    p = sub.add_parser("demo", help="kinematics demo on the paper's circle (figure 3)")
    p.add_argument("--out", default="demo", help="output folder (default: demo)")
    p.add_argument("--resolution", type=int, default=241, help="grid points per axis of the S map")
    common(p)
    p.set_defaults(func=cmd_demo)

    def figure_region(p, what: str):
        p.add_argument("--alpha", type=float, default=0.0, metavar="A", help="platform orientation (rad), default 0")
        p.add_argument("--resolution", type=int, default=201, metavar="N",
                       help=f"grid points per axis (2..{MAX_RESOLUTION}, default 201)")
        p.add_argument("--x-range", nargs=2, type=float, metavar=("XMIN", "XMAX"),
                       help="x extent (m), default: the base and every leg's reach")
        p.add_argument("--y-range", nargs=2, type=float, metavar=("YMIN", "YMAX"), help="y extent (m)")
        p.add_argument("--out", required=True, metavar="FILE.png", help=f"the figure of the {what} (PNG, PDF, SVG...)")
        p.add_argument("--quiet", action="store_true", help="no progress bar")

    p = sub.add_parser("singularity-map", help="S over x-y at one orientation and working mode, S = 0 drawn "
                       "(paper figure 3)")
    figure_region(p, "map")
    p.add_argument("--mode", nargs="+", metavar="SIGN", help="working mode: three signs (+ - +) or one word (+-+); "
                   "default + + +")
    p.add_argument("--csv", metavar="FILE.csv", help="also write the grid: columns x, y, S (NaN out of reach)")
    mechanism(p)
    common(p)
    p.set_defaults(func=cmd_singularity_map)

    p = sub.add_parser("workspace", help="reachable region at one orientation for each working mode (a spatial "
                       "machine: horizontal slices in one working mode)")
    figure_region(p, "working modes")
    p.add_argument("--z", nargs="+", type=float, metavar="Z", help="a spatial machine's slice heights (m), default "
                   "six spread over the heights it reaches")
    p.add_argument("--mode", nargs="+", metavar="SIGN", help="a spatial machine's working mode (+ + +); default the "
                   "first")
    mechanism(p)
    common(p)
    p.set_defaults(func=cmd_workspace)

    p = sub.add_parser("export-mjcf", help="the machine as a MuJoCo model (MJCF): its bodies, joints, loop "
                       "closures, motors and gravity")
    p.add_argument("--out", required=True, metavar="FILE.xml", help="the MJCF file")
    p.add_argument("--pose", nargs="+", type=float, metavar="POSE", help="the configuration of the keyframe "
                   "'pkmlab' (as ik takes it); default: the pose of largest |S| on a grid")
    p.add_argument("--mode", nargs="+", metavar="SIGN", help="the working mode of --pose (default the first)")
    p.add_argument("--closures", metavar="stiff|soft", help="the loop closures: stiff (default: the stiffest "
                   "MuJoCo accepts, solimp 0.9999, solref 2 ms; they behave like the rigid machine) or soft "
                   "(MuJoCo's defaults: the loops open by up to a few mm)")
    p.add_argument("--stiff", action="store_true", help="deprecated, does nothing: stiff closures are the default")
    p.add_argument("--timestep", type=float, default=0.001, metavar="DT", help="MuJoCo's time step (s), default 1 ms")
    p.add_argument("--integrator", choices=("RK4", "implicitfast", "implicit", "Euler"), default="RK4",
                   help="MuJoCo's integrator, default RK4")
    mechanism(p)
    common(p)
    p.set_defaults(func=cmd_export_mjcf)

    p = sub.add_parser("animate", help="GIF of a run written by pkmlab reproduce or pkmlab simulate")
    p.add_argument("result_dir", metavar="RESULT_DIR", help="folder written by pkmlab reproduce or pkmlab simulate")
    p.add_argument("--out", required=True, metavar="FILE.gif", help="the animated GIF")
    p.add_argument("--case", metavar="NAME", help="NAME.csv in RESULT_DIR: nominal (default), disturbed, fast; "
                   "run for pkmlab simulate (default when run.csv exists)")
    p.add_argument("--fps", type=int, default=20, help="frames per second (default 20)")
    p.add_argument("--stride", type=int, help="draw every K-th sample (default: about 100 frames)", metavar="K")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _accept_negative_numbers(p)
    p.add_argument("--params", metavar="FILE.toml", help="the manipulator that produced the run (default: "
                   "RESULT_DIR/plant.toml if present, else the paper's, x1.15 for the reproduced 'disturbed' case)")
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.add_argument("--mechanism", metavar="NAME|FILE.toml", help="the described machine that produced the run "
                   "(default: RESULT_DIR/plant.toml when it holds a [mechanism] table)")
    p.set_defaults(func=cmd_animate)
    for command in sub.choices.values():  # each command knows its parser: its errors show its usage
        command.set_defaults(parser=command)
    return parser


def _pose_names(args) -> tuple[str, ...]:
    """The names of the pose's coordinates of the machine on the command line (the paper's 3-RRR's by default;
    a description that cannot be read yet names none: its error comes later, on its own)."""
    mechanism = getattr(args, "mechanism", None)
    if not mechanism:
        return ("x", "y", "alpha")
    try:
        from .mechanisms.description import load_mechanism
        from .mechanisms.presets import PRESETS, preset

        return (preset(mechanism) if mechanism in PRESETS else load_mechanism(mechanism)).pose_names
    except PkmlabError:
        return ()


def _check_finite(args) -> None:
    """Every number of the command line must be finite: NaN or infinity is refused naming its argument
    (for a list of positional numbers, the one at fault: ``alpha``, ``T1``...)."""
    import math

    actions = {a.dest: a for a in args.parser._actions}
    for dest, value in vars(args).items():
        values = value if isinstance(value, list) else [value]
        bad = [k for k, v in enumerate(values) if isinstance(v, float) and not math.isfinite(v)]
        if not bad:
            continue
        action = actions.get(dest)
        name = dest if action is None else action.option_strings[0] if action.option_strings else str(action.metavar)
        parts = " ".join(_pose_names(args)).upper().split() if name == "POSE" else name.split()
        if len(parts) > 1 and isinstance(value, list) and bad[0] < len(parts):  # "X Y ALPHA": the one at fault
            name = parts[bad[0]].lower() if name == "POSE" or parts[bad[0]] in ("X", "Y", "ALPHA") else parts[bad[0]]
        raise InvalidParameterError(f"{name} must be finite, got {' '.join(str(v) for v in values)}")


def _check_mode(args) -> None:
    """``--mode`` as three signs (``+ - +``, ``1 -1 1``) or one word (``+-+``), the spellings the Python API
    takes; normalised to three ints. Another number of words is a malformed command line (exit 2)."""
    tokens = getattr(args, "mode", None)
    if tokens is None:
        return
    from ._validate import as_mode

    if getattr(args, "mechanism", None) is not None:  # any number of signs: the machine decides
        text = "".join(tokens).replace("+1", "+").replace("-1", "-").replace("1", "+")
        if text.strip("+-"):
            raise InvalidParameterError(f"--mode: a working mode is signs such as + - (or one word such as +-), "
                                        f"got {' '.join(tokens)}")
        args.mode = tuple(1 if c == "+" else -1 for c in text)
        return

    if len(tokens) not in (1, 3):
        args.parser.error(f"argument --mode: expected three signs (+ - +) or one word (+-+), got {' '.join(tokens)}")
    try:
        args.mode = tuple(int(v) for v in as_mode(tokens[0] if len(tokens) == 1 else tokens))
    except InvalidParameterError:
        raise InvalidParameterError(f"--mode: a working mode is three signs such as + - + (or one word such as "
                                    f"+-+), got {' '.join(tokens)}") from None


def _compile_notice(args) -> None:
    """Say once, on a terminal, why the first run after installing pkmlab is slow."""
    from . import _compile_cache

    if _compile_cache.is_cold() and sys.stderr.isatty() and not getattr(args, "quiet", False):
        print("pkmlab: first run of this version: compiling its numerical kernels for this machine "
              "(about a minute, once) ...", file=sys.stderr, flush=True)


def _quiet_stdout() -> None:
    """After a closed pipe (`pkmlab fk ... | head -1`), send what is left of stdout nowhere, so that
    Python's final flush does not report the broken pipe again."""
    import os

    try:
        devnull = os.open(os.devnull, os.O_WRONLY)
        os.dup2(devnull, sys.stdout.fileno())
    except (OSError, ValueError, AttributeError):
        pass


def _strict_json(value):
    """``value`` for ``json.dumps(allow_nan=False)``: non-finite numbers (which strict JSON parsers
    reject) become ``null``."""
    import math

    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: _strict_json(v) for k, v in value.items()}
    if isinstance(value, (list, tuple)):
        return [_strict_json(v) for v in value]
    return value


def _note(args):
    """What a command says besides its result (an earlier result replaced, ...): one line on stderr,
    ``pkmlab CMD: note: ...``; nothing with --quiet."""

    def say(message: str) -> None:
        if not getattr(args, "quiet", False):
            print(f"pkmlab {args.command}: note: {message}", file=sys.stderr)

    return say


def _with_notes(args):
    """Run the command; what pkmlab's general methods warn of (an assembly mode that may be missing) is
    said as one note line each, other warnings as Python shows them."""
    import warnings

    from .errors import IncompleteSolutionWarning

    caught: list = []
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always", IncompleteSolutionWarning)
            return args.func(args)
    finally:  # said also when the command then fails, once the recording has stopped
        for w in caught:
            if issubclass(w.category, IncompleteSolutionWarning):
                _note(args)(str(w.message))
            else:
                warnings.showwarning(w.message, w.category, w.filename, w.lineno)


def _interpreted(args) -> bool:
    """Whether the command is a one-shot evaluation at a single pose or state, whose kernels are quicker to run
    interpreted than to load compiled (:mod:`pkmlab._compile_cache`): ``ik`` of any machine, ``fk`` and
    ``dynamics`` of the paper's 3-RRR (a described machine's forward kinematics solves a polynomial system:
    compiled)."""
    return args.command == "ik" or (args.command in ("fk", "dynamics") and getattr(args, "mechanism", None) is None)


def _run(argv: list[str] | None, one_shot_interpreted: bool = False) -> int:
    parser = build_parser()
    args = parser.parse_args(argv)
    import os

    interpreted_here = (one_shot_interpreted and _interpreted(args) and "pkmlab._compile_cache" not in sys.modules
                        and "PKMLAB_INTERPRETED" not in os.environ)  # the user's choice kept
    if interpreted_here:
        os.environ["PKMLAB_INTERPRETED"] = "1"  # read when the first kernel module is imported
    try:
        return _command(args)
    finally:
        if interpreted_here:  # not passed on to anything this process starts
            os.environ.pop("PKMLAB_INTERPRETED", None)


def _command(args) -> int:
    try:
        _check_finite(args)
        _check_mode(args)
        _compile_notice(args)
        result = _with_notes(args)
    except PkmlabError as exc:
        if getattr(args, "json", False):
            print(json.dumps({"error": {"type": type(exc).__name__, "message": str(exc)}}))
        else:
            print(f"pkmlab {args.command}: error: {exc}", file=sys.stderr)
        return 1
    except KeyboardInterrupt as exc:  # a study's says what it kept and how to finish
        print(f"pkmlab {args.command}: interrupted" + (f": {exc}" if str(exc) else ""), file=sys.stderr)
        return 130
    if getattr(args, "json", False):
        print(json.dumps(_strict_json(result), indent=2, allow_nan=False))
    sys.stdout.flush()
    return 0


def main(argv: list[str] | None = None, one_shot_interpreted: bool = False) -> int:
    """The ``pkmlab`` command. Exit codes: 0 success, 1 a problem with the input (one line on stderr),
    2 a malformed command line, 130 interrupted (Ctrl-C, at any moment, start-up included), 141 the
    reader of the output went away (a closed pipe, as ``| head``), quietly.

    ``one_shot_interpreted`` (the executable's choice, :func:`entry`): in a process that has not loaded any
    kernel yet, the one-shot commands (``ik`` ...) run their kernels interpreted: the same code, without
    the 0.4 s of importing Numba and loading compiled kernels."""
    try:
        return _run(argv, one_shot_interpreted)
    except KeyboardInterrupt:
        print("pkmlab: interrupted", file=sys.stderr)
        return 130
    except BrokenPipeError:
        _quiet_stdout()
        return 141


def _interrupt_from_callbacks(hook=sys.unraisablehook):
    """``sys.unraisablehook`` that turns a Ctrl-C caught inside a callback from compiled code (Numba's
    LLVM engine calls back into Python while it compiles; an exception there cannot propagate and would
    be printed as "Exception ignored", then lost) into a Ctrl-C delivered again to the main program."""
    import signal

    def interrupt(*_args):
        raise KeyboardInterrupt

    def unraisable(info):
        if isinstance(info.exc_value, KeyboardInterrupt) and hasattr(signal, "setitimer"):
            # raised here it would be caught again: deliver it a moment later, once out of the callback
            signal.signal(signal.SIGALRM, interrupt)
            signal.setitimer(signal.ITIMER_REAL, 0.005)
        else:
            hook(info)

    return unraisable


def entry() -> int:
    """The ``pkmlab`` executable: :func:`main` with Ctrl-C honoured everywhere, even inside callbacks of
    compiled code; ignored only once the work is done and the interpreter shuts down (its exit handlers
    would otherwise print a traceback, and there is nothing left to interrupt)."""
    import signal

    sys.unraisablehook = _interrupt_from_callbacks()
    code = main(one_shot_interpreted=True)
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    if hasattr(signal, "setitimer"):
        signal.setitimer(signal.ITIMER_REAL, 0)  # a Ctrl-C still to be delivered: the work is done
    return code


if __name__ == "__main__":
    sys.exit(entry())
