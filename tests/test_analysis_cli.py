"""The analysis commands: ``pkmlab singularity-map``, ``pkmlab workspace`` and ``pkmlab animate``.

Numbers are checked against the paper's geometry written out here (vertices of the platform,
an inverse kinematics by the law of cosines, eq. (19) from ``tests/reference.py``), not against
pkmlab's kernels; the GIF is opened with Pillow and its frames counted.
"""

from __future__ import annotations

import csv
import doctest
import io
import json
import math
import shutil
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_user_error, run
from PIL import Image, ImageSequence
from reference import BASE, A, L, R, S_closed_form, eta

import pkmlab
import pkmlab.progress
import pkmlab.views.animation
from pkmlab.algorithms.analysis import workspace
from pkmlab.cli import main
from pkmlab.progress import Progress

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"


# ------------------------------------------------------------------ independent geometry
def u(angle):
    return np.array([np.cos(angle), np.sin(angle)])


def vertices(x, y, alpha, a=A):
    """Platform vertices p1, p2, p3 of the centroid pose (x, y, alpha) (conventions §1)."""
    p1 = np.array([x, y]) - a / math.sqrt(3) * u(alpha + math.pi / 6)
    return np.array([p1, p1 + a * u(alpha), p1 + a * u(alpha + math.pi / 3)])


def reachable_by_annulus(x, y, alpha, l=L, r=R):
    """Each vertex p_i within [|l - r|, l + r] of b_i; also the smallest distance to a bound."""
    rho = np.linalg.norm(vertices(x, y, alpha) - BASE, axis=1)
    lo, hi = abs(l - r), l + r
    return bool(np.all((lo <= rho) & (rho <= hi))), float(np.min(np.abs(np.r_[rho - lo, rho - hi])))


def inverse_kinematics_by_hand(x, y, alpha, mode):
    """q = (θ, φ, α) by the law of cosines; σ_i = +1 puts elbow e_i left of b_i → p_i."""
    p = vertices(x, y, alpha)
    theta, phi = [], []
    for i in range(3):
        d = p[i] - BASE[i]
        rho = np.hypot(*d)
        gamma = math.acos((L**2 + rho**2 - R**2) / (2 * L * rho))
        theta.append(math.atan2(d[1], d[0]) + mode[i] * gamma)
        e = BASE[i] + L * u(theta[-1])
        phi.append(math.atan2(*(p[i] - e)[::-1]))
    return np.array([*theta, *phi, alpha])


# ------------------------------------------------------------------ helpers
def run_json(capsys, *argv) -> dict:
    code, out, err = run(capsys, *argv, "--json")
    assert code == 0, err
    return json.loads(out)


def read_grid_csv(path: Path) -> np.ndarray:
    with open(path, newline="") as fh:
        rows = list(csv.reader(fh))
    assert rows[0] == ["x", "y", "S"]
    return np.array([[float(v) for v in row] for row in rows[1:]])


def gif_frames(path: Path) -> int:
    with Image.open(path) as im:
        assert im.format == "GIF"
        return sum(1 for _ in ImageSequence.Iterator(im))


def data_rows(path: Path) -> int:
    with open(path) as fh:
        return sum(1 for _ in fh) - 1


class FakeTerminal(io.StringIO):
    def isatty(self) -> bool:
        return True


