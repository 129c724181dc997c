"""Scenario files (``pkmlab.formats.scenario``) and ``pkmlab simulate``.

The paper's cases are checked against conventions §7 written out here; every bad input must give
exit code 1, one line naming the file and the key, and write nothing; Ctrl-C must leave
nothing half-written; a fuzzer feeds the loader random documents and bytes.
"""

from __future__ import annotations

import doctest
import json
import math
import os
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import pkmlab
import pkmlab.formats.params
import pkmlab.formats.scenario
import pkmlab.simulation.run
from pkmlab.cli import main
from pkmlab.control.controller import ControllerSpec
from pkmlab.control.trajectory import Circle, Trajectory
from pkmlab.errors import PkmlabDeprecationWarning, PkmlabError
from pkmlab.formats.params import load_manipulator
from pkmlab.formats.scenario import load_scenario, paper_scenario, scenario_from_dict
from pkmlab.paper.geometry import Planar3RRR
from pkmlab.simulation.result import COLUMNS
from pkmlab.simulation.run import simulate
from pkmlab.simulation.scenario import Scenario

ROOT = Path(__file__).resolve().parents[1]
EXAMPLES = ROOT / "examples"
PACKAGE_SCENARIOS = ROOT / "src" / "pkmlab" / "scenarios"
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
SUMMARY_KEYS = {"max_path_error_m", "rms_path_error_m", "max_alpha_error_rad", "max_joint_error_rad",
                "peak_torque_Nm", "min_abs_S", "working_mode",
                # the names every mechanism's summary has (the paper's machine reports both)
                "max_orientation_error_rad", "max_joint_error", "peak_effort"}

# conventions §1 (the paper's manipulator) and §7 (the cases), written out independently of pkmlab.
PAPER = {"b": 0.52, "l": 0.25, "r": 0.1667, "a": 0.125, "mass_l": 0.468, "mass_r": 0.312, "mass_a": 0.234,
         "inertia_l": 2.438e-3, "inertia_r": 0.722e-3, "inertia_a": 0.305e-3}
PAPER_BASE = np.array([(0.0, 0.0), (0.52, 0.0), (0.26, math.sqrt(3) / 2 * 0.52)])

VALID = """\
[trajectory]
type = "circle"
center = [0.25, 0.21]
radius = 0.05
speed = 0.2
"""


def run(capsys, *args):
    code = main([str(a) for a in args])
    out, err = capsys.readouterr()
    return code, out, err


def leftovers(folder: Path) -> list[str]:
    """Hidden entries (temporary folders) left in ``folder``."""
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.fixture(scope="module")
def fast_result():
    return simulate(paper_scenario("fast"))


# ------------------------------------------------------------------ the paper's cases as files
def paper_numbers(model) -> dict:
    """The paper's parameters (conventions §1) of a model of a 3-RRR, read from its description: base pivots,
    link lengths (each body's tip), platform side (between its attachments), masses and inertias."""
    d = model.description
    att = np.array(d.platform.attachments)
    return {"base_points": np.array([leg.base for leg in d.legs]),
            "l": np.array([math.hypot(*leg.bodies[0].tip) for leg in d.legs]),
            "r": np.array([math.hypot(*leg.bodies[1].tip) for leg in d.legs]),
            "a": float(np.linalg.norm(att[1] - att[0])),
            "mass_l": np.array([leg.bodies[0].mass for leg in d.legs]),
            "mass_r": np.array([leg.bodies[1].mass for leg in d.legs]), "mass_a": d.platform.mass,
            "inertia_l": np.array([leg.bodies[0].inertia for leg in d.legs]),
            "inertia_r": np.array([leg.bodies[1].inertia for leg in d.legs]), "inertia_a": d.platform.inertia}


def _assert_plant(plant, mass: float, length: float):
    """The plant of conventions §7: masses × mass, lengths l, r, a × length, inertias × mass·length², base unchanged."""
    n = paper_numbers(plant)
    np.testing.assert_allclose(n["base_points"], PAPER_BASE, rtol=1e-15, atol=1e-15)
    inertia = mass * length**2
    for key, scale in (("l", length), ("r", length), ("a", length), ("mass_l", mass), ("mass_r", mass),
                       ("mass_a", mass), ("inertia_l", inertia), ("inertia_r", inertia), ("inertia_a", inertia)):
        np.testing.assert_allclose(n[key], np.broadcast_to(PAPER[key] * scale, np.shape(n[key])), rtol=1e-13,
                                   err_msg=key)


@pytest.mark.parametrize("name, speed, scales", [("nominal", 0.2, None), ("disturbed", 0.2, (1.15, 1.15)),
                                                 ("fast", 0.4, None)])
