"""``pkmlab identify``: a machine's base parameters estimated from a log of its actuators and efforts.

JSON (``--json``): ``{"mechanism", "log", "window_s", "polyorder", "efforts", "reversals", "drives", ...}`` (with
``--drives``, also ``coulomb_rate``, the friction model estimated) and the estimate's
summary (:meth:`pkmlab.algorithms.identification.Identification.summary`): ``base_parameters`` (name, estimate,
sigma, relative_sigma_percent), ``condition_number``, ``samples``, ``effort_sigma``, ``rms_residual``,
``unidentifiable``; with ``--consistent``, ``consistent``: ``{"distance", "parameters": {name: value}}`` (the
physically consistent standard parameters, :func:`pkmlab.algorithms.consistency.physically_consistent`), and
``identified.toml`` written: the machine's description with the identified masses, mass centres and inertias,
and ``controller.toml``: the ``[controller]`` table of a scenario that computes with it (and, with ``--drives``,
compensates the identified drives) against the scenario's machine as the plant.
"""

from __future__ import annotations

import contextlib
import json

from ..errors import InvalidParameterError
from ._common import mechanism_name, model_of, strict_json, table, working_mode


def _rows(summary: dict) -> list[list]:
    return [[row["name"], f"{row['estimate']:.6g}", f"{row['sigma']:.3g}", f"{row['relative_sigma_percent']:.3g}"]
            for row in summary["base_parameters"]]


def _csv(summary: dict) -> str:
    lines = ["name,estimate,sigma,relative_sigma_percent"]
    lines += [f"\"{row['name']}\",{row['estimate']!r},{row['sigma']!r},{row['relative_sigma_percent']!r}"
              for row in summary["base_parameters"]]
    return "\n".join(lines) + "\n"


def _controller_table(model, consistent, args, coulomb_rate: float) -> str:
    """``controller.toml``: a scenario's ``[controller]`` table that computes with the identified machine
    (``identified.toml`` beside it) and, with ``--drives``, compensates its identified drives."""
    from ..formats.scenario import scenario_to_toml

    table = {"mechanism": "identified.toml"}
    if args.drives:
        from ..simulation.realism import Drives

        drives = Drives.from_estimate(consistent, model.n_actuators, coulomb_rate=coulomb_rate)
        table |= {"gear_ratio": 1.0, "armature": list(drives.armature), "viscous": list(drives.viscous),
                  "coulomb": list(drives.coulomb), "coulomb_rate": coulomb_rate}
    comment = (f"pkmlab identify --consistent{' --drives' if args.drives else ''} of {args.log}: computed torque's "
               "model of the identified machine\n(the armature is the identified one, at the joint: gear_ratio = 1), "
               "the [controller] table of a scenario whose machine is\nthe real one (its plant). The path is relative "
               "to the scenario's folder: keep the two files together, or change it.")
    return scenario_to_toml({"controller": table}, comment)


