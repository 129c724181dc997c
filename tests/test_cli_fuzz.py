"""The command line fuzzed the way a careless user types: every answer is a result, a one-line
error (exit 1) or a usage error (exit 2) — never a traceback, never NaN in JSON, never a file
written where it was not asked for, never a user's file touched.

Also the consistency classes of errors: the same working mode and the same file accepted
everywhere, encodings refused for the right reason.
"""

import json

import pytest
from conftest import assert_user_error, run
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import pkmlab
import pkmlab.report
import pkmlab.simulation.run
from pkmlab.cli import main
from pkmlab.paper import kinematics as kin
from pkmlab.paper.geometry import Planar3RRR

TRIED = {"argv": 0}

NUMBERS = st.one_of(
    st.floats(-4, 4, allow_nan=False).map(lambda v: f"{v:.6g}"),
    st.sampled_from(["nan", "inf", "-inf", "1e308", "-1e-320", "0", "-0", "1e200", "0x10", "1,5", "", "+", "-",
                     "++", "--", "+-+", "ü", "3.0.1", "1e", "NaN", "Infinity"]),
)


def _argv(draw, folder):
    command = draw(st.sampled_from(["ik", "fk", "dynamics", "singularity-map", "workspace", "animate", "demo",
                                    "simulate", "reproduce"]))
    files = {"params": folder / "params.toml", "scenario": folder / "s.toml", "bad": folder / "bad.toml",
             "missing": folder / "missing.toml", "dir": folder, "user": folder / "user" / "thesis.txt"}
    argv = [command]
    positional = {"ik": 3, "fk": 3, "dynamics": 3}.get(command, 0)
    argv += [draw(NUMBERS) for _ in range(draw(st.sampled_from([positional, positional, max(positional - 1, 0),
                                                                 positional + 1])))]
    if command == "simulate":
        argv.append(str(draw(st.sampled_from([files["bad"], files["missing"], files["dir"], files["params"]]))))
    if command == "animate":
        argv.append(str(draw(st.sampled_from([files["dir"], files["missing"], folder / "user"]))))
    for _ in range(draw(st.integers(0, 3))):
        option = draw(st.sampled_from(["--mode", "--theta-dot", "--near", "--alpha", "--resolution", "--x-range",
                                       "--params", "--json", "--out", "--csv", "--stride", "--fps", "--quiet",
                                       "--control", "--no-figures", "--case"]))
        argv.append(option)
        if option == "--mode":
            argv += draw(st.sampled_from([["+", "-", "+"], ["+-+"], ["1", "-1", "1"], ["x"], ["+", "+"], ["-+-"]]))
        elif option in ("--theta-dot", "--near"):
            argv += [draw(NUMBERS) for _ in range(3)]
        elif option in ("--x-range",):
            argv += [draw(NUMBERS) for _ in range(2)]
        elif option in ("--alpha",):
            argv.append(draw(NUMBERS))
        elif option in ("--resolution", "--stride", "--fps"):
            argv.append(draw(st.sampled_from(["2", "5", "0", "-3", "x", "1e3", "9"])))
        elif option == "--params":
            argv.append(str(draw(st.sampled_from([files["params"], files["bad"], files["missing"], files["dir"]]))))
        elif option in ("--out", "--csv"):
            argv.append(str(draw(st.sampled_from([folder / "new" / "o.png", folder / "user", files["user"],
                                                  folder / "o.csv", folder / "o.gif", files["params"]]))))
        elif option == "--control":
            argv.append(draw(st.sampled_from(["sampled", "continuous", "fast"])))
        elif option == "--case":
            argv.append(draw(st.sampled_from(["nominal", "../x", "run"])))
    return argv


@pytest.fixture(scope="module")
def playground(tmp_path_factory):
    folder = tmp_path_factory.mktemp("fuzz")
    (folder / "params.toml").write_text('[manipulator]\npreset = "paper"\n[manipulator.params]\nl = 0.26\n')
    (folder / "bad.toml").write_text("l = [0.25, nan\n")
    (folder / "user").mkdir()
    (folder / "user" / "thesis.txt").write_text("years of work")
    return folder


def _files(folder):
    return {p: p.read_bytes() for p in folder.rglob("*") if p.is_file()}


@settings(max_examples=250, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture,
                                                                   HealthCheck.too_slow])