# ------------------------------------------------------------------ singularity-map
@pytest.mark.parametrize("mode", [("+", "+", "+"), ("+", "-", "+"), ("-", "-", "-")])
def test_singularity_map_values_are_eq19_of_an_independent_inverse_kinematics(capsys, tmp_path, mode):
    alpha = 0.15
    argv = ["singularity-map", "--alpha", alpha, "--resolution", 21, "--x-range", 0.0, 0.5, "--y-range", 0.0, 0.45,
            "--out", tmp_path / "map.png", "--csv", tmp_path / "map.csv"]
    if mode != ("+", "+", "+"):
        argv += ["--mode", *mode]
    result = run_json(capsys, *argv)
    grid = read_grid_csv(tmp_path / "map.csv")
    assert grid.shape == (21 * 21, 3)
    np.testing.assert_allclose(np.unique(grid[:, 0]), np.linspace(0.0, 0.5, 21), atol=1e-15)
    np.testing.assert_allclose(np.unique(grid[:, 1]), np.linspace(0.0, 0.45, 21), atol=1e-15)
    signs = [1 if m == "+" else -1 for m in mode]
    checked = 0
    for x, y, s in grid:
        reachable, margin = reachable_by_annulus(x, y, alpha)
        if margin < 1e-9:
            continue  # on the boundary of reach: either answer is right
        assert np.isfinite(s) == reachable, (x, y, s)
        if reachable:
            q = inverse_kinematics_by_hand(x, y, alpha, signs)
            np.testing.assert_allclose(eta(q), 0.0, atol=1e-12)  # the hand-made IK closes the loops
            assert s == pytest.approx(S_closed_form(q), abs=1e-9), (x, y)
            checked += 1
    assert checked > 50
    finite = grid[np.isfinite(grid[:, 2]), 2]
    assert result["alpha"] == alpha
    assert result["mode"] == signs
    assert result["min_S"] == pytest.approx(finite.min(), abs=1e-12)
    assert result["max_S"] == pytest.approx(finite.max(), abs=1e-12)
    assert result["reachable_fraction"] == pytest.approx(finite.size / grid.shape[0])
    assert Path(result["figure"]) == tmp_path / "map.png"
    assert (tmp_path / "map.png").read_bytes().startswith(PNG_SIGNATURE)
    assert sorted(p.name for p in tmp_path.iterdir()) == ["map.csv", "map.png"]  # no temporary file left


def test_singularity_map_text_output_and_default_mode(capsys, tmp_path):
    code, out, err = run(capsys, "singularity-map", "--resolution", 11, "--out", tmp_path / "m.png", "--quiet")
    assert code == 0, err
    assert err == ""
    assert "(+, +, +)" in out
    assert str(tmp_path / "m.png") in out
    assert (tmp_path / "m.png").read_bytes().startswith(PNG_SIGNATURE)


# ------------------------------------------------------------------ workspace
def test_workspace_mask_is_the_annulus_test_of_every_leg_and_area_counts_cells():
    res, x_range, y_range, alpha = 41, (-0.05, 0.55), (-0.1, 0.5), -0.2
    ws = workspace(pkmlab.load("paper"), alpha, res, x_range, y_range)
    x, y = np.linspace(*x_range, res), np.linspace(*y_range, res)
    np.testing.assert_allclose(ws.x, x)
    np.testing.assert_allclose(ws.y, y)
    assert ws.reachable.shape == ws.S.shape == (8, res, res)
    assert {tuple(m) for m in ws.modes.tolist()} == {(a, b, c) for a in (1, -1) for b in (1, -1) for c in (1, -1)}
    expected = np.zeros((res, res), dtype=bool)
    for j, yj in enumerate(y):
        for i, xi in enumerate(x):
            expected[j, i], margin = reachable_by_annulus(xi, yj, alpha)
            assert margin > 1e-9  # no grid point on the boundary of reach: the comparison is exact
    cell = (x[1] - x[0]) * (y[1] - y[0])
    for k in range(8):
        np.testing.assert_array_equal(ws.reachable[k], expected)
        np.testing.assert_array_equal(np.isfinite(ws.S[k]), expected)
        assert ws.area[k] == pytest.approx(expected.sum() * cell, rel=1e-12)
    assert 0 < expected.sum() < expected.size


def test_workspace_modes_carry_their_own_singularity_measure():
    ws = workspace(pkmlab.load("paper"), 0.0, 11, (0.15, 0.35), (0.1, 0.3))
    j, i = 5, 5  # (0.25, 0.2), reachable in every mode
    for k, mode in enumerate(ws.modes):
        q = inverse_kinematics_by_hand(ws.x[i], ws.y[j], 0.0, mode)
        assert ws.S[k, j, i] == pytest.approx(S_closed_form(q), abs=1e-9)


