"""Tests of the ``pkmlab`` command line (in-process through ``pkmlab.cli.main`` and, for a few
cases, the installed console script).

The numbers the CLI prints are checked against the paper's geometry written out here: the legs
rebuilt from the printed angles must put the platform vertices where the pose says they are. The paper's
machine is the default; its passive coordinates (``"passive"``) are the passive links' absolute angles
phi1..3 (docs/conventions.md), its pose ``[x, y, alpha]``.
"""

from __future__ import annotations

import itertools
import json
import math
import re
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_user_error, run

from pkmlab.cli import main

SCRIPT = Path(sys.executable).with_name("pkmlab")
PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
ALL_MODES = set(itertools.product((1, -1), repeat=3))


# ------------------------------------------------------------------ independent geometry
@dataclass(frozen=True)
class Geometry:
    """The planar 3-RRR as the paper and docs/conventions.md describe it, independent of pkmlab."""

    b: float = 0.52
    l: tuple[float, float, float] = (0.25, 0.25, 0.25)
    r: tuple[float, float, float] = (0.1667, 0.1667, 0.1667)
    a: float = 0.125

    @property
    def base(self) -> np.ndarray:
        b = self.b
        return np.array([(0.0, 0.0), (b, 0.0), (b / 2, math.sqrt(3) / 2 * b)])

    def vertices(self, pose) -> np.ndarray:
        """Platform vertices p1, p2, p3 of the pose (x, y, alpha) of the centroid."""
        x, y, alpha = pose
        a = self.a
        p1 = np.array([x, y]) - a / math.sqrt(3) * u(alpha + math.pi / 6)
        return np.array([p1, p1 + a * u(alpha), p1 + a * u(alpha + math.pi / 3)])

    def legs(self, theta, phi) -> tuple[np.ndarray, np.ndarray]:
        """Elbows e_i = b_i + l_i u(theta_i) and leg ends p_i = e_i + r_i u(phi_i)."""
        e = np.array([self.base[i] + self.l[i] * u(theta[i]) for i in range(3)])
        p = np.array([e[i] + self.r[i] * u(phi[i]) for i in range(3)])
        return e, p

    def unreachable_legs(self, pose) -> set[int]:
        v = self.vertices(pose)
        rho = np.linalg.norm(v - self.base, axis=1)
        lo = np.abs(np.subtract(self.l, self.r))
        hi = np.add(self.l, self.r)
        return {i + 1 for i in range(3) if not lo[i] <= rho[i] <= hi[i]}


def u(angle: float) -> np.ndarray:
    return np.array([math.cos(angle), math.sin(angle)])


def cross(v, w) -> float:
    return float(v[0] * w[1] - v[1] * w[0])


def wrap(angle):
    """Angle difference folded to (-pi, pi]."""
    return np.angle(np.exp(1j * np.asarray(angle)))


PAPER = Geometry()
POSES = [(0.2, 0.21, 0.0), (0.25, 0.16, -0.1), (0.3, 0.2, 0.3)]


# ------------------------------------------------------------------ helpers
def assert_params_note(err: str, command: str) -> None:
    """What a command given the deprecated ``--params`` says besides its result: one note on stderr."""
    lines = err.strip("\n").split("\n")
    assert len(lines) == 1, err
    assert lines[0].startswith(f"pkmlab {command}: note: --params") and "deprecated" in lines[0], err
    assert "--mechanism FILE.toml" in lines[0], err


def run_json(capsys, *argv) -> dict:
    code, out, err = run(capsys, *argv, "--json")
    assert code == 0, err
    if "--params" in map(str, argv):
        assert_params_note(err, argv[0])
    else:
        assert err == ""
    return json.loads(out)


def ik_solutions(capsys, pose, *extra) -> list[dict]:
    return run_json(capsys, "ik", *map(repr, pose), *extra)["solutions"]


