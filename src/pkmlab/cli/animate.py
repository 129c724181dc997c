"""``pkmlab animate``: a GIF of a recorded run, the machine rebuilt from its recorded actuators."""

from __future__ import annotations

import re
import sys
from pathlib import Path

from ..errors import PkmlabError
from ._common import NewFolders, model_of, output_path, params_file, progress_bar


def _animation_model(args, folder: Path, case: str):
    """``(model, source)``: the machine that produced the run — ``--mechanism`` (or the deprecated ``--params``),
    else the folder's own (:func:`~pkmlab.views.folder.result_machine`)."""
    from ..views.folder import result_machine

    if getattr(args, "mechanism", None) or getattr(args, "params", None):
        return model_of(args), args.mechanism or Path(params_file(args)).name
    return result_machine(folder, case)


def _animate(args, machine, folder: Path, csv_path: Path, out: Path) -> dict:
    """A run rebuilt by forward kinematics and branch following from its recorded actuators, drawn as the
    machine is (the paper's 3-RRR and every planar machine of three-joint legs in the paper's style)."""
    import numpy as np

    from ..formats.params import read_result_csv
    from ..model.mechanism_model import tracked_point
    from ..views.animation import rebuild_configurations, write_gif, write_machine_gif, write_spatial_gif
    from ..views.plotting import three_joint_planar

    model, source = machine
    n_act, names = model.n_actuators, model.description.pose_names
    # the tracked point's coordinates the run recorded (a platform of lower mobility records only its controlled
    # ones: its parasitic x or y are drawn where the rebuilt machine puts them)
    position = tuple(c for c in ("x", "y", "z") if c in names)
    columns = ("t", *(f"theta{i + 1}" for i in range(n_act)), *names, *(f"{c}_d" for c in position))
    data = read_result_csv(csv_path, columns)
    theta = np.column_stack([data[f"theta{i + 1}"] for i in range(n_act)])
    pose = np.column_stack([data[v] for v in names])
    q = rebuild_configurations(model, theta, pose[0], pose)
    point = tracked_point(model, q)
    tracked = point[:, [("x", "y", "z").index(c) for c in position]]
    desired = point.copy()
    for k, c in enumerate(("x", "y", "z")[:point.shape[1]]):
        if c in position:
            desired[:, k] = data[f"{c}_d"]
    title = f"{folder.name}/{csv_path.name}, {model.description.name} ({model.description.notation})"
    writer = (write_spatial_gif if point.shape[1] == 3 else write_gif if three_joint_planar(model)
              else write_machine_gif)
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

    recorded = [data[c] for c in ("x", "y", "z") if c in data][:tracked.shape[1]]  # none for a wrist's run
    deviation = float(np.max(np.linalg.norm(tracked - np.column_stack(recorded), axis=1))) if recorded else 0.0
    if deviation > 1e-3:
        print(f"pkmlab animate: warning: the machine rebuilt from the recorded actuators puts the tracked point up "
              f"to {deviation * 1e3:.3g} mm from the CSV's; is the machine ({source}) the one that produced "
              f"this run? ({option})", file=sys.stderr)
    count = tracked.shape[0]
    stride = args.stride or max(1, math.ceil(count / 100))
    frames = range(0, count, stride)
    with progress_bar(args, len(frames), "frames") as bar, NewFolders(out):
        try:
            write(frames, bar)
        except OSError as exc:
            raise PkmlabError(f"cannot write {out}: {exc.strerror or exc}") from None
    if not args.json:
        print(f"wrote {out}: {len(frames)} frames (one every {stride} of {count} samples) at {args.fps} fps "
              f"from {csv_path}, machine: {source}")
    return {"gif": str(out), "csv": str(csv_path), "frames": len(frames), "stride": stride, "fps": args.fps,
            "samples": count, "mechanism": source, "max_centroid_deviation_m": deviation}


def cmd_animate(args) -> dict:
    """A GIF of a recorded run: the machine rebuilt from its recorded actuators, the desired path, the trail."""
    from ..errors import InvalidParameterError

    folder = Path(args.result_dir)
    if not folder.exists():
        raise PkmlabError(f"result folder {folder} does not exist")
    if not folder.is_dir():
        raise PkmlabError(f"{folder} is not a folder (expected one written by pkmlab reproduce or pkmlab simulate)")
    out = output_path(args.out, "--out", {".gif"}, args.force)
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
    return _animate(args, _animation_model(args, folder, case), folder, csv_path, out)