def test_workspace_command_json_areas(capsys, tmp_path):
    res, x_range, y_range = 31, (0.0, 0.52), (-0.05, 0.45)
    result = run_json(capsys, "workspace", "--resolution", res, "--x-range", *x_range, "--y-range", *y_range,
                      "--alpha", 0.1, "--out", tmp_path / "ws.png")
    x, y = np.linspace(*x_range, res), np.linspace(*y_range, res)
    count = sum(reachable_by_annulus(xi, yj, 0.1)[0] for yj in y for xi in x)
    cell = (x[1] - x[0]) * (y[1] - y[0])
    assert result["cell_area_m2"] == pytest.approx(cell)
    assert len(result["areas"]) == 8
    assert {tuple(a["mode"]) for a in result["areas"]} == {(a, b, c) for a in (1, -1) for b in (1, -1)
                                                           for c in (1, -1)}
    for entry in result["areas"]:
        assert entry["area_m2"] == pytest.approx(count * cell, rel=1e-12)
        assert entry["area_cm2"] == pytest.approx(count * cell * 1e4, rel=1e-12)
    assert (tmp_path / "ws.png").read_bytes().startswith(PNG_SIGNATURE)
    assert [p.name for p in tmp_path.iterdir()] == ["ws.png"]


def test_workspace_text_output(capsys, tmp_path):
    code, out, err = run(capsys, "workspace", "--resolution", 15, "--out", tmp_path / "ws.svg")
    assert code == 0, err
    assert "(-, +, -)" in out and "area (cm^2)" in out
    assert (tmp_path / "ws.svg").read_text().lstrip().startswith("<?xml")


# ------------------------------------------------------------------ animate
@pytest.fixture(scope="module")
def reproduced(tmp_path_factory) -> Path:
    out = tmp_path_factory.mktemp("reproduced") / "out"
    assert main(["reproduce", "--out", str(out), "--no-figures", "--quiet"]) == 0
    return out


def test_animate_writes_a_gif_with_one_frame_per_stride(capsys, tmp_path, reproduced):
    n = data_rows(reproduced / "nominal.csv")
    stride = math.ceil(n / 10)
    gif = tmp_path / "anim" / "run.gif"
    result = run_json(capsys, "animate", reproduced, "--out", gif, "--stride", stride, "--fps", 10)
    data = gif.read_bytes()
    assert data.startswith(b"GIF8")
    expected = len(range(0, n, stride))
    assert 9 <= expected <= 10
    assert gif_frames(gif) == expected == result["frames"]
    assert result["samples"] == n and result["stride"] == stride
    assert result["csv"] == str(reproduced / "nominal.csv")
    assert result["max_centroid_deviation_m"] < 1e-9  # the mechanism rebuilt is the one that ran
    with Image.open(gif) as im:
        assert im.info["duration"] == 100  # 10 fps
    assert [p.name for p in gif.parent.iterdir()] == ["run.gif"]


def test_animate_default_stride_gives_about_100_frames(capsys, tmp_path, reproduced):
    gif = tmp_path / "fast.gif"
    code, out, err = run(capsys, "animate", reproduced, "--case", "fast", "--out", gif)
    assert code == 0, err
    assert err == ""  # not a terminal: no progress bar
    n = data_rows(reproduced / "fast.csv")
    frames = gif_frames(gif)
    assert frames == len(range(0, n, math.ceil(n / 100)))
    assert 90 <= frames <= 100
    assert f"{frames} frames" in out


def test_animate_disturbed_case_uses_the_scaled_plant(capsys, tmp_path, reproduced):
    stride = data_rows(reproduced / "disturbed.csv")  # one frame
    result = run_json(capsys, "animate", reproduced, "--case", "disturbed", "--out", tmp_path / "d.gif",
                      "--stride", stride)
    assert result["frames"] == 1
    assert result["max_centroid_deviation_m"] < 1e-9
    assert result["mechanism"].endswith("disturbed_plant.toml")  # the case's own plant, written by reproduce
    # The paper's machine did not produce that run: the rebuilt centroid is far from the CSV's.
    paper = tmp_path / "paper.toml"
    paper.write_text('[manipulator]\npreset = "paper"\n')
    code, out, err = run(capsys, "animate", reproduced, "--case", "disturbed", "--out", tmp_path / "p.gif",
                         "--stride", stride, "--params", paper, "--json")
    assert code == 0
    assert json.loads(out)["max_centroid_deviation_m"] > 0.01
    assert "warning" in err and "--params" in err