def assert_names(message: str, name: str) -> None:
    """The message names the parameter as the subject of a complaint: ``l must ...``,
    ``a (platform side) must ...``, ``params.toml.params.l must ...``, ``got l2 = 0``."""
    pattern = rf"(^|[\s.:\[]){re.escape(name)}(\]? must|\s\(|\d*\s=)"
    assert re.search(pattern, message), f"message does not name {name!r}: {message!r}"


def write(tmp_path: Path, text: str, name: str = "params.toml") -> Path:
    path = tmp_path / name
    path.write_text(text, encoding="utf-8")
    return path


def assert_solution_at_pose(geometry: Geometry, solution: dict, pose, tol: float = 1e-10) -> None:
    """The legs rebuilt from the printed angles reach the platform vertices of ``pose``; the
    working mode printed is the side of each elbow: sigma_i = +1 iff (p_i - b_i) x (e_i - b_i) > 0."""
    e, p = geometry.legs(solution["theta"], solution["passive"])
    np.testing.assert_allclose(p, geometry.vertices(pose), rtol=0, atol=tol)
    b = geometry.base
    sides = [1 if cross(p[i] - b[i], e[i] - b[i]) > 0 else -1 for i in range(3)]
    assert sides == solution["mode"]


# ------------------------------------------------------------------ ik
def test_ik_prints_a_table_of_eight_working_modes(capsys):
    code, out, err = run(capsys, "ik", "0.2", "0.21", "0")
    assert code == 0
    assert err == ""
    lines = out.strip().splitlines()
    assert "x = 0.2" in lines[0] and "y = 0.21" in lines[0] and "alpha = 0" in lines[0]
    assert lines[1].split() == ["mode", "theta1", "theta2", "theta3", "q1_2", "q2_2", "q3_2", "S"]
    rows = lines[2:]
    assert len(rows) == 8
    row_re = re.compile(r"^\(([+-]), ([+-]), ([+-])\)((\s+[+-]\d+\.\d{6}){7})$")
    modes = set()
    table = {}
    for row in rows:
        match = row_re.match(row)
        assert match, row
        mode = tuple(1 if s == "+" else -1 for s in match.groups()[:3])
        modes.add(mode)
        table[mode] = [float(v) for v in match.group(4).split()]
    assert modes == ALL_MODES
    # The table shows the same angles as the JSON output, rounded to 6 decimals.
    for sol in ik_solutions(capsys, (0.2, 0.21, 0.0)):
        np.testing.assert_allclose(table[tuple(sol["mode"])], sol["theta"] + sol["passive"] + [sol["S"]], rtol=0,
                                   atol=5.1e-7)


def test_ik_json_lists_every_working_mode_once(capsys):
    result = run_json(capsys, "ik", "0.2", "0.21", "0")
    assert set(result) == {"mechanism", "pose_names", "solutions"}
    assert result["mechanism"] == "paper" and result["pose_names"] == ["x", "y", "alpha"]
    solutions = result["solutions"]
    assert len(solutions) == 8
    for sol in solutions:
        assert set(sol) == {"mode", "theta", "passive", "S"}
        assert len(sol["mode"]) == len(sol["theta"]) == len(sol["passive"]) == 3
        assert all(isinstance(m, int) and m in (1, -1) for m in sol["mode"])
        assert all(isinstance(v, float) and math.isfinite(v) for v in sol["theta"] + sol["passive"] + [sol["S"]])
    assert {tuple(sol["mode"]) for sol in solutions} == ALL_MODES


@pytest.mark.parametrize("pose", POSES)
def test_ik_solutions_put_the_platform_at_the_pose(capsys, pose):
    assert PAPER.unreachable_legs(pose) == set()
    solutions = ik_solutions(capsys, pose)
    assert len(solutions) == 8
    for sol in solutions:
        assert_solution_at_pose(PAPER, sol, pose)
    # Two working modes of a leg are two different elbows for the same vertex.
    by_mode = {tuple(sol["mode"]): sol for sol in solutions}
    for leg in range(3):
        plus = by_mode[(1, 1, 1)]
        minus = by_mode[tuple(-1 if i == leg else 1 for i in range(3))]
        assert abs(wrap(plus["theta"][leg] - minus["theta"][leg])) > 1e-3


