"""The command line's grammar: one ``argparse`` sub-parser per command. Each command's function is imported
only when it runs (:func:`_command`), so that a one-shot command loads nothing it does not use."""

from __future__ import annotations

import argparse
import re

from .._version import __version__
from ._common import DEFAULT_MECHANISM, MAX_RESOLUTION
from .help import TOPICS as HELP_TOPICS

# argparse reads only "-1" and "-1.5" as negative numbers: "-1e-3", "-1.2E+00" or "-inf" would be
# taken for unknown options and the positional argument reported missing. Widen its matcher (a
# private attribute of the parser) so every negative float is read as a value — and a working
# mode written as one word that starts with a minus ("-+-", "--+").
_NEGATIVE_NUMBER = re.compile(r"^-(\d+\.?\d*|\.\d+)(e[+-]?\d+)?$|^-(inf|infinity|nan)$|^-[+-]{2}$", re.IGNORECASE)


def _force(p) -> None:
    p.add_argument("--force", action="store_true", help="replace the output file even if pkmlab did not write it "
                   "(by default only a file pkmlab wrote, unchanged since, is replaced)")


def _kinds(p) -> None:
    p.add_argument("--kinds", action="store_true", help="also the inverse (serial) and constraint singularity "
                   "measures of each solution, beside S (the forward one): each zero at a singularity of its kind")


def _accept_negative_numbers(parser: argparse.ArgumentParser) -> argparse.ArgumentParser:
    parser._negative_number_matcher = _NEGATIVE_NUMBER
    return parser


class _Spelled(argparse.Action):
    """An option of several spellings that remembers the one typed (``args.DEST_flag``), for its messages."""

    def __call__(self, parser, namespace, values, option_string=None):
        setattr(namespace, self.dest, values)
        setattr(namespace, f"{self.dest}_flag", option_string)