@given(data=st.data())
def test_fuzz_the_command_line(data, playground, capsys, monkeypatch, warnings_on_stderr):
    # a fuzzed `reproduce` or `simulate` that is valid would run for seconds: stop it at the simulation
    def no_simulation(*_args, **_kwargs):
        raise pkmlab.PkmlabError("(fuzz: simulation skipped)")

    monkeypatch.setattr(pkmlab.report, "run_cases", no_simulation)
    monkeypatch.setattr(pkmlab.simulation.run, "simulate", no_simulation)
    monkeypatch.chdir(playground)  # default output folders (demo, out) land here
    argv = _argv(data.draw, playground)
    TRIED["argv"] += 1
    user_before = (playground / "user" / "thesis.txt").read_bytes()
    try:
        code = main(argv)
    except SystemExit as exc:  # argparse: a malformed command line
        code = exc.code
    out, err = capsys.readouterr()
    assert "Traceback" not in err, (argv, err)
    assert "Warning:" not in err, (argv, err)  # no library's warning text: pkmlab's own words only
    assert code in (0, 1, 2), (argv, code, err)
    if code == 1:
        if "--json" in argv:
            json.loads(out, parse_constant=lambda c: pytest.fail(f"{argv}: {c} in JSON"))
        else:
            assert_user_error(code, out, err)
    if code == 0 and "--json" in argv:
        json.loads(out, parse_constant=lambda c: pytest.fail(f"{argv}: {c} in JSON"))
    assert (playground / "user" / "thesis.txt").read_bytes() == user_before
    assert sorted(p.name for p in (playground / "user").iterdir()) == ["thesis.txt"]
    assert not [p for p in playground.rglob(".*tmp*")], argv  # no temporary file left behind
    assert not (playground / "out").exists()  # reproduce never ran: nothing written


def test_zz_report_how_many_command_lines_were_tried():
    print(f"\ncommand-line fuzzer: {TRIED['argv']} command lines")
    assert TRIED["argv"] == 0 or TRIED["argv"] >= 200  # 0 when this test is run alone


# ------------------------------------------------------------------ one spelling, everywhere
@pytest.mark.parametrize("spelling", [["+", "-", "+"], ["+-+"], ["1", "-1", "1"], ["+1", "-1", "+1"]])
def test_a_working_mode_is_read_the_same_by_every_command_and_the_api(capsys, spelling):
    """`--mode` takes the spellings `inverse_kinematics(mode=...)` takes."""
    api = kin.inverse_kinematics(Planar3RRR.paper(), [0.2, 0.21, 0.0], mode="+-+")
    code, out, _err = run(capsys, "ik", 0.2, 0.21, 0, "--mode", *spelling, "--json")
    assert code == 0
    solution = json.loads(out)["solutions"][0]
    assert solution["mode"] == [1, -1, 1] and solution["theta"] == api.theta.tolist()


def test_a_working_mode_starting_with_a_minus_is_a_value_not_an_option(capsys, tmp_path):
    code, out, _err = run(capsys, "singularity-map", "--mode", "-+-", "--resolution", 5, "--out", tmp_path / "m.png",
                          "--json")
    assert code == 0 and json.loads(out)["mode"] == [-1, 1, -1]


def test_a_bad_working_mode_names_the_option(capsys):
    message = assert_user_error(*run(capsys, "ik", 0.2, 0.21, 0, "--mode", "+", "x", "+"))
    assert "--mode" in message and "working mode" in message


def test_scenario_working_mode_takes_the_same_spellings(tmp_path):
    from pkmlab.formats.scenario import load_scenario

    for written, expected in [('"+-+"', (1, -1, 1)), ("[1, -1, 1]", (1, -1, 1)), ('["-", "+", "-"]', (-1, 1, -1))]:
        path = tmp_path / "s.toml"
        path.write_text('[trajectory]\ntype = "circle"\ncenter = [0.25, 0.21]\nradius = 0.05\nspeed = 0.2\n'
                        f"[simulation]\nworking_mode = {written}\n")
        assert tuple(load_scenario(path).working_mode) == expected


# ------------------------------------------------------------------ encodings: the right reason
def test_a_utf8_byte_order_mark_is_accepted(capsys, tmp_path):
    path = tmp_path / "bom.toml"
    path.write_bytes(b"\xef\xbb\xbfl = 0.26\n")
    code, out, _err = run(capsys, "ik", 0.2, 0.21, 0, "--params", path, "--json")
    assert code == 0 and json.loads(out)["solutions"]


@pytest.mark.parametrize("content, reason", [
    ("l = 0.25 # café\n".encode("latin-1"), "not UTF-8 text (byte 0xe9 at line 1)"),
    ("a = 0.125\nl = 0.25 # café\n".encode("latin-1"), "at line 2"),
    ("l = 0.25\n".encode("utf-16"), "UTF-16"),
])
def test_another_encoding_is_refused_for_that_reason(capsys, tmp_path, content, reason):
    path = tmp_path / "p.toml"
    path.write_bytes(content)
    message = assert_user_error(*run(capsys, "ik", 0.2, 0.21, 0, "--params", path))
    assert reason in message and "malformed" not in message



# ------------------------------------------------------------------ two keys, one of them silently ignored
def test_b_and_base_points_together_are_refused_everywhere(capsys, tmp_path):
    path = tmp_path / "both.toml"
    path.write_text("b = 0.6\nbase_points = [[0, 0], [0.52, 0], [0.26, 0.45]]\n")
    message = assert_user_error(*run(capsys, "ik", 0.2, 0.21, 0, "--params", path))
    assert "both.toml" in message and "not both" in message
    with pytest.raises(pkmlab.InvalidParameterError, match="not both"):
        Planar3RRR.from_params(b=0.6, base_points=[[0, 0], [0.52, 0], [0.26, 0.45]])


