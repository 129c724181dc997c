"""The notebook tour (examples/tour.ipynb) runs in a real Jupyter kernel, and pkmlab's objects show there as
tables: the display is registered by the views layer on ``import pkmlab`` (IPython's HTML formatter), not
by the objects themselves."""

from __future__ import annotations

import os
from pathlib import Path

import pytest

nbformat = pytest.importorskip("nbformat")
nbclient = pytest.importorskip("nbclient")

TOUR = Path(__file__).parents[1] / "examples" / "tour.ipynb"


@pytest.fixture(scope="module")
def executed():
    notebook = nbformat.read(TOUR, as_version=4)
    os.environ.setdefault("MPLBACKEND", "Agg")
    client = nbclient.NotebookClient(notebook, timeout=600, kernel_name="python3",
                                     resources={"metadata": {"path": str(TOUR.parent)}})
    client.execute()
    return notebook


def _outputs(cell) -> dict:
    data = {}
    for output in cell.outputs:
        assert output.output_type != "error", "".join(output.get("traceback", []))
        data.update(output.get("data", {}))
    return data


def test_every_cell_of_the_tour_runs(executed):
    for cell in executed.cells:
        if cell.cell_type == "code":
            _outputs(cell)


@pytest.mark.parametrize(("last_line", "title"), [
    ("model", "paper (3-R*RR)"),
    ("ik", "Inverse kinematics"),
    ("fk", "Forward kinematics: every assembly mode"),
    ("results['fast']", "Run of fast"),
    ("delta", "delta (3-R*US)"),
    ("scenario", "Scenario"),
    ("run", "Run of"),
])
def test_objects_show_as_tables(executed, last_line, title):
    cell = next(c for c in executed.cells if c.cell_type == "code" and c.source.strip().splitlines()[-1] == last_line)
    html = _outputs(cell).get("text/html", "")
    assert "<table" in html and title in html


def test_machines_and_runs_draw_as_plotly_figures(executed):
    for start in ("pkmlab.draw(", "pkmlab.plot(", "pkmlab.show("):
        cell = next(c for c in executed.cells if c.cell_type == "code" and c.source.startswith(start))
        data = _outputs(cell)
        assert "application/vnd.plotly.v1+json" in data or "plotly" in data.get("text/html", "").lower()