def test_paper_scenario_files_follow_spec_section_7(name, speed, scales):
    scenario = paper_scenario(name)
    model = paper_numbers(scenario.model)
    np.testing.assert_allclose(model["base_points"], PAPER_BASE, rtol=1e-15, atol=1e-15)
    np.testing.assert_array_equal(model["l"], [PAPER["l"]] * 3)
    np.testing.assert_array_equal(model["r"], [PAPER["r"]] * 3)
    assert model["a"] == pytest.approx(PAPER["a"], rel=1e-15)
    circle = Circle((0.25, 0.21), 0.05, start_angle=math.pi, alpha=0.0)
    assert scenario.trajectory == Trajectory(circle, speed, "cubic")
    assert scenario.trajectory.duration == pytest.approx(2 * math.pi * 0.05 / speed, rel=1e-15)
    assert scenario.controller == ControllerSpec("computed_torque", kp=1000.0)
    assert scenario.controller.velocity_gain == pytest.approx(2 * math.sqrt(1000.0), rel=1e-15)
    assert scenario.sample_time == 1e-3
    assert scenario.working_mode == "auto"
    assert scenario.name == name
    if scales is None:
        assert scenario.plant is None
    else:
        _assert_plant(scenario.plant, *scales)
    # the file in examples/ is a copy of the packaged one (a file of its own: it works wherever it is copied)
    example = EXAMPLES / f"{name}.toml"
    assert not example.is_symlink()
    assert example.read_bytes() == (PACKAGE_SCENARIOS / f"{name}.toml").read_bytes()
    assert load_scenario(example).replace(name=name) == scenario


def test_every_example_file_works_when_its_folder_is_copied_anywhere(tmp_path):
    """Copied as a user copies a folder (links kept as links), every scenario, study and description file of
    examples/ still loads: none reaches outside its folder."""
    copy = tmp_path / "elsewhere" / "examples"
    shutil.copytree(EXAMPLES, copy, symlinks=True)
    files = sorted([*copy.glob("*.toml"), *copy.glob("identification/*.toml")])
    assert len(files) >= 10
    for path in files:
        data = tomllib.loads(path.read_text())
        if "trajectory" in data:
            load_scenario(path)
        elif "study" in data:
            pkmlab.load_study(path)
        else:
            pkmlab.load(path)


def test_disturbed_dynamics_variant_is_unchanged():
    scenario = paper_scenario("disturbed_dynamics")
    _assert_plant(scenario.plant, 1.15, 1.0)
    assert scenario.trajectory.speed == 0.2


def test_scenario_files_are_package_data():
    text = (ROOT / "pyproject.toml").read_text()
    data = tomllib.loads(text)
    assert "scenarios/*.toml" in data["tool"]["setuptools"]["package-data"]["pkmlab"]
    from importlib.resources import files

    for name in ("nominal", "disturbed", "fast"):
        assert (files("pkmlab") / "scenarios" / f"{name}.toml").is_file()


def test_every_option_of_the_format_is_read(tmp_path):
    path = tmp_path / "mine.toml"
    path.write_text("""
[manipulator]
preset = "paper"
[manipulator.params]
l = [0.25, 0.24, 0.26]
a = 0.12
[plant]
mass_scale = 1.1
[trajectory]
type = "waypoints"
points = [[0.2, 0.2, 0.0], [0.25, 0.2, 0.1], [0.25, 0.25, 0.0]]
speed = 0.1
time_law = "quintic"
[controller]
type = "pd"
kp = 30.0
kv = 1.5
sample_time = 0.002
[simulation]
working_mode = [-1, 1, -1]
singularity_margin = 0.02
singularity_guard = 0.005
substeps = 3
""")
    with pytest.warns(PkmlabDeprecationWarning, match=r"\[manipulator\] is deprecated"):
        s = load_scenario(path)
    assert s.name == "mine"
    np.testing.assert_array_equal(paper_numbers(s.model)["l"], [0.25, 0.24, 0.26])
    assert paper_numbers(s.model)["a"] == pytest.approx(0.12, rel=1e-15)
    np.testing.assert_allclose(paper_numbers(s.plant)["mass_l"], np.full(3, PAPER["mass_l"] * 1.1), rtol=1e-14)
    np.testing.assert_array_equal(paper_numbers(s.plant)["l"], paper_numbers(s.model)["l"])  # length_scale: 1
    np.testing.assert_array_equal(s.trajectory.points, [[0.2, 0.2, 0.0], [0.25, 0.2, 0.1], [0.25, 0.25, 0.0]])
    assert s.trajectory.law == "quintic" and s.trajectory.speed == 0.1
    assert s.controller == ControllerSpec("pd", kp=30.0, kv=1.5)
    assert s.sample_time == 0.002  # (substeps apply to sampled-data control only: not with sample_time = 0)
    assert (s.working_mode, s.singularity_margin, s.singularity_guard, s.substeps) == ((-1, 1, -1), 0.02, 0.005, 3)
    line = scenario_from_dict({"trajectory": {"type": "line", "start": [0.2, 0.2, 0], "end": [0.23, 0.24, 0.1],
                                              "speed": 0.05}}, "l.toml")
    assert line.trajectory.duration == pytest.approx(math.hypot(0.03, 0.04) / 0.05, rel=1e-14)
    assert line.name == "l" and line.plant is None and line.model == pkmlab.load("paper")