def test_animate_simulate_folder_uses_run_csv_and_plant_toml(capsys, tmp_path, reproduced):
    folder = tmp_path / "sim"
    folder.mkdir()
    shutil.copy(reproduced / "disturbed.csv", folder / "run.csv")
    (folder / "plant.toml").write_text(
        "[manipulator.params]\nl = 0.2875\nr = 0.191705\na = 0.14375\n"  # the paper's lengths x1.15
    )
    result = run_json(capsys, "animate", folder, "--out", tmp_path / "run.gif", "--stride", 400)
    assert result["csv"] == str(folder / "run.csv")
    assert result["mechanism"].endswith("plant.toml")
    assert result["max_centroid_deviation_m"] < 1e-9
    assert gif_frames(tmp_path / "run.gif") == len(range(0, data_rows(folder / "run.csv"), 400))


def _csv_text(reproduced: Path, rows: int = 30) -> list[str]:
    return (reproduced / "nominal.csv").read_text().splitlines()[: rows + 1]


def _drop_columns(lines: list[str], names: set[str]) -> str:
    table = [line.split(",") for line in lines]
    keep = [j for j, name in enumerate(table[0]) if name not in names]
    return "\n".join(",".join(row[j] for j in keep) for row in table) + "\n"


def _with_value(lines: list[str], row: int, column: str, value: str) -> str:
    table = [line.split(",") for line in lines]
    table[row][table[0].index(column)] = value
    return "\n".join(",".join(r) for r in table) + "\n"


ANIMATE_ERRORS = {
    "missing folder": (lambda d, r: ["animate", d / "nowhere"], "does not exist"),
    "folder is a file": (lambda d, r: ["animate", r / "summary.json"], "not a folder"),
    "no csv": (lambda d, r: ["animate", d / "empty"], "nominal.csv"),
    "unknown case": (lambda d, r: ["animate", r, "--case", "slow"], "cases found: disturbed, fast, nominal"),
    "bad case name": (lambda d, r: ["animate", r, "--case", "../x"], "--case"),
    "missing columns": (lambda d, r: ["animate", d / "missing"], "missing columns theta2, x_d"),
    "not a number": (lambda d, r: ["animate", d / "text"], "row 3 (line 4): theta1 = 'abc' is not a number"),
    "not finite": (lambda d, r: ["animate", d / "nan"], "row 5 (line 6): y = 'nan' is not a finite number"),
    "short row": (lambda d, r: ["animate", d / "short"], "row 2 (line 3) has 16 fields"),
    "empty csv": (lambda d, r: ["animate", d / "blank"], "empty file"),
    "header only": (lambda d, r: ["animate", d / "header"], "no data rows"),
    "zero stride": (lambda d, r: ["animate", r, "--stride", 0], "--stride"),
    "zero fps": (lambda d, r: ["animate", r, "--fps", 0], "--fps"),
    "missing params": (lambda d, r: ["animate", r, "--params", d / "none.toml"], "none.toml"),
}


@pytest.mark.parametrize("case", list(ANIMATE_ERRORS))
def test_animate_errors_are_one_line_and_write_nothing(capsys, tmp_path, reproduced, case):
    lines = _csv_text(reproduced)
    for name, text in {
        "missing": _drop_columns(lines, {"theta2", "x_d"}),
        "text": _with_value(lines, 3, "theta1", "abc"),
        "nan": _with_value(lines, 5, "y", "nan"),
        "short": "\n".join(lines[:2] + [lines[2].rsplit(",", 1)[0]] + lines[3:]) + "\n",
        "blank": "",
        "header": lines[0] + "\n",
    }.items():
        (tmp_path / name).mkdir()
        (tmp_path / name / "run.csv").write_text(text)
    (tmp_path / "empty").mkdir()
    out_dir = tmp_path / "gifs"
    argv, expected = ANIMATE_ERRORS[case]
    message = assert_user_error(*run(capsys, *argv(tmp_path, reproduced), "--out", out_dir / "a.gif"))
    assert message.startswith("pkmlab animate: error: ")
    assert expected in message
    assert not out_dir.exists()


