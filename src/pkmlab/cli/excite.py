"""``pkmlab excite``: an excitation trajectory for dynamic identification, written as a scenario to run and a table
of the actuators' motion to play on a real machine.

The folder (``--out``) receives ``excitation.toml`` (a scenario: ``pkmlab simulate`` runs it, and its ``run.csv``
is a log ``pkmlab identify`` reads), ``excitation.csv`` (columns ``t``, ``theta1..n``, ``theta_dot1..n``,
``theta_ddot1..n``, the pose's coordinates, ``S``) and ``excitation.json`` (the summary,
:meth:`pkmlab.control.excitation.Excitation.summary`, with the mechanism and the number of base parameters).
"""

from __future__ import annotations

import json
import os
from pathlib import Path

from ._common import mechanism_name, model_of, strict_json, working_mode


def _mechanism_table(args) -> dict:
    """The scenario's ``[mechanism]``: the preset, or the description file relative to the output folder (the
    folder can be moved with it)."""
    from ..description.presets import PRESETS

    name = getattr(args, "mechanism", None) or "paper"
    if name in PRESETS:
        return {"preset": name}
    return {"file": Path(os.path.relpath(Path(name).resolve(), Path(args.out).resolve())).as_posix()}


def _csv(motion, model) -> str:
    n = model.n_actuators
    header = ["t", *(f"theta{j + 1}" for j in range(n)), *(f"theta_dot{j + 1}" for j in range(n)),
              *(f"theta_ddot{j + 1}" for j in range(n)), *model.pose_names, "S"]
    import numpy as np

    rows = np.column_stack([motion.t, motion.theta, motion.theta_dot, motion.theta_ddot, motion.pose, motion.S])
    return "\n".join([",".join(header), *(",".join(map(repr, row)) for row in rows.tolist())]) + "\n"


def _limit(values):
    if values is None:
        return None
    return values[0] if len(values) == 1 else values


def cmd_excite(args) -> dict:
    """``excite``: optimise the trajectory, print its summary (or the JSON) and write the folder."""
    from ..algorithms.regressor import base_parameters
    from ..control.excitation import excitation_trajectory
    from ..errors import InvalidParameterError
    from ..formats.scenario import fourier_table, scenario_to_toml
    from ..outputs import atomic_output_dir
    from ..progress import Progress

    if getattr(args, "params", None):
        raise InvalidParameterError("excite writes a scenario of a described machine: give --mechanism FILE.toml "
                                    "(a description file) instead of --params")
    model = model_of(args)
    mode = working_mode(args, model)
    if args.center is not None and len(args.center) != model.dof:
        args.parser.error(f"argument --center: the {model.name}'s pose is {' '.join(model.pose_names)}: "
                          f"{model.dof} numbers, got {len(args.center)}")
    provenance = {"period_s": args.period, "harmonics": args.harmonics, "periods": args.periods,
                  "seed": args.seed, "rate_hz": args.rate}
    with atomic_output_dir(args.out, "excite", provenance=provenance) as tmp:
        with Progress(args.iterations, "optimising the excitation", enabled=not args.quiet,
                      unit="iterations") as bar:
            def tell(_k, _best):
                bar.update(1)

            excitation = excitation_trajectory(
                model, period=args.period, harmonics=args.harmonics, periods=args.periods, center=args.center,
                mode=mode, excursion=_limit(args.excursion), velocity=_limit(args.velocity),
                effort=_limit(args.effort), singularity_margin=args.margin, drives=args.drives, seed=args.seed,
                iterations=args.iterations, callback=tell)
        motion = excitation.motion(model, args.rate)
        rank = base_parameters(model, drives=args.drives).rank
        out = {"mechanism": mechanism_name(args, model), "base_parameters": rank,
               **excitation.summary(), "rate_hz": args.rate, "samples": len(motion.t)}
        scenario = {"mechanism": _mechanism_table(args), "trajectory": fourier_table(excitation.trajectory),
                    "controller": {"type": "computed_torque", "kp": 1000.0, "sample_time": 1.0 / args.rate},
                    "simulation": {"working_mode": list(excitation.mode), "singularity_margin": args.margin}}
        tr = excitation.trajectory
        comment = (f"An excitation trajectory of the {model.name} written by pkmlab excite: {tr.harmonics} harmonics "
                   f"of a {tr.period:g} s period, condition number of the base regressor "
                   f"{excitation.condition_number:.4g}.\nRun it with pkmlab simulate; identify from the run.csv it "
                   "writes with pkmlab identify.")
        (tmp / "excitation.toml").write_text(scenario_to_toml(scenario, comment))
        (tmp / "excitation.csv").write_text(_csv(motion, model))
        (tmp / "excitation.json").write_text(json.dumps(strict_json(out), indent=2) + "\n")
    if not args.json:
        print(f"{model.name}: {tr.harmonics} harmonics over {tr.duration:g} s, condition number "
              f"{excitation.start_condition_number:.4g} -> {excitation.condition_number:.4g} "
              f"({out['base_parameters']} base parameters, {excitation.iterations} iterations)")
        print(f"min |S| {excitation.singularity:.3g}; peak rate per actuator "
              f"{', '.join(f'{v:.3g}' for v in excitation.velocity)}; peak effort "
              f"{', '.join(f'{v:.3g}' for v in excitation.effort)}")
        print(f"results in {args.out}/: run it with pkmlab simulate {Path(args.out) / 'excitation.toml'} --out RUN")
    return out