@pytest.mark.parametrize("module", [pkmlab.formats.scenario, pkmlab.formats.params])
def test_docstring_examples(module):
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0 and result.failed == 0


# ------------------------------------------------------------------ every bad input
CIRCLE = 'type = "circle"\ncenter = [0.25, 0.21]\nradius = 0.05\nspeed = 0.2\n'

BAD_INPUTS = {
    # unknown tables and keys, with the closest valid one suggested
    "unknown table": ("[trajectorie]\n" + CIRCLE, ["unknown table 'trajectorie'", "did you mean 'trajectory'?"]),
    "unknown key": (VALID.replace("radius", "radus"), ["unknown key 'radus' in [trajectory]",
                                                        "did you mean 'radius'?"]),
    "unknown controller key": (VALID + "[controller]\nkpp = 10.0\n", ["[controller]", "did you mean 'kp'?"]),
    "unknown parameter": (VALID + "[manipulator.params]\nmass_ll = 1.0\n", ["[manipulator.params]",
                                                                          "did you mean 'mass_l'?"]),
    "key of another table": ("speed = 0.2\n" + VALID, ["unknown key 'speed'", "[trajectory].speed"]),
    "key of another path": ('[trajectory]\ntype = "line"\nstart = [0.2, 0.2, 0]\nend = [0.3, 0.2, 0]\n'
                            "speed = 0.1\nradius = 0.05\n", ["[trajectory].radius", "line trajectory"]),
    "unknown trajectory type": (VALID.replace('"circle"', '"circel"'), ["[trajectory].type", "'circle'"]),
    "unknown time law": (VALID + 'time_law = "quintik"\n', ["[trajectory].time_law", "'quintic'"]),
    "unknown controller": (VALID + '[controller]\ntype = "computed-torque"\n', ["[controller].type",
                                                                               "'computed_torque'"]),
    "unknown preset": (VALID + '[manipulator]\npreset = "papr"\n', ["[manipulator].preset", "'paper'"]),
    # wrong types
    "bool as number": (VALID.replace("0.05", "true"), ["[trajectory].radius must be a positive number, got true"]),
    "string as number": (VALID.replace("0.2\n", '"fast"\n'), ['[trajectory].speed', 'got "fast"']),
    "string in a vector": (VALID.replace("[0.25, 0.21]", '[0.25, "y"]'), ["[trajectory].center[1]",
                                                                          'got "y"']),
    "short vector": (VALID.replace("[0.25, 0.21]", "[0.25]"), ["[trajectory].center must be 2 numbers"]),
    "table as number": (VALID + "[controller]\nkp = {value = 1}\n", ["[controller].kp", "{value = 1}"]),
    "number as table": ("trajectory = 3\n", ["[trajectory] must be a table, got 3"]),
    "string as type": (VALID.replace('"circle"', "3"), ["[trajectory].type", "got 3"]),
    "bad working mode": (VALID + "[simulation]\nworking_mode = [1, 2, 1]\n", ["[simulation].working_mode",
                                                                               "[1, 2, 1]"]),
    "fractional substeps": (VALID + "[simulation]\nsubsteps = 2.5\n", ["[simulation].substeps", "2.5"]),
    "list of the wrong length": (VALID + "[manipulator.params]\nl = [0.25, 0.25]\n",
                                 ["[manipulator.params].l", "one per leg"]),
    # not finite, not positive
    "negative radius": (VALID.replace("0.05", "-0.05"),
                        ["scenario.toml: [trajectory].radius must be a positive number, got -0.05"]),
    "nan speed": (VALID.replace("0.2\n", "nan\n"), ["[trajectory].speed must be a finite positive number, got nan"]),
    "infinite centre": (VALID.replace("[0.25, 0.21]", "[inf, 0.21]"), ["[trajectory].center[0]", "inf"]),
    "overflowing radius": (VALID.replace("0.05", "1e400"), ["[trajectory].radius", "finite", "inf"]),
    "huge integer": (VALID.replace("0.05", "1" + "0" * 400), ["[trajectory].radius", "finite"]),
    "zero speed": (VALID.replace("0.2\n", "0\n"), ["[trajectory].speed must be a positive number, got 0"]),
    "zero kp": (VALID + "[controller]\nkp = 0\n", ["[controller].kp must be a positive number, got 0"]),
    "negative kv": (VALID + "[controller]\nkv = -1.0\n", ["[controller].kv must be a non-negative number"]),
    "negative sample time": (VALID + "[controller]\nsample_time = -0.001\n", ["[controller].sample_time",
                                                                              "-0.001"]),
    "negative plant scale": (VALID + "[plant]\nmass_scale = -1.15\n", ["[plant].mass_scale", "-1.15"]),
    "infinite plant scale": (VALID + "[plant]\nlength_scale = inf\n", ["[plant].length_scale", "finite"]),
    "nan link": (VALID + "[manipulator.params]\nl = nan\n", ["[manipulator.params].l", "finite", "nan"]),
    "negative link": (VALID + "[manipulator.params]\nl = [0.25, -0.25, 0.25]\n",
                      ["[manipulator.params].l[1]", "-0.25"]),
    "zero platform": (VALID + "[manipulator.params]\na = 0\n", ["[manipulator.params].a", "got 0"]),
    "impossible machine": (VALID + "[manipulator.params]\nl = 0.1\nr = 0.05\n",
                           ["[manipulator.params]", "cannot be assembled"]),
    "b and base points": (VALID + "[manipulator.params]\nb = 0.5\nbase_points = [[0, 0], [1, 0], [0, 1]]\n",
                          ["[manipulator.params]", "b", "base_points"]),
    "repeated line end": ('[trajectory]\ntype = "line"\nstart = [0.2, 0.2, 0]\nend = [0.2, 0.2, 0]\nspeed = 0.1\n',
                          ["[trajectory].end must differ from start"]),
    "repeated waypoint": ('[trajectory]\ntype = "waypoints"\npoints = [[0.2, 0.2, 0], [0.2, 0.2, 0]]\n'
                          "speed = 0.1\n", ["[trajectory].points[1]"]),
    "endless run": (VALID.replace("0.2\n", "1e-300\n"), ["samples", "[trajectory].speed"]),
    "instant run": (VALID.replace("0.2\n", "1e300\n"), ["less than one sample", "[trajectory].speed"]),
    "vanishing path": (VALID.replace("0.05", "1e-300"), ["less than one sample"]),
    # missing required keys
    "no trajectory": ("[controller]\nkp = 100.0\n", ["[trajectory] table is required"]),
    "no type": (VALID.replace('type = "circle"\n', ""), ["[trajectory].type is required"]),
    "no center": (VALID.replace("center = [0.25, 0.21]\n", ""), ["[trajectory].center is required"]),
    "no radius": (VALID.replace("radius = 0.05\n", ""), ["[trajectory].radius is required"]),
    "no speed": (VALID.replace("speed = 0.2\n", ""), ["[trajectory].speed is required"]),
    "no line end": ('[trajectory]\ntype = "line"\nstart = [0.2, 0.2, 0]\nspeed = 0.1\n',
                    ["[trajectory].end is required"]),
    "no waypoints": ('[trajectory]\ntype = "waypoints"\nspeed = 0.1\n', ["[trajectory].points is required"]),
    # malformed TOML, with its line
    "malformed TOML": (VALID.replace("radius = 0.05", "radius = 0.05 0.06"), ["malformed TOML", "line 4"]),
    "unclosed string": ('[trajectory]\n\ntype = "circle\n', ["malformed TOML", "line 3"]),
    "duplicate key": (VALID + "radius = 0.06\n", ["malformed TOML", "line 6"]),
}