@pytest.mark.parametrize("mode", [["+", "-", "+"], ["1", "-1", "1"], ["+1", "-1", "+1"]], ids=" ".join)
def test_ik_one_working_mode(capsys, mode):
    pose = (0.2, 0.21, 0.0)
    solutions = ik_solutions(capsys, pose, "--mode", *mode)
    assert len(solutions) == 1
    (sol,) = solutions
    assert sol["mode"] == [1, -1, 1]
    assert_solution_at_pose(PAPER, sol, pose)
    everything = {tuple(s["mode"]): s for s in ik_solutions(capsys, pose)}
    np.testing.assert_allclose(sol["theta"], everything[(1, -1, 1)]["theta"], rtol=0, atol=1e-12)
    np.testing.assert_allclose(sol["passive"], everything[(1, -1, 1)]["passive"], rtol=0, atol=1e-12)


def test_ik_one_working_mode_table(capsys):
    code, out, err = run(capsys, "ik", "0.2", "0.21", "0", "--mode", "-", "-", "+")
    assert code == 0 and err == ""
    rows = out.strip().splitlines()[2:]
    assert len(rows) == 1
    assert rows[0].startswith("(-, -, +)")


def test_ik_negative_positional_arguments(capsys):
    pose = (0.25, 0.16, -0.1)
    code, out, err = run(capsys, "ik", "0.25", "0.16", "-0.1")
    assert code == 0, err
    assert "alpha = -0.1" in out.splitlines()[0]
    solutions = ik_solutions(capsys, pose)
    assert len(solutions) == 8
    for sol in solutions:
        assert_solution_at_pose(PAPER, sol, pose)
    # With --mode after a negative positional too.
    (sol,) = ik_solutions(capsys, pose, "--mode", "-1", "1", "-1")
    assert sol["mode"] == [-1, 1, -1]
    assert_solution_at_pose(PAPER, sol, pose)


@pytest.mark.parametrize("alpha", ["-1e-1", "-1.0E-1", "-.1", "-0.100"])
def test_ik_negative_numbers_in_any_float_spelling(capsys, alpha):
    pose = (0.25, 0.16, -0.1)
    solutions = run_json(capsys, "ik", "0.25", "0.16", alpha, "--mode", "+", "-", "-")["solutions"]
    assert len(solutions) == 1
    assert_solution_at_pose(PAPER, solutions[0], pose)


def test_fk_negative_numbers_in_scientific_notation(capsys):
    plain = run_json(capsys, "fk", "1.6", "2.0", "-1.2")
    assert run_json(capsys, "fk", "1.6e0", "2.0", "-1.2e0") == plain
    assert run_json(capsys, "fk", "1.6", "2.0", "-12E-1") == plain


def test_ik_invalid_mode_is_a_user_error(capsys):
    message = assert_user_error(*run(capsys, "ik", "0.2", "0.21", "0", "--mode", "+", "-", "x"))
    assert "mode" in message


# ------------------------------------------------------------------ fk
def fk_solutions(capsys, theta, *extra) -> list[dict]:
    return run_json(capsys, "fk", *map(repr, theta), *extra)["solutions"]


def assert_closes_loops(geometry: Geometry, theta, sol: dict, tol: float = 1e-10) -> None:
    """The three leg ends form the platform (equilateral, side a) at the printed pose."""
    _e, p = geometry.legs(theta, sol["passive"])
    sides = [np.linalg.norm(p[(i + 1) % 3] - p[i]) for i in range(3)]
    np.testing.assert_allclose(sides, [geometry.a] * 3, rtol=0, atol=tol)
    pose = sol["pose"]
    np.testing.assert_allclose(p, geometry.vertices(pose), rtol=0, atol=tol)


