"""``pkmlab calibrate``: a machine's geometry calibrated from its actuator readings at measured poses.

The CSV has one row per measured pose: ``theta1..n`` (the readings) and the measured coordinates by the pose's
names — ``x, y[, z]`` for a laser tracker (``--measure position``, the default) or every pose coordinate
(``--measure pose``). JSON (``--json``): ``{"mechanism", "poses_file", "measure", ...}`` and the calibration's
summary (:meth:`pkmlab.algorithms.calibration.Calibration.summary`); with ``--out`` also ``calibration.json``
and ``calibrated.toml`` (the description with the calibrated geometry; the actuators' offsets are in the JSON:
add them to the readings). ``--validate HELD.csv`` (held-out poses, same format) adds ``validation``:
``{"poses", "rms_before", "rms_after", "max_point_error_before", "max_point_error_after", "poses_file"}`` — each
held-out pose predicted from its readings by the described and the calibrated machine — and with ``--out``
``validation.png``.
"""

from __future__ import annotations

import contextlib
import json

from ._common import mechanism_name, model_of, strict_json, table


def _read(path, model, measure: str):
    import numpy as np

    from ..errors import FileFormatError
    from ..formats.params import read_result_csv

    n = model.n_actuators
    names = model.pose_names
    measured = list(names) if measure == "pose" else [c for c in names if c in ("x", "y", "z")]
    data = read_result_csv(path, [*(f"theta{j + 1}" for j in range(n)), *measured])
    theta = np.column_stack([data[f"theta{j + 1}"] for j in range(n)])
    if len(theta) == 0:
        raise FileFormatError(f"{path}: no poses (one row per measured pose)")
    return theta, np.column_stack([data[c] for c in measured])


def _validation(model, result, theta, measured, measure: str):
    """The held-out poses' errors: measured against predicted from the readings by the described and the calibrated
    machine — RMS over the measured coordinates, and the tracked point's distance per pose."""
    import numpy as np

    from ..algorithms.calibration import predicted_measurements

    described = measured - predicted_measurements(model, theta, measured, measure=measure)
    calibrated = measured - predicted_measurements(result.model, theta, measured, measure=measure,
                                                   offsets=result.offsets)
    names = model.pose_names if measure == "pose" else [n for n in model.pose_names if n in ("x", "y", "z")]
    point = [i for i, n in enumerate(names) if n in ("x", "y", "z")]
    before, after = (np.linalg.norm(e[:, point], axis=1) for e in (described, calibrated))
    summary = {"poses": int(len(theta)), "rms_before": float(np.sqrt(np.nanmean(described**2))),
               "rms_after": float(np.sqrt(np.nanmean(calibrated**2))), "max_point_error_before": float(before.max()),
               "max_point_error_after": float(after.max())}
    return summary, (before, after)


def _figure(path, before, after, unit) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from ..views.plotting import plot_calibration_validation

    figure = plot_calibration_validation(before, after, unit=unit).figure
    figure.savefig(path, dpi=130, bbox_inches="tight")
    plt.close(figure)


def cmd_calibrate(args) -> dict:
    """``calibrate``: read the poses, calibrate, print the table (or the JSON), and with ``--out`` write it."""
    from ..algorithms.calibration import calibrate
    from ..description.files import mechanism_to_toml
    from ..outputs import atomic_output_dir

    model = model_of(args)
    provenance = {"poses_file": str(args.poses), "measure": args.measure}
    inputs = [args.poses, *([args.validate] if args.validate else [])]
    folder = (atomic_output_dir(args.out, "calibrate", inputs=inputs, provenance=provenance) if args.out else
              contextlib.nullcontext())
    with folder as tmp:
        theta, measured = _read(args.poses, model, args.measure)
        held = _read(args.validate, model, args.measure) if args.validate else None  # refused before any work
        result = calibrate(model, theta, measured, measure=args.measure)
        out = {"mechanism": mechanism_name(args, model), **provenance, **result.summary(),
               "offsets": result.offsets.tolist()}
        if held is not None:
            out["validation"], errors = _validation(model, result, *held, args.measure)
            out["validation"]["poses_file"] = str(args.validate)
        if tmp is not None:
            if held is not None:
                _figure(tmp / "validation.png", *errors, "m" if set(model.pose_names) & {"x", "y", "z"} else "")
            (tmp / "calibration.json").write_text(json.dumps(strict_json(out), indent=2) + "\n")
            (tmp / "calibrated.toml").write_text(mechanism_to_toml(
                result.model.description, f"{model.name} calibrated by pkmlab calibrate from {args.poses}; the "
                f"actuators' zero offsets (add them to the readings): {result.offsets.tolist()}"))
    if not args.json:
        rows = [[r["name"], f"{r['nominal']:.6g}", f"{r['estimate']:.6g}", f"{r['sigma']:.2g}"]
                for r in out["parameters"] if not r["fixed"]]
        print(f"{model.name}: {len(rows)} geometric parameters from {out['poses']} poses (O1 "
              f"{out['observability_O1']:.3g}); RMS residual {out['rms_before']:.3g} -> {out['rms_after']:.3g}")
        print(table(["parameter", "nominal", "calibrated", "sigma"], rows))
        if out["fixed"]:
            print(f"fixed (the poses do not determine them): {', '.join(out['fixed'])}")
        if held is not None:
            check = out["validation"]
            print(f"held-out {args.validate} ({check['poses']} poses): RMS error {check['rms_before']:.3g} -> "
                  f"{check['rms_after']:.3g}, worst point {check['max_point_error_before']:.3g} -> "
                  f"{check['max_point_error_after']:.3g}"
                  + (f" (figure {args.out}/validation.png)" if args.out else ""))
        if args.out:
            print(f"results in {args.out}/")
    return out