@pytest.mark.parametrize("out, expected", [("a.png", "unsupported file type"), ("folder", "is a folder"),
                                           ("blocker/a.gif", "not a folder")])
def test_animate_bad_output_paths(capsys, tmp_path, reproduced, out, expected):
    (tmp_path / "folder").mkdir()
    (tmp_path / "blocker").write_text("a file")
    before = sorted(p.name for p in tmp_path.iterdir())
    message = assert_user_error(*run(capsys, "animate", reproduced, "--out", tmp_path / out))
    assert expected in message
    assert sorted(p.name for p in tmp_path.iterdir()) == before


# ------------------------------------------------------------------ errors of the maps
MAP_ERRORS = [
    (["--resolution", 1], "--resolution"),
    (["--resolution", 100000], "--resolution"),
    (["--alpha", "nan"], "alpha must be finite"),
    (["--x-range", 0.3, 0.1], "x_range"),
    (["--y-range", 0.2, "inf"], "--y-range must be finite"),
    (["--x-range", 5.0, 6.0], "no pose of the region"),
    (["--params", "missing.toml"], "missing.toml"),
]


@pytest.mark.parametrize("command", ["singularity-map", "workspace"])
@pytest.mark.parametrize("extra, expected", MAP_ERRORS)
def test_map_errors_are_one_line_and_write_nothing(capsys, tmp_path, command, extra, expected):
    out = tmp_path / "figs" / "f.png"
    message = assert_user_error(*run(capsys, command, "--resolution", 9, *extra, "--out", out))
    assert message.startswith(f"pkmlab {command}: error: ")
    assert expected in message
    assert not (tmp_path / "figs").exists()


@pytest.mark.parametrize("extra, expected", [
    (["--mode", "+", "x", "+"], "working mode"),
    (["--csv", "{tmp}/f.txt"], "unsupported file type"),
    (["--out", "{tmp}/f.xyz"], "unsupported file type"),
    (["--out", "{tmp}/blocker/f.png"], "not a folder"),
])
def test_singularity_map_option_errors(capsys, tmp_path, extra, expected):
    (tmp_path / "blocker").write_text("a file")
    extra = [str(a).format(tmp=tmp_path) for a in extra]
    message = assert_user_error(*run(capsys, "singularity-map", "--resolution", 9, "--out", tmp_path / "f.png", *extra))
    assert expected in message
    assert [p.name for p in tmp_path.iterdir()] == ["blocker"]


def test_map_errors_with_json_go_to_stdout(capsys, tmp_path):
    code, out, err = run(capsys, "workspace", "--resolution", 1, "--out", tmp_path / "w.png", "--json")
    assert code == 1
    assert json.loads(out)["error"]["type"] == "InvalidParameterError"
    assert list(tmp_path.iterdir()) == []


# ------------------------------------------------------------------ progress
def test_progress_bar_only_on_a_terminal_and_not_with_quiet(capsys, tmp_path, reproduced, monkeypatch):
    argv = ["animate", str(reproduced), "--out", str(tmp_path / "a.gif"), "--stride", "300"]
    # capsys: stderr is not a terminal
    assert main(argv) == 0
    assert capsys.readouterr().err == ""
    terminal = FakeTerminal()
    monkeypatch.setattr(sys, "stderr", terminal)
    assert main(argv + ["--quiet"]) == 0
    assert terminal.getvalue() == ""
    assert main(argv) == 0
    bar = terminal.getvalue()
    assert bar.startswith("\r[")
    assert bar.endswith("] 100% frames\n")
    assert bar.count("\n") == 1
    terminal.truncate(0)
    terminal.seek(0)
    assert main(["workspace", "--resolution", "40", "--out", str(tmp_path / "w.png")]) == 0
    assert "100% workspace\n" in terminal.getvalue()
    terminal.truncate(0)
    terminal.seek(0)
    assert main(["singularity-map", "--resolution", "40", "--out", str(tmp_path / "m.png"), "--quiet"]) == 0
    assert terminal.getvalue() == ""


