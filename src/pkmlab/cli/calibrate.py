"""``pkmlab calibrate``: a machine's geometry calibrated from its actuator readings at measured poses.

The CSV has one row per measured pose: ``theta1..n`` (the readings) and the measured coordinates by the pose's
names — ``x, y[, z]`` for a laser tracker (``--measure position``, the default) or every pose coordinate
(``--measure pose``). JSON (``--json``): ``{"mechanism", "poses_file", "measure", ...}`` and the calibration's
summary (:meth:`pkmlab.algorithms.calibration.Calibration.summary`); with ``--out`` also ``calibration.json``
and ``calibrated.toml`` (the description with the calibrated geometry; the actuators' offsets are in the JSON:
add them to the readings).
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


def cmd_calibrate(args) -> dict:
    """``calibrate``: read the poses, calibrate, print the table (or the JSON), and with ``--out`` write it."""
    from ..algorithms.calibration import calibrate
    from ..description.files import mechanism_to_toml
    from ..outputs import atomic_output_dir

    model = model_of(args)
    provenance = {"poses_file": str(args.poses), "measure": args.measure}
    folder = (atomic_output_dir(args.out, "calibrate", inputs=[args.poses], provenance=provenance) if args.out else
              contextlib.nullcontext())
    with folder as tmp:
        theta, measured = _read(args.poses, model, args.measure)
        result = calibrate(model, theta, measured, measure=args.measure)
        out = {"mechanism": mechanism_name(args, model), **provenance, **result.summary(),
               "offsets": result.offsets.tolist()}
        if tmp is not None:
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
        if args.out:
            print(f"results in {args.out}/")
    return out
