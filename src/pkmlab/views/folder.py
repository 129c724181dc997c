"""Reading a result folder back into views: ``pkmlab view RESULT_DIR``.

A folder of ``pkmlab simulate`` holds ``run.csv`` and ``plant.toml`` (the machine that ran); one of
``pkmlab reproduce`` holds ``nominal.csv``, ``disturbed.csv``, ``fast.csv`` and each case's
``<case>_plant.toml``. The machine is rebuilt from the recorded actuator values (forward
kinematics at the first sample, nearest the recorded pose; then branch following), exactly as
``pkmlab animate`` does. Every problem — not a result folder, a CSV truncated or edited out of shape,
a machine that does not hold the recorded motion — is one :class:`~pkmlab.errors.PkmlabError` line
naming the file.
"""

from __future__ import annotations

import json
import re
from pathlib import Path

import numpy as np

from ..errors import PkmlabError
from .run import RunView

#: The runs a result folder may hold, in the order they are shown.
CASES = ("run", "nominal", "disturbed", "fast")


def result_cases(folder: Path) -> list[str]:
    """The runs of a result folder (the stems of its CSV files that pkmlab writes); refuses anything else."""
    folder = Path(folder)
    if not folder.exists():
        raise PkmlabError(f"result folder {folder} does not exist")
    if not folder.is_dir():
        raise PkmlabError(f"{folder} is not a folder (expected one written by pkmlab simulate or pkmlab reproduce)")
    cases = [c for c in CASES if (folder / f"{c}.csv").is_file()]
    if not cases:
        raise PkmlabError(f"{folder} is not a result folder: no run.csv (pkmlab simulate) nor nominal.csv, "
                          "disturbed.csv, fast.csv (pkmlab reproduce)")
    return cases


def result_machine(folder: Path, case: str):
    """``(model, source)``: the machine that produced run ``case`` of ``folder`` (what ``pkmlab animate`` and
    ``pkmlab view`` rebuild the run on) — its ``<case>_plant.toml`` (reproduce) or ``plant.toml`` (simulate),
    else the paper's (×1.15 for a reproduced ``disturbed`` case). A plant file of pkmlab 0.2 (a
    ``[manipulator]`` table, the paper's 3-RRR) is read as the same machine."""
    from .._files import read_text
    from ..description.files import load_mechanism
    from ..model.mechanism_model import MechanismModel, load
    from ..simulation.scenario import scaled_model

    for plant in (folder / f"{case}_plant.toml", folder / "plant.toml"):
        if plant.is_file():
            source = f"{folder.name}/{plant.name}"
            if re.search(r"^\[mechanism\]", read_text(plant), re.MULTILINE):
                return MechanismModel.from_description(load_mechanism(plant)), source
            from ..formats.params import load_manipulator

            return MechanismModel.from_description(load_manipulator(plant).to_mechanism()), source
    if case == "disturbed":
        return scaled_model(load("paper"), 1.15, 1.15), "paper preset, masses and lengths x1.15"
    return load("paper"), "paper preset"


def _columns(model) -> tuple[tuple[str, ...], int, tuple[str, ...]]:
    """The CSV columns a view needs, the number of actuators and the pose's names."""
    description = model.description
    n = len(description.actuators)
    names = description.pose_names
    return (("t", *(f"theta{i + 1}" for i in range(n)), *(f"tau{i + 1}" for i in range(n)), *names,
             *(f"{v}_d" for v in names), "S"), n, names)


def read_view(folder: Path, case: str) -> RunView:
    """The view of run ``case`` of result folder ``folder``."""
    from .._files import read_text
    from ..errors import FileFormatError
    from ..formats.params import read_result_csv
    from .animation import rebuild_configurations

    folder = Path(folder)
    model, source = result_machine(folder, case)
    columns, n, names = _columns(model)
    path = folder / f"{case}.csv"
    data = read_result_csv(path, columns)
    t = data["t"]
    if t.size < 2 or np.any(np.diff(t) <= 0):
        k = int(np.argmax(np.diff(t) <= 0)) + 2 if t.size >= 2 else 1
        raise FileFormatError(f"{path}: the times t must increase from row to row (row {k} does not)"
                              if t.size >= 2 else f"{path}: a run needs at least two rows")
    theta = np.column_stack([data[f"theta{i + 1}"] for i in range(n)])
    pose = np.column_stack([data[v] for v in names])
    pose_d = np.column_stack([data[f"{v}_d"] for v in names])
    tau = np.column_stack([data[f"tau{i + 1}"] for i in range(n)])
    try:
        q = rebuild_configurations(model, theta, pose[0], pose)
    except PkmlabError as exc:
        raise PkmlabError(f"{path}: the machine of {source} does not hold this run: {exc}") from None
    summary = {}
    summary_path = folder / "summary.json"
    if summary_path.is_file():
        try:
            data_json = json.loads(read_text(summary_path))
            summary = data_json.get("cases", {}).get(case, data_json) if case != "run" else data_json
            summary = {k: v for k, v in summary.items() if k not in ("provenance", "cases")}
        except (ValueError, AttributeError):
            raise FileFormatError(f"{summary_path}: not JSON written by pkmlab") from None
    scenario = folder / "scenario.toml"
    text = read_text(scenario) if case == "run" and scenario.is_file() else ""
    name = case if case != "run" else str(summary.get("scenario", folder.name))
    return RunView.from_run(name, model, t, q, pose, pose_d, tau, data["S"], names, summary, text)


def read_result_views(folder) -> list[RunView]:
    """Every run of a result folder as a view (:func:`read_view`)."""
    folder = Path(folder)
    return [read_view(folder, case) for case in result_cases(folder)]