def test_fk_json_structure(capsys):
    theta = [s["theta"] for s in ik_solutions(capsys, (0.2, 0.21, 0.0), "--mode", "+", "-", "+")][0]
    result = run_json(capsys, "fk", *map(repr, theta))
    assert set(result) == {"mechanism", "pose_names", "solutions", "method"}
    assert result["method"].endswith(": complete")  # the paper's sextic: every real root, nothing to doubt
    assert result["mechanism"] == "paper" and result["pose_names"] == ["x", "y", "alpha"]
    solutions = result["solutions"]
    assert 1 <= len(solutions) <= 6
    for sol in solutions:
        assert set(sol) == {"pose", "passive", "S"}
        assert len(sol["pose"]) == len(sol["passive"]) == 3
        values = [*sol["pose"], sol["S"], *sol["passive"]]
        assert all(isinstance(v, float) and math.isfinite(v) for v in values)


@pytest.mark.parametrize("pose", POSES[:2])
def test_fk_recovers_the_ik_pose_and_closes_the_loops(capsys, pose):
    for ik_sol in ik_solutions(capsys, pose):
        theta = ik_sol["theta"]
        solutions = fk_solutions(capsys, theta)
        assert 1 <= len(solutions) <= 6
        for sol in solutions:
            assert_closes_loops(PAPER, theta, sol)
        # Distinct assembly modes.
        for s1, s2 in itertools.combinations(solutions, 2):
            (x1, y1, a1), (x2, y2, a2) = s1["pose"], s2["pose"]
            gap = np.hypot(x1 - x2, y1 - y2) + abs(wrap(a1 - a2))
            assert gap > 1e-6
        # One of them is the pose IK started from, with IK's passive angles.
        errors = [max(abs(s["pose"][0] - pose[0]), abs(s["pose"][1] - pose[1]), abs(wrap(s["pose"][2] - pose[2])))
                  for s in solutions]
        match = solutions[int(np.argmin(errors))]
        assert min(errors) < 1e-9, (ik_sol["mode"], errors)
        np.testing.assert_allclose(wrap(np.subtract(match["passive"], ik_sol["passive"])), 0.0, atol=1e-9)


def test_fk_singularity_measure_follows_the_paper_formula(capsys):
    # conventions §2: S = sin(phi1 - alpha) sin(phi2 - phi3) + sin(phi1 - phi2) sin(alpha + 2 pi/3 - phi3)
    # for the paper's geometry (equal r_i, equilateral platform).
    theta = ik_solutions(capsys, (0.2, 0.21, 0.0), "--mode", "-", "+", "-")[0]["theta"]
    solutions = fk_solutions(capsys, theta)
    for sol in solutions:
        f1, f2, f3 = sol["passive"]
        alpha = sol["pose"][2]
        expected = math.sin(f1 - alpha) * math.sin(f2 - f3) + math.sin(f1 - f2) * math.sin(alpha + 2 * math.pi / 3 - f3)
        assert sol["S"] == pytest.approx(expected, abs=1e-10)
        assert abs(sol["S"]) > 1e-6


def test_fk_table(capsys):
    theta = ik_solutions(capsys, (0.2, 0.21, 0.0), "--mode", "+", "+", "+")[0]["theta"]
    solutions = fk_solutions(capsys, theta)
    code, out, err = run(capsys, "fk", *map(repr, theta))
    assert code == 0 and err == ""
    lines = out.strip().splitlines()
    assert f"{len(solutions)} assembly mode" in lines[0]
    assert lines[1].split() == ["#", "x", "y", "alpha", "q1_2", "q2_2", "q3_2", "S"]
    assert lines[-1].startswith("method: ") and lines[-1].endswith(": complete")
    rows = [line.split() for line in lines[2:-1]]
    assert [row[0] for row in rows] == [str(j + 1) for j in range(len(solutions))]
    for row, sol in zip(rows, solutions, strict=True):
        np.testing.assert_allclose([float(v) for v in row[1:]], [*sol["pose"], *sol["passive"], sol["S"]], rtol=0,
                                   atol=5.1e-7)


def test_fk_without_assembly_is_a_user_error(capsys):
    # theta = 0: every elbow at b_i + (l, 0); e1 and e2 are b = 0.52 apart on the x axis while
    # p1 and p2 must be a apart within r of them: 0.52 - 2 r > a, so no assembly exists.
    assert 0.52 - 2 * 0.1667 > 0.125
    message = assert_user_error(*run(capsys, "fk", "0", "0", "0"))
    assert "cannot be assembled" in message