def test_substeps_with_continuous_time_control_is_refused(capsys, tmp_path):
    path = tmp_path / "s.toml"
    path.write_text('[trajectory]\ntype = "circle"\ncenter = [0.25, 0.21]\nradius = 0.05\nspeed = 0.2\n'
                    "[controller]\nsample_time = 0\n[simulation]\nsubsteps = 4\n")
    out = tmp_path / "out"
    message = assert_user_error(*run(capsys, "simulate", path, "--out", out))
    assert "[simulation].substeps" in message and "sample_time" in message and not out.exists()


def test_a_non_finite_number_beyond_the_expected_count_is_named(capsys):
    """Found by the fuzzer: `ik 0 0 0 nan` once failed with an IndexError while naming the argument."""
    message = assert_user_error(*run(capsys, "ik", 0, 0, 0, "nan"))
    assert "must be finite" in message


# ------------------------------------------------------------------ no library's warning reaches the user
@pytest.fixture
def warnings_on_stderr(monkeypatch):
    """Warnings shown on stderr, as outside pytest (which records them instead)."""
    import sys
    import warnings

    def show(message, category, filename, lineno, file=None, line=None):
        sys.stderr.write(warnings.formatwarning(message, category, filename, lineno, line))

    monkeypatch.setattr(warnings, "showwarning", show)


def _scenario_with(tmp_path, old: str, new: str):
    from pkmlab.formats.scenario import SCENARIO_DIR

    path = tmp_path / "s.toml"
    path.write_text((SCENARIO_DIR / "nominal.toml").read_text().replace(old, new, 1))
    return path


def test_a_gain_near_the_float_range_gets_its_error_alone(capsys, tmp_path, warnings_on_stderr):
    """kp = 1e300 printed NumPy's "overflow encountered in multiply" before the (right) error."""
    out = tmp_path / "out"
    message = assert_user_error(*run(capsys, "simulate", _scenario_with(tmp_path, "kp = 1000.0", "kp = 1e300"),
                                     "--out", out))
    assert "unstable" in message and "kp = 1e+300" in message and not out.exists()


def test_a_description_number_near_the_float_range_is_refused_by_name(capsys, tmp_path, warnings_on_stderr):
    """base = [1e300, 0] printed NumPy's overflow warning, then blamed the legs' reach on a grid up to 1e300 m."""
    from pkmlab.description.mechanism import planar_mechanism_to_toml
    from pkmlab.description.presets import preset

    path = tmp_path / "far.toml"
    path.write_text(planar_mechanism_to_toml(preset("3rpr")).replace("base = [0.0, 0.0]", "base = [1e300, 0.0]", 1))
    assert "1e300" in path.read_text()
    message = assert_user_error(*run(capsys, "ik", 0.25, 0.2, 0, "--mechanism", path))
    assert "leg 1: base[0] = 1e+300 is beyond any machine" in message


def test_a_library_warning_is_dropped_before_an_error_and_said_as_a_note_otherwise(capsys, monkeypatch,
                                                                                  warnings_on_stderr):
    """Whatever library warns on the way: a failing command says its own error alone, a succeeding one says the
    warning in one pkmlab note line (never Python's two-line warning text)."""
    import warnings

    import pkmlab.algorithms.kinematics as kinematics

    solve = kinematics.inverse_kinematics

    def warning_then(fail):
        def inverse_kinematics(*args, **kwargs):
            warnings.warn("overflow encountered in multiply", RuntimeWarning, stacklevel=1)
            if fail:
                raise pkmlab.InvalidParameterError("pose: the true reason")
            return solve(*args, **kwargs)
        return inverse_kinematics

    monkeypatch.setattr(kinematics, "inverse_kinematics", warning_then(fail=True))
    assert assert_user_error(*run(capsys, "ik", 0.2, 0.21, 0)) == "pkmlab ik: error: pose: the true reason"
    monkeypatch.setattr(kinematics, "inverse_kinematics", warning_then(fail=False))
    code, out, err = run(capsys, "ik", 0.2, 0.21, 0)
    assert code == 0 and out
    lines = err.strip("\n").split("\n")
    note = "pkmlab ik: note: a computation warned on the way (RuntimeWarning"
    assert len(lines) == 1 and lines[0].startswith(note), err


@pytest.mark.parametrize("command", ["singularity-map", "workspace"])
def test_an_orientation_for_a_machine_without_one_is_refused(capsys, tmp_path, command):
    """`singularity-map --mechanism five_bar --alpha 0.3` reported "S at alpha = 0.3 rad" for a point platform."""
    out = tmp_path / "map.png"
    message = assert_user_error(*run(capsys, command, "--mechanism", "five_bar", "--alpha", 0.3, "--out", out))
    assert "--alpha" in message and "no orientation" in message and not out.exists()