@pytest.mark.parametrize("case", list(BAD_INPUTS))
def test_bad_scenario_is_refused_with_one_line_and_writes_nothing(tmp_path, capsys, case):
    text, expected = BAD_INPUTS[case]
    path = tmp_path / "scenario.toml"
    path.write_text(text)
    out = tmp_path / "results"
    code, stdout, stderr = run(capsys, "simulate", path, "--out", out)
    assert code == 1
    assert stdout == ""
    lines = stderr.splitlines()
    assert len(lines) == 1, stderr
    assert lines[0].startswith(f"pkmlab simulate: error: {path}: ")
    for fragment in expected:
        assert fragment in lines[0], (fragment, lines[0])
    assert not out.exists()
    assert leftovers(tmp_path) == []
    # the library raises the same message as a PkmlabError
    with pytest.raises(PkmlabError) as info:
        load_scenario(path)
    assert str(info.value) == lines[0].removeprefix("pkmlab simulate: error: ")


def test_bad_scenario_with_json_reports_the_error_on_stdout(tmp_path, capsys):
    path = tmp_path / "s.toml"
    path.write_text(VALID.replace("0.05", "-0.05"))
    code, stdout, stderr = run(capsys, "simulate", path, "--out", tmp_path / "o", "--json")
    assert code == 1 and stderr == ""
    error = json.loads(stdout)["error"]
    assert error["type"] == "InvalidParameterError"
    assert error["message"] == f"{path}: [trajectory].radius must be a positive number, got -0.05"
    assert not (tmp_path / "o").exists()