# ------------------------------------------------------------------ user errors
@pytest.mark.parametrize(
    "pose",
    [(0.09, 0.06, 0.0), (0.1, 0.3, 0.2), (0.5, 0.05, 0.0), (5.0, 5.0, 0.0)],
)
def test_unreachable_pose_names_the_legs(capsys, pose):
    expected = PAPER.unreachable_legs(pose)
    assert expected  # the pose really is out of reach
    message = assert_user_error(*run(capsys, "ik", *map(repr, pose)))
    assert "reach" in message
    assert named_legs(message) == expected, message
    first = min(expected)  # why the first of them cannot: the distance to its base point
    assert f"(leg {first}: the attachment point is " in message


def named_legs(message: str) -> set[int]:
    """The legs an ik error says cannot reach the pose: ``... legs 1 and 2 cannot reach it ...``."""
    match = re.search(r"\blegs? ((?:\d+(?:, | and )?)+) cannot reach it", message)
    assert match, message
    return {int(v) for v in re.findall(r"\d+", match.group(1))}


def test_unreachable_pose_json(capsys):
    code, out, err = run(capsys, "ik", "0.09", "0.06", "0", "--json")
    assert code == 1
    assert err == ""
    error = json.loads(out)["error"]
    assert set(error) == {"type", "message"}
    assert error["type"] == "UnreachablePoseError"
    assert "leg 1" in error["message"]
    assert "\n" not in error["message"]


@pytest.mark.parametrize(
    "argv",
    [
        ["ik", "nan", "0.2", "0"],
        ["ik", "0.2", "inf", "0"],
        ["ik", "0.2", "0.21", "-inf"],
        ["fk", "1.6", "nan", "-1.2"],
    ],
)
def test_non_finite_input_is_a_user_error(capsys, argv):
    message = assert_user_error(*run(capsys, *argv))
    assert "finite" in message


def test_missing_params_file(capsys, tmp_path):
    missing = tmp_path / "nowhere.toml"
    message = assert_user_error(*run(capsys, "ik", "0.2", "0.21", "0", "--params", missing))
    assert "nowhere.toml" in message


def test_params_file_is_a_directory(capsys, tmp_path):
    assert_user_error(*run(capsys, "ik", "0.2", "0.21", "0", "--params", tmp_path))


def test_malformed_toml_names_the_line(capsys, tmp_path):
    path = write(tmp_path, "l = 0.25\nr = = 0.17\na = 0.12\n")
    message = assert_user_error(*run(capsys, "ik", "0.2", "0.21", "0", "--params", path))
    assert re.search(r"\bline 2\b", message), message
    assert "params.toml" in message


def test_non_utf8_params_file(capsys, tmp_path):
    path = tmp_path / "params.toml"
    path.write_bytes(b"l = 0.25\n# \xff\xfe\n")
    assert_user_error(*run(capsys, "ik", "0.2", "0.21", "0", "--params", path))


@pytest.mark.parametrize(
    ("text", "typo", "suggestion"),
    [
        ("mass_ll = 0.5\n", "mass_ll", "mass_l"),
        ("inertia_rr = 1e-3\n", "inertia_rr", "inertia_r"),
        ("[manipulator]\n[manipulator.params]\nlenght = 0.25\n", "lenght", None),
        ("[manipulator]\npreset = 'paper'\n[manipulator.parms]\nl = 0.25\n", "parms", "params"),
        ("[manipulator]\npreset = 'papr'\n", "papr", "paper"),
    ],
)
def test_unknown_key_suggests_the_closest(capsys, tmp_path, text, typo, suggestion):
    path = write(tmp_path, text)
    message = assert_user_error(*run(capsys, "ik", "0.2", "0.21", "0", "--params", path))
    assert f"'{typo}'" in message
    if suggestion is not None:
        assert f"'{suggestion}'" in message