def test_progress_draws_percentages():
    stream = FakeTerminal()
    with Progress(4, "steps", stream=stream, width=8) as bar:
        for _ in range(4):
            bar.update()
    assert stream.getvalue() == ("\r[........]   0% steps\r[##......]  25% steps\r[####....]  50% steps"
                                 "\r[######..]  75% steps\r[########] 100% steps\n")
    silent = FakeTerminal()
    with Progress(4, "steps", enabled=False, stream=silent) as bar:
        bar.update(4)
    assert silent.getvalue() == ""


def test_a_long_job_off_a_terminal_says_how_far_it_is_in_whole_lines(monkeypatch):
    """A log or a pipe gets no bar (no carriage return) but, every STATUS_EVERY seconds of a long job, one whole
    line with the percentage, the count and the time left, and a last line saying where it ended; a quick job
    says nothing there."""
    clock = iter(np.arange(0.0, 1000.0, 4.0))  # each look at the clock 4 s later
    monkeypatch.setattr(pkmlab.progress.time, "monotonic", lambda: next(clock))
    log = io.StringIO()
    with Progress(10, "sweep", stream=log, unit="runs") as bar:
        for _ in range(6):
            bar.update()
    lines = log.getvalue().splitlines()
    assert "\r" not in log.getvalue() and len(lines) >= 2
    assert lines[0].startswith("pkmlab: sweep: ") and "/10 runs, ETA " in lines[0]
    assert lines[-1] == "pkmlab: sweep: stopped at 60% (6/10 runs)"
    monkeypatch.setattr(pkmlab.progress.time, "monotonic", lambda: 0.0)  # a quick job
    quick = io.StringIO()
    with Progress(10, "sweep", stream=quick, unit="runs") as bar:
        bar.update(10)
    assert quick.getvalue() == ""
    quiet = io.StringIO()
    with Progress(10, "sweep", stream=quiet, enabled=False, status_every=0.0) as bar:
        bar.update(10)
    assert quiet.getvalue() == ""


@pytest.mark.parametrize("module", [pkmlab.views.animation, pkmlab.progress])
def test_docstring_examples(module):
    result = doctest.testmod(module, optionflags=doctest.ELLIPSIS | doctest.NORMALIZE_WHITESPACE)
    assert result.attempted > 0
    assert result.failed == 0


# ------------------------------------------------------------------ failures while writing
def test_animate_interrupted_while_drawing_leaves_nothing(capsys, tmp_path, reproduced, monkeypatch):
    calls = []

    def interrupt(self, n=1):
        calls.append(n)
        if len(calls) == 3:
            raise KeyboardInterrupt

    monkeypatch.setattr(Progress, "update", interrupt)
    code, out, err = run(capsys, "animate", reproduced, "--out", tmp_path / "new" / "deeper" / "a.gif",
                         "--stride", 200)
    assert code == 130
    assert err.strip() == "pkmlab animate: interrupted"
    assert list(tmp_path.iterdir()) == []  # neither the GIF, its temporary file nor the folders made for it


def test_map_write_failure_is_one_line_and_leaves_nothing(capsys, tmp_path, monkeypatch):
    from matplotlib.figure import Figure

    def disk_full(self, fname, **kwargs):
        Path(fname).write_bytes(b"partial")
        raise OSError(28, "No space left on device")

    monkeypatch.setattr(Figure, "savefig", disk_full)
    out = tmp_path / "new" / "map.png"
    message = assert_user_error(*run(capsys, "singularity-map", "--resolution", 9, "--out", out,
                                     "--csv", tmp_path / "new" / "map.csv"))
    assert "No space left on device" in message
    assert list(tmp_path.iterdir()) == []