@pytest.mark.parametrize("what", ["missing", "directory", "binary"])
def test_unreadable_scenario_file(tmp_path, capsys, what):
    path = tmp_path / "scenario.toml"
    if what == "directory":
        path.mkdir()
    elif what == "binary":
        path.write_bytes(b"\xff\xfe\x00[trajectory]")
    code, _stdout, stderr = run(capsys, "simulate", path, "--out", tmp_path / "o")
    assert code == 1
    assert len(stderr.splitlines()) == 1 and "cannot read" in stderr and str(path) in stderr
    assert not (tmp_path / "o").exists()


def test_malformed_command_line_exits_2(tmp_path, capsys):
    with pytest.raises(SystemExit) as info:
        main(["simulate", str(EXAMPLES / "fast.toml")])  # --out is required
    assert info.value.code == 2
    assert "--out" in capsys.readouterr().err


# ------------------------------------------------------------------ output folders
def _no_simulation(monkeypatch):
    def refuse(_scenario):
        raise AssertionError("simulated although the output folder cannot be written")

    monkeypatch.setattr(pkmlab.simulation.run, "simulate", refuse)


def test_output_folder_under_a_file_is_refused_before_simulating(tmp_path, capsys, monkeypatch):
    _no_simulation(monkeypatch)
    blocker = tmp_path / "file"
    blocker.write_text("keep")
    code, _out, err = run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", blocker / "results")
    assert code == 1
    assert len(err.splitlines()) == 1 and "cannot write results to" in err
    assert blocker.read_text() == "keep"
    assert sorted(p.name for p in tmp_path.iterdir()) == ["file"]


def test_output_folder_that_is_a_file_is_refused(tmp_path, capsys, monkeypatch):
    _no_simulation(monkeypatch)
    target = tmp_path / "results"
    target.write_text("keep")
    code, _out, err = run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", target)
    assert code == 1 and "not a folder" in err and len(err.splitlines()) == 1
    assert target.read_text() == "keep"
    assert leftovers(tmp_path) == []


def test_output_folder_with_an_impossible_name_is_refused(tmp_path, capsys, monkeypatch):
    _no_simulation(monkeypatch)
    code, _out, err = run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", tmp_path / ("x" * 300) / "results")
    assert code == 1 and "cannot write results to" in err and len(err.splitlines()) == 1
    assert list(tmp_path.iterdir()) == []


def test_a_folder_of_other_files_is_never_replaced(tmp_path, capsys, monkeypatch):
    _no_simulation(monkeypatch)
    precious = tmp_path / "thesis"
    precious.mkdir()
    (precious / "chapter1.tex").write_text("keep")
    code, _out, err = run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", precious)
    assert code == 1 and "choose a new or empty folder" in err and len(err.splitlines()) == 1
    assert [p.name for p in precious.iterdir()] == ["chapter1.tex"]
    assert leftovers(tmp_path) == []


@pytest.mark.parametrize("target", [".", ".."])
def test_the_current_folder_is_never_replaced(tmp_path, capsys, monkeypatch, target):
    _no_simulation(monkeypatch)
    monkeypatch.chdir(tmp_path)
    code, _out, err = run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", target)
    assert code == 1 and "name a folder" in err
    assert list(tmp_path.iterdir()) == []


@pytest.mark.skipif(os.name != "posix" or os.geteuid() == 0, reason="root may write into read-only folders")
def test_output_folder_in_a_read_only_folder_is_refused(tmp_path, capsys, monkeypatch):
    _no_simulation(monkeypatch)
    locked = tmp_path / "locked"
    locked.mkdir()
    locked.chmod(0o555)
    try:
        code, _out, err = run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", locked / "results")
    finally:
        locked.chmod(0o755)
    assert code == 1 and "cannot write results to" in err and len(err.splitlines()) == 1
    assert list(locked.iterdir()) == []


# ------------------------------------------------------------------ Ctrl-C
def test_interrupt_during_the_simulation_leaves_nothing(tmp_path, capsys, monkeypatch):
    def interrupted(_scenario):
        raise KeyboardInterrupt

    monkeypatch.setattr(pkmlab.simulation.run, "simulate", interrupted)
    out = tmp_path / "new" / "deeper" / "results"
    code, stdout, err = run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", out)
    assert code == 130
    assert "interrupted" in err and stdout == ""
    assert list(tmp_path.iterdir()) == []  # neither the results, nor a temporary folder, nor the parents