@pytest.mark.parametrize(
    ("text", "name"),
    [
        ("l = -0.1\n", "l"),
        ("l = [0.25, 0.0, 0.25]\n", "l"),
        ("r = 0\n", "r"),
        ("a = -0.125\n", "a"),
        ("mass_a = 0\n", "mass_a"),
        ("inertia_l = [2e-3, 2e-3, -1e-3]\n", "inertia_l"),
        ("b = 0\n", "b"),
        ("l = nan\n", "l"),
        ("r = inf\n", "r"),
    ],
)
def test_invalid_parameter_value(capsys, tmp_path, text, name):
    path = write(tmp_path, text)
    message = assert_user_error(*run(capsys, "ik", "0.2", "0.21", "0", "--params", path))
    assert_names(message, name)


@pytest.mark.parametrize(
    ("text", "name"),
    [
        ('l = "abc"\n', "l"),
        ("l = true\n", "l"),
        ("l = [true, 1, 1]\n", "l"),
        ('r = [0.17, 0.17, "x"]\n', "r"),
        ("l = [0.25, 0.25]\n", "l"),
        ("a = [0.1, 0.2]\n", "a"),
        ('mass_a = ["x"]\n', "mass_a"),
        ("l = {x = 1}\n", "l"),
        ('base_points = [[0, 0], [0.52, 0], [0.26, "x"]]\n', "base_points"),
        ("base_points = [[0, 0], [0.52], [0.26, 0.45]]\n", "base_points"),
        ("[manipulator]\nparams = 3\n", "params"),
        ("manipulator = 3\n", "manipulator"),
    ],
)
def test_wrong_type_of_parameter(capsys, tmp_path, text, name):
    path = write(tmp_path, text)
    message = assert_user_error(*run(capsys, "ik", "0.2", "0.21", "0", "--params", path))
    assert_names(message, name)


def test_collinear_base_points(capsys, tmp_path):
    path = write(tmp_path, "base_points = [[0, 0], [0.3, 0], [0.6, 0]]\n")
    message = assert_user_error(*run(capsys, "ik", "0.2", "0.21", "0", "--params", path))
    assert "collinear" in message


@pytest.mark.parametrize("text", ["a = 2.0\n", "[manipulator]\n[manipulator.params]\nb = 2.0\n"])
def test_platform_that_cannot_be_assembled(capsys, tmp_path, text):
    # Each vertex must lie within l + r = 0.4167 of its base point: with a = 2 the vertices would
    # have to be 2 apart, more than b + 2 (l + r) = 1.35; with b = 2, at most 2 (l + r) + a = 0.96 apart.
    path = write(tmp_path, text)
    message = assert_user_error(*run(capsys, "ik", "0.2", "0.21", "0", "--params", path))
    assert "cannot be assembled" in message


@pytest.mark.parametrize(
    ("text", "error_type"),
    [
        ("mass_ll = 0.5\n", "FileFormatError"),
        ("l = -0.1\n", "InvalidParameterError"),
        ("l = [0.25,\n", "FileFormatError"),
    ],
)
def test_params_error_json(capsys, tmp_path, text, error_type):
    path = write(tmp_path, text)
    code, out, err = run(capsys, "fk", "1.6", "2.0", "-1.2", "--params", path, "--json")
    assert code == 1
    assert err == ""
    error = json.loads(out)["error"]
    assert set(error) == {"type", "message"}
    assert error["type"] == error_type
    assert error["message"] and "\n" not in error["message"]


def test_missing_params_file_json(capsys, tmp_path):
    code, out, err = run(capsys, "ik", "0.2", "0.21", "0", "--params", tmp_path / "none.toml", "--json")
    assert code == 1 and err == ""
    error = json.loads(out)["error"]
    assert error["type"] == "FileFormatError"
    assert "none.toml" in error["message"]