def build_parser() -> argparse.ArgumentParser:
    parser = argparse.ArgumentParser(prog="pkmlab", description="Kinematics, dynamics and control of "
                                     "parallel manipulators: the paper's planar 3-RRR by default, any preset or "
                                     "described machine with --mechanism. Angles in radians, lengths in metres.")
    _accept_negative_numbers(parser)
    parser.add_argument("--version", action="version", version=f"pkmlab {__version__}")
    sub = parser.add_subparsers(dest="command", required=True)

    def common(p):
        _accept_negative_numbers(p)
        p.add_argument("--params", metavar="FILE.toml", help="deprecated: a parameter file of the paper's 3-RRR "
                       "(use --mechanism FILE.toml, a description file)")
        p.add_argument("--json", action="store_true", help="machine-readable output")

    def mechanism(p, default: str = f"{DEFAULT_MECHANISM} (the paper's 3-RRR)"):
        p.add_argument("--mechanism", metavar="NAME|FILE.toml", help="the machine: a preset (paper, five_bar, "
                       f"3rpr, 3prr, delta, stewart) or a description file; default: {default}")

    p = sub.add_parser("ik", help="inverse kinematics: every working mode that reaches a platform pose")
    p.add_argument("pose", nargs="+", type=float, metavar="POSE",
                   help="the platform pose: x y alpha (the paper's 3-RRR, a planar rigid platform), x y (a point), "
                   "x y z (the Delta), x y z roll pitch yaw (a six-DOF platform; R = Rz(yaw) Ry(pitch) Rx(roll))")
    p.add_argument("--mode", nargs="+", metavar="SIGN", help="one working mode: one sign per two-branch leg "
                   "(+ - + or one word +-+); default every working mode")
    _kinds(p)
    mechanism(p)
    common(p)
    p.set_defaults(func=_command("kinematics", "cmd_ik"))

    p = sub.add_parser("fk", help="forward kinematics: every assembly mode of the actuator values")
    p.add_argument("theta", nargs="+", type=float, metavar="THETA",
                   help="the actuator values theta1 theta2 ... (angles in rad, slides in m)")
    _kinds(p)
    mechanism(p)
    common(p)
    p.set_defaults(func=_command("kinematics", "cmd_fk"))

    p = sub.add_parser("dynamics", help="the actuator-space model M, c, g (paper eq. 35, with gravity) and the "
                       "loop-closure multipliers (eq. 26) at a state, for every assembly mode")
    p.add_argument("theta", nargs="+", type=float, metavar="THETA",
                   help="the actuator values theta1 theta2 ... (angles in rad, slides in m)")
    p.add_argument("--theta-dot", "--rates", dest="theta_dot", nargs="+", type=float, metavar="W", action=_Spelled,
                   help="the actuator rates theta_dot (rad/s or m/s), default 0; --rates is a synonym")
    p.add_argument("--tau", nargs="+", type=float, metavar="T", help="the actuator efforts (N m or N) under which "
                   "the multipliers are computed; default c + g, the efforts of zero actuator acceleration (the JSON "
                   "says which in \"tau_from\" and gives them as \"tau\")")
    p.add_argument("--near", nargs="+", type=float, metavar="POSE",
                   help="only the assembly mode whose platform pose is nearest to this pose (as ik takes it)")
    mechanism(p)
    common(p)
    p.set_defaults(func=_command("dynamics", "cmd_dynamics"))

    p = sub.add_parser("reproduce", help="the paper's three simulated cases with every figure (paper §5)")
    p.add_argument("--out", default="out", help="output folder (default: out)")
    p.add_argument("--control", choices=("sampled", "continuous"), default="sampled",
                   help="sampled-data control at 1 ms (default) or continuous-time")
    p.add_argument("--no-figures", action="store_true", help="skip the figures")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    mechanism(p, default="paper (the paper's own cases); another machine whose pose is x, y, alpha runs them "
              "on that machine")
    common(p)
    p.set_defaults(func=_command("reproduce", "cmd_reproduce"))


    p = sub.add_parser("simulate", help="simulate a scenario file: summary, time series, figures, REPORT.md")
    p.add_argument("scenario", metavar="SCENARIO.toml", help="the scenario (format: pkmlab help scenario-files)")
    p.add_argument("--out", required=True, metavar="DIR", help="output folder: new, empty, or an earlier result of "
                   "pkmlab simulate (replaced when the run succeeds; anything else in it is refused, never deleted)")
    p.add_argument("--no-figures", action="store_true", help="skip the figures")
    p.add_argument("--quiet", action="store_true", help="no progress messages")
    p.add_argument("--json", action="store_true", help="print the summary as JSON")
    p.add_argument("--plant", choices=("pkmlab", "mujoco"), default="pkmlab", help="the plant the controller runs "
                   "against: pkmlab's exact actuator-space model (default) or MuJoCo's integration of the exported "
                   "machine")
    p.add_argument("--mujoco-timestep", type=float, metavar="DT", help="MuJoCo's time step (s), dividing the sample "
                   "time; default the sample time or 1 ms, whichever is smaller")
    p.add_argument("--mujoco-integrator", choices=("RK4", "implicitfast", "implicit", "Euler"), default="RK4",
                   help="MuJoCo's integrator, default RK4")
    p.add_argument("--mujoco-closures", metavar="stiff|soft", help="MuJoCo's loop closures: stiff (default: "
                   "solimp 0.9999, solref 2 ms, they behave like the rigid machine) or soft (MuJoCo's defaults: the "
                   "loops open by up to a few mm)")
    p.add_argument("--mujoco-stiff", action="store_true", help="deprecated, does nothing: stiff closures are the "
                   "default")
    mechanism(p, default="the scenario's own machine (its [manipulator] or [mechanism] table)")
    p.set_defaults(func=_command("simulate", "cmd_simulate"))

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
    p.add_argument("study", metavar="SWEEP.toml", help="the study (format: pkmlab help study-files)")
    p.add_argument("--out", required=True, metavar="DIR", help="the study's folder: new or empty, or this study's "
                   "(with --resume)")
    p.add_argument("--resume", action="store_true", help="finish the study DIR holds, running only what is missing")
    p.add_argument("--csv", action="store_true", help="also write the table as runs.csv")
    p.add_argument("--heatmap", nargs=2, metavar=("Y", "X"), help="the two axes of the maps (default: the first "
                   "two that vary)")
    p.add_argument("--no-figures", action="store_true", help="skip the figures")
    execution(p)
    p.set_defaults(func=_command("study", "cmd_sweep"))

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
    p.add_argument("--kp-range", type=float, nargs=2, metavar=("LO", "HI"),
                   help="the search box of kp, 1/s^2 (default 10 to 1e6 or, under sampled-data computed torque, the "
                   "loop's stability limit if lower): bound it by what the machine's sensors and drives allow, which "
                   "the model does not know")
    p.add_argument("--zeta-range", type=float, nargs=2, metavar=("LO", "HI"),
                   help="the search box of the damping ratio, kv = 2 zeta sqrt(kp) (default 0.3 3; not with "
                   "--critical)")
    p.add_argument("--trials", type=int, default=48, metavar="N", help="candidate gains to evaluate (default 48)")
    p.add_argument("--seed", type=int, default=0, help="seed of the draws and the optimiser (default 0)")
    execution(p)
    p.set_defaults(func=_command("study", "cmd_tune"))

    p = sub.add_parser("view", help="an interactive HTML view of a result folder: the machine animated in sync "
                       "with its time series, offline")
    p.add_argument("result_dir", metavar="RESULT_DIR", help="a folder of pkmlab simulate or pkmlab reproduce")
    p.add_argument("--out", metavar="FILE.html", help="where to write it (default RESULT_DIR/REPORT.html, added to "
                   "the folder's manifest)")
    _force(p)
    p.add_argument("--json", action="store_true", help="machine-readable output")
    p.set_defaults(func=_command("view", "cmd_view"))

    p = sub.add_parser("demo", help="kinematics demo on the paper's circle (figure 3)")
    p.add_argument("--out", default="demo", help="output folder (default: demo)")
    p.add_argument("--resolution", type=int, default=241, help="grid points per axis of the S map")
    mechanism(p)
    common(p)
    p.set_defaults(func=_command("reproduce", "cmd_demo"))

    def figure_region(p, what: str):
        p.add_argument("--alpha", type=float, metavar="A", help="the platform's orientation (rad; default 0), for a "
                       "planar platform that has one")
        p.add_argument("--resolution", type=int, default=201, metavar="N",
                       help=f"grid points per axis (2..{MAX_RESOLUTION}, default 201)")
        p.add_argument("--x-range", nargs=2, type=float, metavar=("XMIN", "XMAX"),
                       help="x extent (m), default: the base and every leg's reach")
        p.add_argument("--y-range", nargs=2, type=float, metavar=("YMIN", "YMAX"), help="y extent (m)")
        p.add_argument("--out", required=True, metavar="FILE.png", help=f"the figure of the {what} (PNG, PDF, SVG...)")
        _force(p)
        p.add_argument("--quiet", action="store_true", help="no progress bar")

    p = sub.add_parser("singularity-map", help="S over x-y at one orientation and working mode, S = 0 drawn "
                       "(paper figure 3)")
    figure_region(p, "map")
    p.add_argument("--mode", nargs="+", metavar="SIGN", help="working mode: three signs (+ - +) or one word (+-+); "
                   "default + + +")
    p.add_argument("--csv", metavar="FILE.csv", help="also write the grid: columns x, y, S (NaN out of reach)")
    mechanism(p)
    common(p)
    p.set_defaults(func=_command("maps", "cmd_singularity_map"))

    p = sub.add_parser("workspace", help="reachable region at one orientation for each working mode (a spatial "
                       "machine: horizontal slices in one working mode)")
    figure_region(p, "working modes")
    p.add_argument("--z", nargs="+", type=float, metavar="Z", help="a spatial machine's slice heights (m), default "
                   "six spread over the heights it reaches")
    p.add_argument("--mode", nargs="+", metavar="SIGN", help="a spatial machine's working mode (+ + +); default the "
                   "first")
    mechanism(p)
    common(p)
    p.set_defaults(func=_command("maps", "cmd_workspace"))

    p = sub.add_parser("export-mjcf", help="the machine as a MuJoCo model (MJCF): its bodies, joints, loop "
                       "closures, motors and gravity")
    p.add_argument("--out", required=True, metavar="FILE.xml", help="the MJCF file")
    _force(p)
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
    p.set_defaults(func=_command("mujoco", "cmd_export_mjcf"))

    p = sub.add_parser("identify", help="dynamic identification: the machine's base parameters, with their "
                       "standard deviations, from a log of measured actuators and efforts")
    p.add_argument("log", metavar="LOG.csv", help="columns t, theta1..n, tau1..n at a fixed rate (the run.csv of "
                   "pkmlab simulate is one); pose columns, when all there, choose the starting assembly mode")
    p.add_argument("--window", type=float, metavar="S", help="the Savitzky-Golay filter's window (s) that smooths "
                   "and differentiates the actuators and smooths the efforts; default 0.05")
    p.add_argument("--polyorder", type=int, metavar="K", help="the filter's polynomial order (2..10, default 4)")
    p.add_argument("--drives", action="store_true", help="also each actuator's armature and viscous and Coulomb "
                   "friction")
    p.add_argument("--efforts", choices=("held", "sampled"), default="held", help="how the logged efforts act: held "
                   "from each sample to the next (commanded efforts, pkmlab simulate's tau; default) or sampled at "
                   "their instants (a measurement)")
    p.add_argument("--reversals", choices=("drop", "keep"), default="drop", help="the samples whose filter window "
                   "holds a reversal of an actuator's rate, where the smoothed effort mixes the friction of both "
                   "directions: left out (default; kept, they bias the friction estimates) or kept")
    p.add_argument("--coulomb-rate", type=float, metavar="V", help="with --drives, the Coulomb friction model "
                   "fc tanh(rate / V) (the [plant] key coulomb_rate); default 0, fc sign(rate)")
    p.add_argument("--mode", nargs="+", metavar="SIGN", help="the working mode whose home configuration chooses the "
                   "starting assembly mode when the log has no pose columns (default the first)")
    p.add_argument("--validate", metavar="LOG.csv", help="a held-out log of the same machine: its efforts against "
                   "the estimate's prediction (RMS in the JSON; with --out, prediction.png)")
    p.add_argument("--consistent", action="store_true", help="also the physically consistent estimate (every body's "
                   "mass and inertia real), and with --out identified.toml: the machine with them, a description "
                   "file pkmlab simulate takes")
    p.add_argument("--out", metavar="DIR", help="also write identification.json and base_parameters.csv there: a new "
                   "or empty folder, or an earlier result of pkmlab identify")
    mechanism(p)
    common(p)
    p.set_defaults(func=_command("identify", "cmd_identify"))

    p = sub.add_parser("calibrate", help="kinematic calibration: the machine's geometry and actuator offsets from "
                       "its readings at externally measured poses")
    p.add_argument("poses", metavar="POSES.csv", help="one row per measured pose: theta1..n and the measured x, y[, z] "
                   "(or, with --measure pose, every pose coordinate)")
    p.add_argument("--measure", choices=("position", "pose"), default="position", help="what the instrument "
                   "measures: the tracked point (a laser tracker, default) or the whole pose")
    p.add_argument("--validate", metavar="HELD.csv", help="held-out poses in the same format: each one's error "
                   "predicted from its readings by the described and the calibrated machine (in the JSON; with --out, "
                   "validation.png)")
    p.add_argument("--out", metavar="DIR", help="also write calibration.json and calibrated.toml there: a new or empty "
                   "folder, or an earlier result of pkmlab calibrate")
    mechanism(p)
    common(p)
    p.set_defaults(func=_command("calibrate", "cmd_calibrate"))

    p = sub.add_parser("excite", help="an excitation trajectory for identification: a periodic motion of the pose "
                       "that makes the base parameters well determined, within limits; written as a scenario to run "
                       "and a table of the actuators' motion")
    p.add_argument("--out", required=True, metavar="DIR", help="write excitation.toml (a scenario pkmlab simulate "
                   "runs), excitation.csv and excitation.json there: a new or empty folder, or an earlier result of "
                   "pkmlab excite")
    p.add_argument("--period", type=float, default=10.0, metavar="S", help="the period (s); default 10")
    p.add_argument("--harmonics", type=int, default=5, metavar="K", help="harmonics per pose coordinate (2..20, "
                   "default 5)")
    p.add_argument("--periods", type=int, default=1, metavar="N", help="times the period is repeated (default 1)")
    p.add_argument("--center", nargs="+", type=float, metavar="POSE", help="the pose the motion is about, where it "
                   "starts and ends (default a pose far from singularities)")
    p.add_argument("--excursion", nargs="+", type=float, metavar="E", help="largest distance from the centre: one "
                   "number, or one per pose coordinate (m, rad); default 0.1 of the machine's size, 0.3 rad")
    p.add_argument("--velocity", nargs="+", type=float, metavar="V", help="largest actuator rate (rad/s, m/s): one "
                   "number or one per actuator; default none")
    p.add_argument("--effort", nargs="+", type=float, metavar="F", help="largest effort of the model (N m, N): one "
                   "number or one per actuator; default none")
    p.add_argument("--margin", type=float, default=0.05, metavar="S", help="the smallest |S| along the motion "
                   "(default 0.05)")
    p.add_argument("--mode", nargs="+", metavar="SIGN", help="the working mode (default the first)")
    p.add_argument("--drives", action="store_true", help="excite the drives' armature and friction too")
    p.add_argument("--seed", type=int, default=0, help="the optimisation's random start (default 0)")
    p.add_argument("--iterations", type=int, default=50, metavar="N", help="the optimiser's largest number of "
                   "iterations (default 50)")
    p.add_argument("--rate", type=float, default=1000.0, metavar="HZ", help="samples per second of excitation.csv "
                   "and the scenario's controller (default 1000)")
    p.add_argument("--quiet", action="store_true", help="no progress bar")
    _accept_negative_numbers(p)
    mechanism(p)
    common(p)
    p.set_defaults(func=_command("excite", "cmd_excite"))

    p = sub.add_parser("animate", help="GIF of a run written by pkmlab reproduce or pkmlab simulate")
    p.add_argument("result_dir", metavar="RESULT_DIR", help="folder written by pkmlab reproduce or pkmlab simulate")
    p.add_argument("--out", required=True, metavar="FILE.gif", help="the animated GIF")
    _force(p)
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
    p.set_defaults(func=_command("animate", "cmd_animate"))
    p = sub.add_parser("help", help="print a reference page shipped with pkmlab: file formats, output folders, "
                       "exit codes (without TOPIC: the list of topics)")
    p.add_argument("topic", nargs="?", choices=tuple(HELP_TOPICS), metavar="TOPIC",
                   help=f"one of: {', '.join(HELP_TOPICS)}")
    p.set_defaults(func=_command("help", "cmd_help"), quiet=True)

    for command in sub.choices.values():  # each command knows its parser: its errors show its usage
        command.set_defaults(parser=command)
    return parser


def _command(module: str, name: str):
    """The command ``name`` of the module ``module`` of this package, imported when it is called."""

    def run(args):
        import importlib

        return getattr(importlib.import_module(f".{module}", __package__), name)(args)

    run.__name__ = run.__qualname__ = name
    return run