def test_interrupt_while_writing_keeps_the_previous_results(tmp_path, capsys, monkeypatch, fast_result):
    out = tmp_path / "results"
    monkeypatch.setattr(pkmlab.simulation.run, "simulate", lambda _scenario: fast_result)
    assert run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", out, "--no-figures")[0] == 0  # an earlier run
    before = {p.name: p.read_bytes() for p in out.iterdir()}

    def interrupted(self, path):
        Path(path).write_text("half")  # something was already written in the temporary folder
        raise KeyboardInterrupt

    monkeypatch.setattr(pkmlab.simulation.result.SimulationResult, "to_csv", interrupted)
    code, _stdout, err = run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", out, "--no-figures")
    assert code == 130 and "interrupted" in err
    assert {p.name: p.read_bytes() for p in out.iterdir()} == before
    assert leftovers(tmp_path) == []


# ------------------------------------------------------------------ happy paths
def test_simulate_fast_example_gives_the_library_summary(tmp_path, capsys, fast_result):
    out = tmp_path / "fast"
    code, stdout, err = run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", out, "--no-figures", "--quiet")
    assert code == 0 and err == ""
    assert f"results in {out}/" in stdout
    summary = json.loads((out / "summary.json").read_text())
    assert summary.pop("scenario") == "fast"
    provenance = summary.pop("provenance")
    assert provenance["control"] == "sampled" and provenance["sample_time_s"] == 1e-3
    assert provenance["scenario"] == str(EXAMPLES / "fast.toml") and provenance["pkmlab_version"] == pkmlab.__version__
    units = summary.pop("units")  # every figure's unit: the 3-RRR's actuators are revolute
    assert set(units) == SUMMARY_KEYS and units["peak_effort"] == units["peak_torque_Nm"] == "N*m"
    assert units["max_joint_error"] == "rad" and units["max_path_error_m"] == "m" and units["min_abs_S"] == ""
    assert summary == json.loads(json.dumps(fast_result.summary()))
    assert set(summary) == SUMMARY_KEYS
    rows = (out / "run.csv").read_text().splitlines()
    assert rows[0] == ",".join(COLUMNS)
    table = np.array([row.split(",") for row in rows[1:]], dtype=float)
    np.testing.assert_array_equal(table, fast_result.table())
    # conventions §8: one row per 1 ms sample from t = 0 to the end of the motion, T = L / v (conventions §4)
    duration = 2 * math.pi * 0.05 / 0.4
    np.testing.assert_allclose(table[:, 0], np.arange(len(table)) * 1e-3, rtol=0, atol=1e-12)
    assert abs(table[-1, 0] - duration) < 1e-3
    assert pkmlab.load(out / "plant.toml") == pkmlab.load("paper")
    assert sorted(p.name for p in out.iterdir()) == ["REPORT.md", "pkmlab-manifest.json", "plant.toml", "run.csv",
                                                     "scenario.toml", "summary.json"]
    assert (out / "scenario.toml").read_bytes() == (EXAMPLES / "fast.toml").read_bytes()
    report = (out / "REPORT.md").read_text()
    assert "sampled-data, Ts = 1 ms" in report
    assert "scenario `fast`" in report and "| (-1, 1, -1) |" in report and ".png" not in report
    assert leftovers(tmp_path) == []


def test_simulate_disturbed_with_figures_and_json(tmp_path, capsys):
    out = tmp_path / "disturbed"
    out.mkdir()  # an empty folder may be used
    code, stdout, err = run(capsys, "simulate", EXAMPLES / "disturbed.toml", "--out", out, "--json")
    assert code == 0 and err == ""
    printed = json.loads(stdout)
    assert printed == json.loads((out / "summary.json").read_text())
    assert printed["scenario"] == "disturbed" and set(printed) == SUMMARY_KEYS | {"scenario", "units", "provenance"}
    figures = ["path.png", "path_error.png", "alpha.png", "torques.png", "singularity_along_path.png"]
    report = (out / "REPORT.md").read_text()
    for name in figures:
        assert (out / name).read_bytes().startswith(PNG_SIGNATURE)
        assert f"]({name})" in report
    # and the interactive page beside them, Plotly embedded, linked from the report
    assert "](REPORT.html)" in report and (out / "REPORT.html").stat().st_size > 4_000_000
    # plant.toml holds the real machine and reads back as exactly the same model
    plant = pkmlab.load(out / "plant.toml")
    assert plant == paper_scenario("disturbed").plant
    _assert_plant(plant, 1.15, 1.15)
    assert (out / "plant.toml").stat().st_mode & 0o777 == 0o644
    assert leftovers(tmp_path) == []


def test_plant_file_round_trips_a_non_equilateral_base(tmp_path):
    model = Planar3RRR.from_params(base_points=[(0.0, 0.0), (0.5, 0.02), (0.27, 0.44)], l=[0.25, 0.24, 0.26],
                                   mass_a=0.3, inertia_r=[1e-3, 2e-3, 3e-3])
    path = tmp_path / "plant.toml"
    path.write_text(pkmlab.formats.params.manipulator_to_toml(model, "a comment\nover two lines"))
    assert load_manipulator(path) == model