@pytest.mark.parametrize(
    "argv",
    [
        ["ik", "0.1"],
        ["ik", "0.1", "0.2"],
        ["ik", "a", "0.2", "0"],
        ["ik", "0.2", "0.21", "0", "--mode", "+", "-"],
        ["fk", "1", "2"],
        ["ik", "0.2", "0.21", "0", "--bogus"],
        ["demo", "--resolution", "many"],
        ["teleport"],
        [],
    ],
)
def test_malformed_command_line_exits_2(capsys, argv):
    with pytest.raises(SystemExit) as info:
        main(argv)
    assert info.value.code == 2
    out, err = capsys.readouterr()
    assert out == ""
    assert "usage:" in err
    assert "Traceback" not in err


def test_help_exits_0(capsys):
    with pytest.raises(SystemExit) as info:
        main(["ik", "--help"])
    assert info.value.code == 0
    assert "--mode" in capsys.readouterr().out


# ------------------------------------------------------------------ --params changes the answer
def test_params_nested_format_with_per_leg_lengths(capsys, tmp_path):
    path = write(tmp_path, '[manipulator]\npreset = "paper"\n\n[manipulator.params]\nl = [0.25, 0.25, 0.26]\n'
                           "a = 0.12\n")
    geometry = Geometry(l=(0.25, 0.25, 0.26), a=0.12)
    pose = (0.2, 0.21, 0.0)
    custom = ik_solutions(capsys, pose, "--params", path)
    paper = {tuple(s["mode"]): s for s in ik_solutions(capsys, pose)}
    assert len(custom) == 8
    for sol in custom:
        assert_solution_at_pose(geometry, sol, pose)
        # The platform is smaller, so every leg moves.
        default = paper[tuple(sol["mode"])]
        assert np.all(np.abs(wrap(np.subtract(sol["theta"], default["theta"]))) > 1e-4)


def test_params_flat_format_with_one_longer_leg(capsys, tmp_path):
    path = write(tmp_path, "l = [0.25, 0.25, 0.26]\n")
    geometry = Geometry(l=(0.25, 0.25, 0.26))
    pose = (0.25, 0.16, -0.1)
    custom = {tuple(s["mode"]): s for s in ik_solutions(capsys, pose, "--params", path)}
    paper = {tuple(s["mode"]): s for s in ik_solutions(capsys, pose)}
    assert set(custom) == ALL_MODES
    for mode, sol in custom.items():
        assert_solution_at_pose(geometry, sol, pose)
        # Only leg 3 changed: legs 1 and 2 keep their angles, leg 3 does not.
        np.testing.assert_allclose(sol["theta"][:2], paper[mode]["theta"][:2], rtol=0, atol=1e-12)
        np.testing.assert_allclose(sol["passive"][:2], paper[mode]["passive"][:2], rtol=0, atol=1e-12)
        assert abs(wrap(sol["theta"][2] - paper[mode]["theta"][2])) > 1e-4
        assert abs(wrap(sol["passive"][2] - paper[mode]["passive"][2])) > 1e-4


def test_params_flat_format_base_and_passive_lengths(capsys, tmp_path):
    path = write(tmp_path, "b = 0.5\nr = [0.16, 0.17, 0.18]\n# a comment\n")
    geometry = Geometry(b=0.5, r=(0.16, 0.17, 0.18))
    pose = (0.24, 0.15, 0.1)
    assert geometry.unreachable_legs(pose) == set()
    solutions = ik_solutions(capsys, pose, "--params", path)
    assert len(solutions) == 8
    for sol in solutions:
        assert_solution_at_pose(geometry, sol, pose)
    # Forward kinematics reads the same file.
    theta = solutions[0]["theta"]
    fk = fk_solutions(capsys, theta, "--params", path)
    for sol in fk:
        assert_closes_loops(geometry, theta, sol)
    assert min(abs(s["pose"][0] - pose[0]) + abs(s["pose"][1] - pose[1]) + abs(wrap(s["pose"][2] - pose[2]))
               for s in fk) < 1e-9


def test_params_preset_only_is_the_paper(capsys, tmp_path):
    path = write(tmp_path, '[manipulator]\npreset = "paper"\n')
    pose = (0.2, 0.21, 0.0)
    assert ik_solutions(capsys, pose, "--params", path) == ik_solutions(capsys, pose)


