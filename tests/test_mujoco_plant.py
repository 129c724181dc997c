"""pkmlab's controller against MuJoCo as the plant (pkmlab.mujoco_plant, pkmlab simulate --plant mujoco)."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

from pkmlab import load_scenario, paper_scenario, simulate
from pkmlab.errors import InvalidParameterError

pytest.importorskip("mujoco")
from pkmlab.mujoco_plant import simulate_mujoco  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
#: The default runs of three machines (planar rigid, planar point, spatial with gravity), and how far the
#: MuJoCo plant's path may stray from pkmlab's: MuJoCo's loop closures are soft, by (1 - d)/d at impedance d.
RUNS = {"nominal": lambda: paper_scenario("nominal"),
        "five_bar": lambda: load_scenario(EXAMPLES / "five_bar_circle.toml"),
        "delta": lambda: load_scenario(EXAMPLES / "delta_pick_and_place.toml")}
BOUNDS = {"stiff": (1e-6, 1e-6), "default": (1e-2, 1e-2)}  # path deviation (m), loop-closure violation (m)


@pytest.mark.parametrize("name", sorted(RUNS))
def test_default_runs_on_mujoco_stay_near_pkmlabs_plant(name):
    scenario = RUNS[name]()
    ours = simulate(scenario)
    deviations = {}
    for setting in ("stiff", "default"):
        run = simulate_mujoco(scenario, stiff=setting == "stiff")
        deviation = float(np.linalg.norm(run.pose[:, :3 if name == "delta" else 2]
                                         - ours.pose[:, :3 if name == "delta" else 2], axis=1).max())
        path_bound, closure_bound = BOUNDS[setting]
        assert deviation < path_bound and run.closure_violation.max() < closure_bound
        assert run.summary()["max_closure_violation_m"] == run.closure_violation.max()
        assert np.array_equal(run.t, ours.t) and run.columns[-1] == "closure_violation_m"
        deviations[setting] = deviation
    assert deviations["stiff"] < 1e-2 * deviations["default"]  # the stiffer, the closer to the rigid chain


def test_bad_settings_are_refused():
    scenario = paper_scenario("nominal")
    with pytest.raises(InvalidParameterError, match="must divide the sample time"):
        simulate_mujoco(scenario, timestep=0.0003)
    with pytest.raises(InvalidParameterError, match="integrator must be one of"):
        simulate_mujoco(scenario, integrator="Verlet")
    with pytest.raises(InvalidParameterError, match="sampled-data control"):
        simulate_mujoco(scenario.replace(sample_time=0.0))


def test_simulate_on_mujoco_from_the_command_line(tmp_path, capsys):
    from pkmlab.cli import main

    out = tmp_path / "run"
    assert main(["simulate", str(EXAMPLES / "five_bar_circle.toml"), "--plant", "mujoco", "--mujoco-stiff",
                 "--mujoco-timestep", "0.0005", "--no-figures", "--out", str(out), "--json"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["max_closure_violation_m"] < 1e-6
    assert "MuJoCo, time step 0.0005 s, RK4, stiffest" in summary["provenance"]["plant"]
    assert (out / "run.csv").read_text().splitlines()[0].endswith(",S,closure_violation_m")
    capsys.readouterr()
    bad = tmp_path / "bad"
    assert main(["simulate", str(EXAMPLES / "five_bar_circle.toml"), "--mujoco-stiff", "--out", str(bad)]) == 1
    assert "go with --plant mujoco" in capsys.readouterr().err and not bad.exists()


def test_the_core_never_imports_mujoco_and_says_how_to_install_it(monkeypatch):
    import subprocess
    import sys

    code = ("import sys, pkmlab, pkmlab.simulation, pkmlab.mujoco_export, pkmlab.cli\n"
            "from pkmlab.mechanism_model import MechanismModel\n"
            "pkmlab.mujoco_export.mjcf(MechanismModel.from_preset('five_bar'))\n"
            "assert 'mujoco' not in sys.modules, 'mujoco was imported'\n")
    subprocess.run([sys.executable, "-c", code], check=True)
    from pkmlab.errors import PkmlabError

    monkeypatch.setitem(sys.modules, "mujoco", None)  # as if it were not installed
    with pytest.raises(PkmlabError, match=r"pip install 'pkmlab\[mujoco\]'"):
        simulate_mujoco(paper_scenario("nominal"))


def test_mujocos_own_failure_is_one_line_naming_the_time(monkeypatch):
    """MuJoCo's state turning non-finite (as an unstable integration leaves it) stops the run with one line
    naming the sample interval, instead of NaN results."""
    import mujoco

    step, calls = mujoco.mj_step, {"n": 0}

    def failing(model, data):
        step(model, data)
        calls["n"] += 1
        if calls["n"] == 100:
            data.qvel[0] = np.nan

    monkeypatch.setattr(mujoco, "mj_step", failing)
    from pkmlab.errors import UnstableControlError

    with pytest.raises(UnstableControlError, match=r"MuJoCo's integration failed between t = 0\.0990 and 0\.1000 s"):
        simulate_mujoco(paper_scenario("nominal"))