# ------------------------------------------------------------------ fuzzing the loader
def toml_string(text: str) -> str:
    out = []
    for ch in text:
        if ch in '"\\' or ord(ch) < 0x20 or ord(ch) == 0x7F:
            out.append(f"\\u{ord(ch):04x}")
        else:
            out.append(ch)
    return '"' + "".join(out) + '"'


def toml_value(value) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return toml_string(value)
    if isinstance(value, list):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        return "{" + ", ".join(f"{toml_string(k)} = {toml_value(v)}" for k, v in value.items()) + "}"
    raise TypeError(value)


def toml_document(doc: dict) -> str:
    """A tiny TOML writer: top-level values first, then one ``[table]`` per dict (nested ones inline)."""
    lines = [f"{toml_string(k)} = {toml_value(v)}" for k, v in doc.items() if not isinstance(v, dict)]
    for name, table in doc.items():
        if isinstance(table, dict):
            lines.append(f"[{toml_string(name)}]")
            lines += [f"{toml_string(k)} = {toml_value(v)}" for k, v in table.items()]
    return "\n".join(lines) + "\n"


KNOWN_TABLES = list(pkmlab.formats.scenario.TABLES)
KNOWN_KEYS = sorted({k for keys in pkmlab.formats.scenario.TABLES.values() for k in keys}
                    | set(pkmlab.formats.params.PARAM_KEYS))
WORDS = ["circle", "line", "waypoints", "cubic", "quintic", "computed_torque", "pd", "auto", "paper"]
scalars = st.one_of(
    st.floats(allow_nan=True, allow_infinity=True),
    st.floats(min_value=-1.0, max_value=1.0),
    st.sampled_from([0.05, 0.2, 0.25, 0.21, 1000.0, 1e-3, 0.0, -0.05, 1.15]),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.sampled_from([1, -1, 0, 2, 3]),
    st.booleans(),
    st.sampled_from(WORDS),
    st.text(max_size=6),
)
values = st.recursive(scalars, lambda inner: st.one_of(st.lists(inner, max_size=4),
                                                       st.dictionaries(st.sampled_from(KNOWN_KEYS), inner,
                                                                       max_size=3)),
                      max_leaves=10)
keys = st.one_of(st.sampled_from(KNOWN_KEYS), st.text(max_size=6))


@pytest.fixture(scope="module")
def fuzz_dir(tmp_path_factory):
    return tmp_path_factory.mktemp("fuzz")


def _load_or_refuse(path: Path):
    """Loading must either give a Scenario or raise a PkmlabError with a one-line message."""
    try:
        scenario = load_scenario(path)
    except PkmlabError as exc:
        message = str(exc)
        assert message and "\n" not in message and "\r" not in message
        return None
    assert isinstance(scenario, Scenario)
    return scenario


numbers = st.one_of(st.floats(min_value=-0.5, max_value=0.5), st.floats(min_value=0.01, max_value=0.4),
                    st.sampled_from([0.0, 1.0, -1.0, 1e-3, 1000.0, 1.15, float("nan"), float("inf")]))
plausible = st.one_of(
    numbers,
    st.lists(numbers, min_size=2, max_size=3),
    st.lists(st.lists(numbers, min_size=3, max_size=3), min_size=1, max_size=4),
    st.lists(st.sampled_from([1, -1, 0, 2]), min_size=3, max_size=3),
    st.sampled_from(WORDS),
    values,
)


@settings(max_examples=200, deadline=None, suppress_health_check=[HealthCheck.too_slow])
@given(data=st.data())
def test_fuzz_loader_with_edited_documents(fuzz_dir, data):
    """Random edits of a valid scenario: values of every type, mostly under the keys the format knows."""
    doc = tomllib.loads((PACKAGE_SCENARIOS / "disturbed.toml").read_text())
    for _ in range(data.draw(st.integers(1, 3), label="edits")):
        table = data.draw(st.sampled_from([*KNOWN_TABLES * 8, "manipulator.params", "manipulator.params", None]),
                          label="table")
        if table is None:
            table = data.draw(st.text(max_size=6), label="other table")
        action = data.draw(st.sampled_from(["set"] * 8 + ["delete", "replace table"]), label="action")
        if action == "replace table":
            doc[table] = data.draw(values, label="table value")
            continue
        if table == "manipulator.params":
            target = doc.setdefault("manipulator", {})
            target = target.setdefault("params", {}) if isinstance(target, dict) else None
            valid = list(pkmlab.formats.params.PARAM_KEYS)
        else:
            target = doc.setdefault(table, {})
            valid = list(pkmlab.formats.scenario.TABLES.get(table, ())) or KNOWN_KEYS
        if not isinstance(target, dict):
            continue
        key = data.draw(st.sampled_from([*valid * 6, None]), label="key")
        if key is None:
            key = data.draw(keys, label="other key")
        if action == "delete":
            target.pop(key, None)
        else:
            target[key] = data.draw(plausible, label="value")
    text = toml_document(doc)
    tomllib.loads(text)  # the writer above makes valid TOML: the loader sees the document, not a syntax error
    path = fuzz_dir / "edited.toml"
    path.write_text(text, encoding="utf-8")
    _load_or_refuse(path)