def cmd_identify(args) -> dict:
    """``identify``: read the log, filter it, estimate the base parameters by weighted least squares; print the
    table (or the JSON), and with ``--out`` write it."""
    from ..algorithms.identification import DEFAULT_POLYORDER, DEFAULT_WINDOW, filter_measurements, identify
    from ..formats.measurements import read_measurement_log
    from ..outputs import atomic_output_dir

    model = model_of(args)
    mode = working_mode(args, model)
    window = DEFAULT_WINDOW if args.window is None else args.window
    polyorder = DEFAULT_POLYORDER if args.polyorder is None else args.polyorder
    coulomb_rate = 0.0 if args.coulomb_rate is None else args.coulomb_rate
    if args.coulomb_rate is not None and not args.drives:
        raise InvalidParameterError("--coulomb-rate is the drives' friction model: it needs --drives")
    provenance = {"log": str(args.log), "window_s": window, "polyorder": polyorder, "efforts": args.efforts,
                  "reversals": args.reversals, "drives": args.drives,
                  **({"coulomb_rate": coulomb_rate} if args.drives else {})}
    inputs = [args.log, *([args.validate] if args.validate else [])]
    folder = (atomic_output_dir(args.out, "identify", inputs=inputs, provenance=provenance) if args.out else
              contextlib.nullcontext())

    def filtered(path):
        """The log file ``path`` read and filtered into states, its filter's errors naming the file (their rows
        are the file's)."""
        log = read_measurement_log(path, model)
        try:
            return filter_measurements(model, log.t, log.theta, log.tau, window=window, polyorder=polyorder,
                                       pose=log.pose, mode=mode, first_row=1, efforts=args.efforts,
                                       reversals=args.reversals)
        except InvalidParameterError as exc:
            raise InvalidParameterError(f"{path}: {exc}") from None

    with folder as tmp:  # a folder that cannot take the results is refused before the log is read
        data = filtered(args.log)
        result = identify(model, *data.states, data.tau, drives=args.drives, coulomb_rate=coulomb_rate)
        out = {"mechanism": mechanism_name(args, model), **provenance, **result.summary()}
        identified = None
        if args.consistent:
            from ..algorithms.consistency import identified_model, physically_consistent
            from ..description.files import mechanism_to_toml

            consistent = physically_consistent(model, result)
            out["consistent"] = {"distance": consistent.distance,
                                 "parameters": dict(zip(consistent.names, consistent.parameters.tolist(),
                                                        strict=True))}
            identified = mechanism_to_toml(identified_model(model, consistent).description,
                                           f"{model.name} identified by pkmlab identify from {args.log}: the "
                                           "physically consistent estimate's masses, mass centres and inertias")
            controller = _controller_table(model, consistent, args, coulomb_rate)
        figure = None
        if args.validate:  # a held-out log: its efforts against the estimate's prediction at its states
            import numpy as np

            other = filtered(args.validate)
            predicted = result.predict(model, *other.states)
            rms = np.sqrt(np.mean((other.tau - predicted) ** 2, axis=0))
            out["validation"] = {"log": str(args.validate), "samples": int(len(other.t)),
                                 "rms_error": rms.tolist(),
                                 "rms_effort": np.sqrt(np.mean(other.tau**2, axis=0)).tolist()}
            if tmp is not None:
                import matplotlib

                matplotlib.use("Agg")
                from ..views.plotting import plot_effort_prediction

                figure = plot_effort_prediction(other.t, other.tau, predicted,
                                                kinds=model.description.actuator_kinds).figure
        if tmp is not None:
            if figure is not None:
                import matplotlib.pyplot as plt

                figure.savefig(tmp / "prediction.png", dpi=130)
                plt.close(figure)
            (tmp / "identification.json").write_text(json.dumps(strict_json(out), indent=2) + "\n")
            (tmp / "base_parameters.csv").write_text(_csv(out))
            if identified is not None:
                (tmp / "identified.toml").write_text(identified)
                (tmp / "controller.toml").write_text(controller)
    if not args.json:
        print(f"{model.name}: {len(out['base_parameters'])} base parameters from {out['samples']} samples of "
              f"{args.log} (condition number {out['condition_number']:.4g})")
        print(table(["base parameter", "estimate", "sigma", "sigma %"], _rows(out)))
        rms = ", ".join(f"{v:.3g}" for v in out["rms_residual"])
        print(f"rms effort residual per actuator: {rms}")
        if out["unidentifiable"]:
            print(f"unidentifiable (no effort depends on them): {', '.join(out['unidentifiable'])}")
        if args.validate:
            errors = ", ".join(f"{e:.3g} of {r:.3g}" for e, r in zip(out["validation"]["rms_error"],
                                                                    out["validation"]["rms_effort"], strict=True))
            print(f"held-out {args.validate}: RMS effort error per actuator {errors}"
                  + (f" (figure {args.out}/prediction.png)" if args.out else ""))
        if args.consistent:
            print(f"physically consistent estimate: Mahalanobis distance {out['consistent']['distance']:.3g} to the "
                  "least-squares one" + (f"; the machine in {args.out}/identified.toml" if args.out else ""))
        if args.out:
            print(f"results in {args.out}/")
    return out