def test_params_makes_a_reachable_pose_unreachable(capsys, tmp_path):
    # Shorter legs: (0.2, 0.21, 0) needs |p2 - b2| = 0.31 m, more than l + r = 0.2 + 0.1.
    path = write(tmp_path, "l = 0.2\nr = 0.1\n")
    geometry = Geometry(l=(0.2,) * 3, r=(0.1,) * 3)
    assert geometry.unreachable_legs((0.2, 0.21, 0.0)) == {2}
    message = assert_user_error(*run(capsys, "ik", "0.2", "0.21", "0", "--params", path))
    assert named_legs(message) == {2} and "leg 2" in message
    assert "leg 1" not in message and "leg 3" not in message


# ------------------------------------------------------------------ demo
def test_demo_writes_the_singularity_map(capsys, tmp_path):
    out_dir = tmp_path / "figures" / "nested"
    code, out, err = run(capsys, "demo", "--out", out_dir, "--resolution", "21")
    assert code == 0, err
    figure = out_dir / "fig03_singularity_map.png"
    assert figure.is_file()
    data = figure.read_bytes()
    assert len(data) > 1000
    assert data.startswith(PNG_SIGNATURE)
    assert "working mode" in out
    assert str(figure) in out
    # No temporary file is left behind; the manifest says pkmlab wrote the folder.
    assert sorted(p.name for p in out_dir.iterdir()) == ["fig03_singularity_map.png", "pkmlab-manifest.json"]
    assert sorted(p.name for p in out_dir.parent.iterdir()) == ["nested"]


def test_demo_json_is_machine_readable(capsys, tmp_path):
    result = run_json(capsys, "demo", "--out", tmp_path, "--resolution", "5")
    assert set(result) == {"working_mode", "figure"}
    assert tuple(result["working_mode"]) in ALL_MODES
    assert Path(result["figure"]) == tmp_path / "fig03_singularity_map.png"
    assert Path(result["figure"]).read_bytes().startswith(PNG_SIGNATURE)


def test_demo_unwritable_output_folder_is_a_user_error(capsys, tmp_path):
    blocker = tmp_path / "a_file"
    blocker.write_text("not a folder")
    message = assert_user_error(*run(capsys, "demo", "--out", blocker / "figs", "--resolution", "5"))
    assert "a_file" in message


def test_demo_invalid_resolution_is_a_user_error(capsys, tmp_path):
    code, out, err = run(capsys, "demo", "--out", tmp_path, "--resolution", "1")
    assert code == 1
    assert "Traceback" not in err
    assert len(err.strip().splitlines()) == 1
    assert "resolution" in err
    assert not (tmp_path / "fig03_singularity_map.png").exists()


# ------------------------------------------------------------------ the installed console script
def run_script(*argv) -> subprocess.CompletedProcess:
    return subprocess.run([str(SCRIPT), *map(str, argv)], capture_output=True, text=True, timeout=600, check=False)


def test_console_script_ik_json(capsys):
    assert SCRIPT.is_file()
    proc = run_script("ik", "0.2", "0.21", "-0.05", "--json")
    assert proc.returncode == 0, proc.stderr
    assert proc.stderr == ""
    solutions = json.loads(proc.stdout)["solutions"]
    assert {tuple(s["mode"]) for s in solutions} == ALL_MODES
    for sol in solutions:
        assert_solution_at_pose(PAPER, sol, (0.2, 0.21, -0.05))
    assert solutions == ik_solutions(capsys, (0.2, 0.21, -0.05))


def test_console_script_user_error_and_usage_error():
    proc = run_script("ik", "0.09", "0.06", "0")
    assert proc.returncode == 1
    assert proc.stdout == ""
    assert "Traceback" not in proc.stderr
    lines = proc.stderr.strip().splitlines()
    assert len(lines) == 1
    assert lines[0].startswith("pkmlab ik")
    assert "leg 1" in lines[0]

    proc = run_script("ik", "0.1")
    assert proc.returncode == 2
    assert "usage:" in proc.stderr