@pytest.mark.filterwarnings("ignore::pkmlab.errors.PkmlabDeprecationWarning")  # random [manipulator] tables
@settings(max_examples=100, deadline=None)
@given(doc=st.dictionaries(st.one_of(st.sampled_from(KNOWN_TABLES), st.text(max_size=6)),
                           st.one_of(st.dictionaries(keys, values, max_size=6), values), max_size=5))
def test_fuzz_loader_with_random_documents(fuzz_dir, doc):
    text = toml_document(doc)
    tomllib.loads(text)
    path = fuzz_dir / "random.toml"
    path.write_text(text, encoding="utf-8")
    _load_or_refuse(path)


@settings(max_examples=100, deadline=None)
@given(blob=st.one_of(st.binary(max_size=300),
                      st.builds(lambda head, cut, junk: head[:cut] + junk + head[cut:],
                                st.just((PACKAGE_SCENARIOS / "fast.toml").read_bytes()),
                                st.integers(0, 1200), st.binary(max_size=8))))
def test_fuzz_loader_with_random_bytes(fuzz_dir, blob):
    path = fuzz_dir / "bytes.toml"
    path.write_bytes(blob)
    _load_or_refuse(path)


def test_documented_scenario_example_loads():
    """The example of the scenario files' page (``pkmlab help scenario-files``; docs/reference/scenario-files.md
    includes it) is a valid scenario, read as it says."""
    page = (ROOT / "src" / "pkmlab" / "help" / "scenario-files.md").read_text()
    assert (ROOT / "docs" / "reference" / "scenario-files.md").read_text() == \
        '--8<-- "src/pkmlab/help/scenario-files.md"\n'
    section = page[page.index("# Scenario files and `pkmlab simulate`"):]
    block = section[section.index("```toml\n") + len("```toml\n"):]
    block = block[: block.index("```")]
    s = scenario_from_dict(tomllib.loads(block), "my_run.toml")
    assert s.name == "my_run" and s.trajectory.original.speed == 0.2 and s.controller.kp == 1000.0
    assert isinstance(s.trajectory, pkmlab.TimeOptimal) and s.trajectory.duration < s.trajectory.original.duration
    assert s.model == pkmlab.load("paper")
    _assert_plant(s.plant, 1.15, 1.15)


# ------------------------------------------------------------------ the deprecated [manipulator] table
def test_a_manipulator_table_is_read_with_a_note_giving_the_mechanism_text(tmp_path, capsys):
    """A pkmlab 0.2 scenario ([manipulator] with parameters) runs the same machine as the [mechanism] text its
    deprecation note gives, and the command line says the note once the run has succeeded."""
    old = tmp_path / "old.toml"
    old.write_text('[manipulator]\npreset = "paper"\n[manipulator.params]\nl = [0.25, 0.24, 0.26]\n' + VALID
                   + '[controller]\nsample_time = 0.005\n')
    with pytest.warns(PkmlabDeprecationWarning) as caught:
        scenario = load_scenario(old)
    (warning,) = caught
    message = str(warning.message)
    assert message.startswith(f"{old}: [manipulator] is deprecated")
    text = message[message.index("\n[mechanism]") + 1:]  # the equivalent description, as a scenario's table
    new = tmp_path / "new.toml"
    new.write_text(text + "\n" + VALID + '[controller]\nsample_time = 0.005\n')
    assert load_scenario(new).model == scenario.model
    np.testing.assert_array_equal(paper_numbers(scenario.model)["l"], [0.25, 0.24, 0.26])
    code, out, err = run(capsys, "simulate", old, "--out", tmp_path / "run", "--no-figures", "--json")
    assert code == 0, err
    assert "note:" in err and "[manipulator] is deprecated" in err and "[mechanism]" in err
    assert json.loads(out)["max_path_error_m"] == simulate(load_scenario(new)).summary()["max_path_error_m"]


def test_summary_units_name_every_key_of_every_machine():
    for scenario in (paper_scenario("nominal"), load_scenario(EXAMPLES / "five_bar_circle.toml"),
                     load_scenario(EXAMPLES / "3prr_circle.toml")):
        summary = simulate(scenario.replace(sample_time=0.004)).summary()
        units = pkmlab.simulation.result.summary_units(scenario.model)
        assert set(summary) <= set(units)
        kinds = set(scenario.model.description.actuator_kinds)
        assert units["peak_effort"] == {"R": "N*m", "P": "N"}[kinds.pop()]
