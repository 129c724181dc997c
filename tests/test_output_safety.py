"""Nothing lost, nothing silently wrong: output folders, provenance, refusals that tell the truth.

Each test names the promise it backs (the documentation's pages on output folders and exit codes, the command
line's output, scenario files, parameter files, getting started: :data:`PROMISES`) or the failure it guards against.
"""

import json
import os
import random
import re
import signal
import subprocess
import sys
import textwrap
import time
import warnings
from pathlib import Path

import numpy as np
import pytest
from conftest import assert_user_error, run
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import pkmlab
import pkmlab.report
from pkmlab import outputs
from pkmlab.formats.params import load_manipulator
from pkmlab.formats.scenario import paper_scenario
from pkmlab.model.mechanism_model import MechanismModel
from pkmlab.paper import kinematics as kin
from pkmlab.paper.geometry import Planar3RRR
from pkmlab.simulation.run import simulate

ROOT = Path(__file__).resolve().parent.parent
EXAMPLES = ROOT / "examples"
MANIFEST = "pkmlab-manifest.json"


def snapshot(folder: Path) -> dict:
    """Every file under ``folder`` (relative path -> bytes), hidden ones included."""
    return {p.relative_to(folder).as_posix(): p.read_bytes() for p in sorted(folder.rglob("*")) if p.is_file()}


def user_folder(folder: Path) -> dict:
    """A folder of a user's files: a notebook, notes, data in a subfolder, and a summary.json of their own."""
    (folder / "data").mkdir(parents=True)
    (folder / "analysis.ipynb").write_text('{"cells": []}')
    (folder / "notes.md").write_text("thesis notes\n")
    (folder / "data" / "measured.csv").write_text("t,x\n0,1\n")
    (folder / "summary.json").write_text("{}")
    return snapshot(folder)


def hidden(folder: Path) -> list[str]:
    return sorted(p.name for p in folder.iterdir() if p.name.startswith("."))


@pytest.fixture(scope="module")
def results():
    """The paper's three cases, simulated once for the tests that only write them."""
    return {name: simulate(paper_scenario(name)) for name in ("nominal", "disturbed", "fast")}


@pytest.mark.parametrize("writer", ["to_csv", "to_json"])
def test_a_result_written_into_a_missing_folder_makes_no_folder(results, tmp_path, writer):
    """A library writer makes no folder its caller did not ask for: a mistyped folder is refused by name."""
    missing = tmp_path / "no_such_folder"
    expected = "^" + re.escape(f"cannot write {missing / 'run.x'}: there is no folder ")
    with pytest.raises(outputs.OutputFileError, match=expected):
        getattr(results["nominal"], writer)(missing / "run.x")
    assert not missing.exists()


@pytest.mark.parametrize("writer", ["to_csv", "to_json"])
def test_a_result_written_onto_a_folder_is_refused_by_its_name(results, tmp_path, writer):
    """Not a raw IsADirectoryError naming a temporary file: pkmlab's error naming the caller's path, and the
    folder as it was."""
    folder = tmp_path / "a_folder"
    folder.mkdir()
    (folder / "mine.txt").write_text("keep me")
    with pytest.raises(outputs.OutputFileError, match="^" + re.escape(f"cannot write {folder}: it is a folder")):
        getattr(results["nominal"], writer)(folder)
    assert sorted(p.name for p in folder.iterdir()) == ["mine.txt"] and hidden(tmp_path) == []


@pytest.fixture
def quick(monkeypatch, results):
    """pkmlab reproduce/simulate with the simulation replaced by the precomputed results."""
    monkeypatch.setattr(pkmlab.report, "run_cases", lambda scenarios: {name: results[s.name]
                                                                        for name, s in scenarios.items()})
    monkeypatch.setattr(pkmlab.simulation.run, "simulate", lambda scenario: results["fast"])


# ------------------------------------------------------------------ a user's files are never deleted
@pytest.mark.parametrize("command", [
    ["simulate", EXAMPLES / "fast.toml", "--no-figures"],
    ["reproduce", "--no-figures"],
    ["demo", "--resolution", 5],
])
def test_promise_a_folder_holding_anything_else_is_refused_never_deleted(capsys, tmp_path, quick, command):
    """Scenario files: "a folder holding anything else is refused, never deleted" — even one with a summary.json."""
    out = tmp_path / "results"
    before = user_folder(out)
    message = assert_user_error(*run(capsys, *command, "--out", out))
    assert "pkmlab did not write" in message and str(out) in message
    assert snapshot(out) == before
    assert hidden(tmp_path) == []


def test_an_earlier_result_with_a_file_added_or_changed_is_refused(capsys, tmp_path, quick):
    out = tmp_path / "r"
    argv = ["simulate", EXAMPLES / "fast.toml", "--out", out, "--no-figures", "--quiet"]
    assert run(capsys, *argv)[0] == 0
    (out / "my_notes.txt").write_text("mine")
    before = snapshot(out)
    assert "my_notes.txt" in assert_user_error(*run(capsys, *argv))
    assert snapshot(out) == before
    (out / "my_notes.txt").unlink()
    with open(out / "REPORT.md", "a") as f:
        f.write("\nMy conclusions.\n")
    before = snapshot(out)
    assert "REPORT.md was changed" in assert_user_error(*run(capsys, *argv))
    assert snapshot(out) == before


def test_an_input_inside_the_output_folder_survives(capsys, tmp_path, quick):
    """`pkmlab simulate D/my_scenario.toml --out D` must not delete its own input."""
    folder = tmp_path / "D"
    folder.mkdir()
    scenario = folder / "my_scenario.toml"
    scenario.write_bytes((EXAMPLES / "fast.toml").read_bytes())
    before = snapshot(folder)
    message = assert_user_error(*run(capsys, "simulate", scenario, "--out", folder))
    assert "my_scenario.toml" in message
    assert snapshot(folder) == before
    # the same for a parameter file of pkmlab reproduce
    params = folder / "params.toml"
    params.write_text('[manipulator]\npreset = "paper"\n')
    before = snapshot(folder)
    assert "params.toml" in assert_user_error(*run(capsys, "reproduce", "--params", params, "--out", folder))
    assert snapshot(folder) == before


def test_an_input_inside_an_earlier_result_survives(capsys, tmp_path, quick):
    out = tmp_path / "r"
    assert run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", out, "--quiet")[0] == 0
    # pkmlab's own copy of the scenario, run again into the folder that holds it
    before = snapshot(out)
    assert "scenario.toml" in assert_user_error(*run(capsys, "simulate", out / "scenario.toml", "--out", out))
    assert snapshot(out) == before


def test_results_of_another_command_are_not_replaced(capsys, tmp_path, quick):
    out = tmp_path / "out"
    assert run(capsys, "reproduce", "--out", out, "--no-figures", "--quiet")[0] == 0
    before = snapshot(out)
    message = assert_user_error(*run(capsys, "demo", "--out", out, "--resolution", 5))
    assert "pkmlab reproduce" in message
    message = assert_user_error(*run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", out))
    assert "pkmlab reproduce" in message
    assert snapshot(out) == before


def test_replacing_an_earlier_result_of_the_same_command_is_said(capsys, tmp_path, quick):
    """Output folders: an earlier result is replaced — not silently: a note names what it was."""
    out = tmp_path / "out"
    assert run(capsys, "reproduce", "--out", out, "--no-figures")[0] == 0
    code, _stdout, err = run(capsys, "reproduce", "--out", out, "--no-figures", "--control", "continuous")
    assert code == 0
    assert err.count("\n") == 1 and "note: replaced the earlier results" in err and "sampled control" in err
    assert outputs.read_manifest(out)["provenance"]["control"] == "continuous"
    assert run(capsys, "reproduce", "--out", out, "--no-figures", "--quiet")[2] == ""  # --quiet: no note


def test_a_symbolic_link_inside_a_result_is_not_followed_or_deleted(capsys, tmp_path, quick):
    out = tmp_path / "r"
    assert run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", out, "--quiet", "--no-figures")[0] == 0
    precious = tmp_path / "precious"
    precious.mkdir()
    (precious / "data.txt").write_text("keep me")
    (out / "link").symlink_to(precious)
    assert "link" in assert_user_error(*run(capsys, "simulate", EXAMPLES / "fast.toml", "--out", out))
    assert (precious / "data.txt").read_text() == "keep me" and (out / "link").is_symlink()


def test_read_manifest_checks_every_file(tmp_path):
    out = tmp_path / "r"
    with outputs.atomic_output_dir(out, "test", provenance={"k": 1}) as tmp:
        (tmp / "a.txt").write_text("a")
        (tmp / "sub").mkdir()
        (tmp / "sub" / "b.txt").write_text("b")
    manifest = outputs.read_manifest(out)
    assert set(manifest["files"]) == {"a.txt", "sub/b.txt"} and manifest["provenance"] == {"k": 1}
    (out / "sub" / "b.txt").unlink()
    with pytest.raises(outputs.OutputFolderError, match="sub/b.txt.*missing"):
        outputs.read_manifest(out)


# ------------------------------------------------------------------ kill -9: the old result or the new one
WRITER = textwrap.dedent("""
    import sys, time
    from pkmlab.outputs import atomic_output_dir
    out, tag = sys.argv[1], sys.argv[2]
    with atomic_output_dir(out, "test") as tmp:
        for i in range(40):
            (tmp / f"part{i:02d}.txt").write_text(tag * 1000)
            time.sleep(0.002)
    print("done", flush=True)
""")


def _is_complete(out: Path, tag: str) -> bool:
    outputs.read_manifest(out)  # raises unless every listed file is there, unchanged, and nothing else
    return all((out / f"part{i:02d}.txt").read_text() == tag * 1000 for i in range(40))


def test_kill_9_mid_write_leaves_the_old_result_or_the_new_one(tmp_path):
    """Killed at random moments while writing, a result folder is always a whole result."""
    out = tmp_path / "r"
    script = tmp_path / "writer.py"
    script.write_text(WRITER)
    env = {**os.environ, "PYTHONPATH": str(ROOT / "src")}
    subprocess.run([sys.executable, str(script), str(out), "A"], check=True, env=env, capture_output=True)
    rng = random.Random(1)
    outcomes = {"old": 0, "new": 0}
    current = "A"
    for attempt in range(12):
        new = "B" if current == "A" else "A"
        proc = subprocess.Popen([sys.executable, str(script), str(out), new], env=env, stdout=subprocess.PIPE)
        time.sleep(rng.uniform(0.05, 0.4))
        proc.send_signal(signal.SIGKILL)
        proc.wait()
        if _is_complete(out, new):
            outcomes["new"] += 1
            current = new
        else:
            assert _is_complete(out, current), f"attempt {attempt}: a mix of two results"
            outcomes["old"] += 1
    assert outcomes["old"] > 0  # the kills did land while writing
    # the next run into the same folder removes the temporary folders the killed runs left
    subprocess.run([sys.executable, str(script), str(out), "C"], check=True, env=env, capture_output=True)
    assert _is_complete(out, "C") and hidden(tmp_path) == []


def _files_being_written(folder: Path, pid: int) -> int:
    """How many files the temporary output folder in ``folder`` of the run of process ``pid`` holds (-1: it has
    none there yet)."""
    tmp = [p for p in folder.iterdir() if p.name.startswith(".") and f".pkmlab-tmp-{pid}-" in p.name]
    try:
        return sum(1 for t in tmp for p in t.rglob("*") if p.is_file()) if tmp else -1
    except OSError:  # (the folder renamed or removed while counted: the run has finished writing)
        return -1


def test_kill_9_of_a_real_simulation_keeps_the_earlier_result(tmp_path):
    """A run killed -9 while it writes its results (its temporary folder there, with none, three and eight of its
    thirteen files in it) leaves the earlier result as it was; one that finished before the kill left its whole
    result."""
    out = tmp_path / "r"
    argv = [sys.executable, "-m", "pkmlab.cli", "simulate", str(EXAMPLES / "fast.toml"), "--out", str(out)]
    subprocess.run(argv + ["--no-figures"], check=True, capture_output=True)
    before = snapshot(out)
    landed = 0
    for written in (0, 3, 8):
        proc = subprocess.Popen(argv, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        while proc.poll() is None and _files_being_written(tmp_path, proc.pid) < written:
            time.sleep(0.005)
        proc.send_signal(signal.SIGKILL)
        killed = proc.wait() == -signal.SIGKILL
        now = snapshot(out)
        if now != before:  # the new run had finished: then it is whole, with its figures
            outputs.read_manifest(out)
            assert "path.png" in now
            before = now
        landed += killed and now == before
    assert landed > 0  # at least one kill struck a run in progress, and the earlier result stood
    subprocess.run(argv, check=True, capture_output=True)  # the next run cleans up after the killed ones
    assert hidden(tmp_path) == [] and "path.png" in snapshot(out)


def test_without_an_atomic_exchange_the_two_step_swap_is_safe_too(tmp_path, monkeypatch):
    """Where the system cannot exchange two folders atomically, the old folder is moved aside first; a run
    killed between the two renames leaves it aside, and the next run puts it back before anything else."""
    monkeypatch.setattr(outputs, "_exchange", lambda a, b: False)
    out = tmp_path / "r"
    for tag in ("A", "B"):
        with outputs.atomic_output_dir(out, "test", note=lambda _m: None) as tmp:
            (tmp / "a.txt").write_text(tag)
        assert (out / "a.txt").read_text() == tag and hidden(tmp_path) == []
    # killed between the renames: the earlier result is aside under a temporary name, `out` is missing
    aside = tmp_path / ".r.pkmlab-tmp-999999999-old-x"
    os.rename(out, aside)
    notes = []
    with pytest.raises(outputs.OutputFolderError), outputs.atomic_output_dir(out, "other", note=notes.append):
        pass  # a run of another command: refused, since the earlier result is back in place
    assert (out / "a.txt").read_text() == "B" and "restored" in notes[0] and hidden(tmp_path) == []


# ------------------------------------------------------------------ reproduce --params is honoured
def test_reproduce_refuses_an_impossible_parameter_file_before_writing(capsys, tmp_path):
    params = tmp_path / "p.toml"
    params.write_text("a = 5\n")
    out = tmp_path / "out"
    assert_user_error(*run(capsys, "reproduce", "--params", params, "--out", out, "--no-figures"))
    assert not out.exists() and hidden(tmp_path) == []


def test_reproduce_with_params_runs_the_cases_on_that_machine_and_says_so(capsys, tmp_path):
    params = tmp_path / "mine.toml"
    params.write_text("[manipulator]\npreset = \"paper\"\n[manipulator.params]\nl = 0.26\nmass_a = 0.3\n")
    out = tmp_path / "out"
    code, stdout, _err = run(capsys, "reproduce", "--params", params, "--out", out, "--no-figures", "--json")
    assert code == 0
    summary = json.loads(stdout)
    assert summary["provenance"]["mechanism"].endswith("mine.toml")
    mine = load_manipulator(params)
    written = {name: pkmlab.load(out / f"{name}.toml") for name in ("mechanism", "nominal_plant", "disturbed_plant")}
    # the paper's 3-RRR with the file's numbers, and its plant of the disturbed case (conventions §7: masses and
    # lengths x1.15, inertias x1.15^3), in the paper's own formulation
    k = 1.15
    disturbed = mine.replace(active_lengths=mine.active_lengths * k, passive_lengths=mine.passive_lengths * k,
                             platform_side=mine.platform_side * k, active_masses=mine.active_masses * k,
                             passive_masses=mine.passive_masses * k, platform_mass=mine.platform_mass * k,
                             active_inertias=mine.active_inertias * k**3, passive_inertias=mine.passive_inertias * k**3,
                             platform_inertia=mine.platform_inertia * k**3)
    for name, machine in (("mechanism", mine), ("nominal_plant", mine), ("disturbed_plant", disturbed)):
        np.testing.assert_allclose(written[name].P, MechanismModel.from_3rrr(machine).P, rtol=1e-14, atol=1e-16)
    report = (out / "REPORT.md").read_text()
    assert "not the paper's numbers" in report and "mine.toml" in report
    # the numbers are those of the user's machine, not the paper's
    own = simulate(paper_scenario("nominal").replace(model=MechanismModel.from_3rrr(mine)))
    assert summary["cases"]["nominal"]["peak_torque_Nm"] == own.summary()["peak_torque_Nm"]
    assert summary["cases"]["nominal"]["peak_torque_Nm"] != simulate(paper_scenario("nominal")).summary()[
        "peak_torque_Nm"]


# ------------------------------------------------------------------ provenance
def test_results_record_how_they_were_made(capsys, tmp_path, quick):
    out = tmp_path / "continuous"
    assert run(capsys, "reproduce", "--out", out, "--control", "continuous", "--no-figures", "--quiet")[0] == 0
    summary = json.loads((out / "summary.json").read_text())
    prov = summary["provenance"]
    assert prov["control"] == "continuous" and prov["sample_time_s"] is None
    assert prov["pkmlab_version"] == pkmlab.__version__ and prov["mechanism"] == "the paper's (its section 5)"
    report = (out / "REPORT.md").read_text()
    assert "continuous-time" in report and f"pkmlab {pkmlab.__version__}" in report
    manifest = outputs.read_manifest(out)
    assert manifest["command"] == "reproduce" and manifest["provenance"] == prov
    assert pkmlab.load(out / "mechanism.toml") == pkmlab.load("paper")


# ------------------------------------------------------------------ dynamics at a singularity
def _singular_configuration():
    """A configuration of the paper's machine at a gain-type singularity, by bisection on alpha:
    S changes sign between alpha = -2.87 and -2.86 at (0.25, 0.21) in working mode (-, +, -)."""
    model, mode = Planar3RRR.paper(), (-1, 1, -1)

    def s(alpha):
        return float(kin.inverse_kinematics(model, [0.25, 0.21, alpha], mode=mode).S)

    lo, hi = -2.875, -2.86
    assert s(lo) * s(hi) < 0
    for _ in range(60):
        mid = 0.5 * (lo + hi)
        lo, hi = (mid, hi) if s(mid) * s(lo) > 0 else (lo, mid)
    pose = [0.25, 0.21, 0.5 * (lo + hi)]
    return pose, kin.inverse_kinematics(model, pose, mode=mode)


def _near_singular(offset):
    pose, _ik = _singular_configuration()
    near = [pose[0], pose[1], pose[2] + offset]
    return near, kin.inverse_kinematics(Planar3RRR.paper(), near, mode=(-1, 1, -1))


@pytest.mark.parametrize("offset", [0.0, -1e-10, -1e-8])
def test_dynamics_at_a_singularity_is_refused(capsys, offset):
    """At S = 0, and where S is so small that M_theta ~ 1/S^2 means nothing (it printed 1e13 with exit 0)."""
    pose, ik = _near_singular(offset)
    assert abs(float(ik.S)) < 1e-7
    message = assert_user_error(*run(capsys, "dynamics", *ik.theta, "--near", *pose))
    assert "singularity" in message


def test_dynamics_near_a_singularity_warns(capsys):
    pose, ik = _near_singular(-1e-4)
    code, out, err = run(capsys, "dynamics", *ik.theta, "--near", *pose, "--json")
    assert code == 0
    (record,) = json.loads(out)["solutions"]
    assert abs(record["S"] - float(ik.S)) < 1e-9 and 1e-6 < abs(record["S"]) < 1e-2
    assert "near a gain-type singularity" in record["warning"] and "warning" in err


def test_dynamics_says_when_no_assembly_mode_is_near_the_pose_asked_for(capsys):
    theta = kin.inverse_kinematics(Planar3RRR.paper(), [0.2, 0.21, 0.0], mode=(-1, 1, -1)).theta
    code, _out, err = run(capsys, "dynamics", *theta, "--near", 0.2, 0.21, 0.0)
    assert code == 0 and err == ""
    code, _out, err = run(capsys, "dynamics", *theta, "--near", 0.3, 0.21, 0.0)
    assert code == 0 and "no assembly mode is within" in err and "(0.200000, 0.210000" in err


def _strict(text: str):
    def refuse(constant):
        raise ValueError(f"not JSON: {constant}")

    return json.loads(text, parse_constant=refuse)


@pytest.mark.parametrize("argv", [
    ["dynamics", 0.19, 3.11, -2.64, "--theta-dot", "1e200", 0, 0, "--json"],
    ["dynamics", 0.19, 3.11, -2.64, "--theta-dot", "nan", 0, 0, "--json"],
    ["ik", 0.09, 0.06, 0, "--json"],
])
def test_json_output_is_strict_json_even_for_errors(capsys, argv):
    code, out, err = run(capsys, *argv)
    assert code == 1 and err == ""
    error = _strict(out)["error"]
    assert "\n" not in error["message"]


def test_overflowing_dynamics_is_an_error_not_nan(capsys):
    message = assert_user_error(*run(capsys, "dynamics", 0.19, 3.11, -2.64, "--theta-dot", "1e200", 0, 0))
    assert "overflow" in message and "--theta-dot" in message


# ------------------------------------------------------------------ the command line itself
def test_version():
    proc = subprocess.run([sys.executable, "-m", "pkmlab.cli", "--version"], capture_output=True, text=True)
    assert proc.returncode == 0 and proc.stdout.strip() == f"pkmlab {pkmlab.__version__}"


def test_a_closed_pipe_ends_quietly():
    """`pkmlab fk ... --json | head -1`: no traceback when the reader goes away."""
    proc = subprocess.Popen([sys.executable, "-m", "pkmlab.cli", "fk", "0.189", "3.112", "-2.642", "--json"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    proc.stdout.close()  # the reader is gone before anything is written
    err = proc.stderr.read().decode()
    assert proc.wait() == 141
    assert "Traceback" not in err and "BrokenPipe" not in err and err == ""


def _in_pkmlab(traceback: str) -> bool:
    """Whether a traceback passes through pkmlab's own code (a frame in one of its files)."""
    package = str(Path(pkmlab.__file__).parent)
    return any(f.startswith(package) for f in re.findall(r'File "([^"]+)"', traceback))


def test_ctrl_c_during_start_up_is_no_traceback():
    """Ctrl-C while pkmlab starts (imports, loading or compiling its kernels, whose compiler calls back
    into Python) ends with exit code 130 and one line, never a traceback through pkmlab's code.

    The command is started as the executable starts it (``from pkmlab.cli import entry; sys.exit(entry())``), after
    a line on stdout once the interpreter has started and imported the ``pkmlab`` package (which defines names
    only): the delays count from there, so that a loaded machine's slow start-up does not move them (a fixed delay
    from the process's start once landed in the interpreter's own start-up). What Python does outside pkmlab's code
    is its own: a Ctrl-C while its import system looks for ``pkmlab.cli``'s file, or in the few instructions between
    that module's last line and ``entry()``'s try (the console script's, under Python's default handler), is a
    traceback that passes through no file of pkmlab's."""
    entry = ("import sys, pkmlab\nsys.stdout.write('started\\n')\nsys.stdout.flush()\n"
             "from pkmlab.cli import entry\nsys.argv[0] = 'pkmlab'\nsys.exit(entry())")
    # the kernels compiled (PKMLAB_INTERPRETED=0: fk would otherwise run them interpreted, in a fifth of a
    # second), then interpreted (Numba never imported: the whole start-up is Python's imports, about 50 ms)
    for interpreted, delays in (("0", (0.2, 0.4, 0.7, 1.1, 1.5)), ("1", (0.0, 0.01, 0.02, 0.04, 0.06))):
        env = {**os.environ, "PKMLAB_INTERPRETED": interpreted}
        codes = []
        for delay in delays:
            proc = subprocess.Popen([sys.executable, "-c", entry, "fk", "0.189", "3.112", "-2.642"],
                                    stdout=subprocess.PIPE, stderr=subprocess.PIPE, env=env)
            assert proc.stdout.readline() == b"started\n"
            time.sleep(delay)
            proc.send_signal(signal.SIGINT)
            _out, err = proc.communicate()
            err = err.decode()
            if "Traceback" in err and not _in_pkmlab(err) and err.endswith("KeyboardInterrupt\n"):
                continue  # Python's own moments (the docstring)
            assert "Traceback" not in err and "Exception ignored" not in err, (delay, err)
            assert proc.returncode in (0, 130), (delay, proc.returncode)
            if proc.returncode == 130:
                assert err.endswith("interrupted\n")
            codes.append(proc.returncode)
        assert 130 in codes, interpreted  # the signal did arrive during the start-up


def test_an_interrupt_python_reports_as_another_error_while_the_command_line_loads_is_the_interrupt():
    """Python reports a Ctrl-C inside a class's creation (``__set_name__``) as a RuntimeError caused by it: the
    command line's import guard takes it for the interrupt it is (exit 130, one line); an error not caused by one
    is raised as it is."""
    finder = textwrap.dedent("""
        import sys
        class Interrupted:  # raises, as Python does, the error an interrupt caused while pkmlab.cli._parser loads
            def find_spec(self, name, path=None, target=None):
                if name == "pkmlab.cli._parser":
                    try:
                        raise KeyboardInterrupt
                    except KeyboardInterrupt as exc:
                        if sys.argv[1] == "caused":
                            raise RuntimeError("Error calling __set_name__") from exc
                    raise RuntimeError("an error of its own")
        sys.meta_path.insert(0, Interrupted())
        import pkmlab.cli
        """)
    caused = subprocess.run([sys.executable, "-c", finder, "caused"], capture_output=True, text=True)
    assert (caused.returncode, caused.stderr) == (130, "pkmlab: interrupted\n")
    other = subprocess.run([sys.executable, "-c", finder, "other"], capture_output=True, text=True)
    assert other.returncode == 1 and other.stderr.strip().endswith("RuntimeError: an error of its own")


@pytest.mark.parametrize("moment", ["before main's own try", "while Ctrl-C is being ignored", "on SystemExit"])
def test_ctrl_c_between_the_executables_handler_and_main_is_no_traceback(monkeypatch, capsys, moment):
    """The executable's Ctrl-C handler raises at whichever instruction runs next: one that landed outside
    main()'s try — at main's first instruction, or once main had returned and before Ctrl-C was ignored — was a
    traceback (seen once in a test run, at the start-up test's 0.08 s). Made to happen: the real handler raising
    in a command with no try of its own (exit 130, one line); an interrupt at the instruction that ignores Ctrl-C
    after the command returned (its own exit code, nothing said); and a command ending by SystemExit (``--help``, a
    malformed command line) leaves Ctrl-C ignored too, as the interpreter shuts down."""
    import pkmlab.cli as cli

    set_handler, ignoring = signal.signal, []

    def main(**_kwargs):
        if moment == "before main's own try":
            signal.raise_signal(signal.SIGINT)  # the executable's handler raises here, outside any try of main's
        if moment == "on SystemExit":
            raise SystemExit(2)
        return 0

    def signal_once_interrupted(signum, handler):  # a Ctrl-C at the first attempt to ignore Ctrl-C
        if handler is signal.SIG_IGN and not ignoring:
            ignoring.append(True)
            raise KeyboardInterrupt
        return set_handler(signum, handler)

    monkeypatch.setattr(cli, "main", main)
    monkeypatch.setattr(cli, "_INTERRUPTED", False)  # (the real handler sets it: the process's later main() calls)
    monkeypatch.setattr(sys, "unraisablehook", sys.unraisablehook)
    if moment == "while Ctrl-C is being ignored":
        monkeypatch.setattr(signal, "signal", signal_once_interrupted)
    previous, timer = signal.getsignal(signal.SIGINT), signal.getitimer(signal.ITIMER_REAL)
    try:
        if moment == "on SystemExit":
            with pytest.raises(SystemExit) as exit_info:
                cli.entry()
            code = exit_info.value.code
        else:
            code = cli.entry()
        after = signal.getsignal(signal.SIGINT)
    finally:
        set_handler(signal.SIGINT, previous)
        signal.setitimer(signal.ITIMER_REAL, *timer)
    _out, err = capsys.readouterr()
    assert after is signal.SIG_IGN
    expected = {"before main's own try": (130, "pkmlab: interrupted\n"), "while Ctrl-C is being ignored": (0, ""),
                "on SystemExit": (2, "")}[moment]
    assert (code, err) == expected
    assert bool(ignoring) == (moment == "while Ctrl-C is being ignored")


@pytest.mark.parametrize("terminal", [True, False])
def test_first_run_says_it_compiles(capsys, monkeypatch, terminal):
    """The first run of a machine structure compiles for up to a minute: it is said once per process on stderr,
    on a terminal or not (a log, a pipe, a notebook), not by a run whose kernels are in the cache."""
    from pkmlab import _compile_cache
    from pkmlab.model import mechanism_model

    monkeypatch.setattr(mechanism_model, "_SPOKEN", set())
    monkeypatch.setattr(_compile_cache, "has_compiled", lambda name: False)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: terminal, raising=False)
    code, _out, err = run(capsys, "ik", 0.2, 0.21, 0, "--mode", "+", "+", "+")
    assert code == 0 and err.count("compiling") == 1 and err.startswith("pkmlab: paper: compiling"), err
    assert run(capsys, "ik", 0.2, 0.21, 0)[2] == ""  # once per process
    monkeypatch.setattr(mechanism_model, "_SPOKEN", set())
    monkeypatch.setattr(_compile_cache, "has_compiled", lambda name: True)
    assert run(capsys, "ik", 0.2, 0.21, 0)[2] == ""


def test_has_compiled_reads_the_kernel_cache(tmp_path, monkeypatch):
    from pkmlab import _compile_cache

    monkeypatch.setattr(_compile_cache, "CACHE_DIR", tmp_path)
    assert not _compile_cache.has_compiled("pkmlab.kernels.planar_RaRR_RaRR_RaRR_rigid")
    (tmp_path / "kernels_1f").mkdir()
    (tmp_path / "kernels_1f" / "planar_RaRR_RaRR_RaRR_rigid._ik-1.py311.nbi").write_bytes(b"")
    assert _compile_cache.has_compiled("pkmlab.kernels.planar_RaRR_RaRR_RaRR_rigid")
    assert not _compile_cache.has_compiled("pkmlab.kernels.planar_RaRR_RaRR_point")
    assert _compile_cache.has_compiled("pkmlab.kernels.planar_RaRR_RaRR_RaRR_rigid", "_ik")
    assert not _compile_cache.has_compiled("pkmlab.kernels.planar_RaRR_RaRR_RaRR_rigid", "_i")
    assert not _compile_cache.has_compiled("pkmlab.kernels.planar_RaRR_RaRR_RaRR_rigid", "sampled_data_chunk")


def test_a_new_cache_folder_removes_those_of_other_versions_unused_for_a_week(tmp_path, monkeypatch):
    """The first process of a new version of the sources removes the cache folders no process has used for
    STALE_AFTER_DAYS; one used since (by its marker, or its own time without one) and anything not a cache
    folder of pkmlab's stay."""
    from pkmlab import _compile_cache

    monkeypatch.setenv("PKMLAB_CACHE_DIR", str(tmp_path))
    old = time.time() - (_compile_cache.STALE_AFTER_DAYS + 1) * 86400
    recent = time.time() - (_compile_cache.STALE_AFTER_DAYS - 1) * 86400
    folders = {name: tmp_path / name for name in ("numba-old", "numba-unmarked", "numba-recent", "written")}
    for folder in folders.values():
        (folder / "kernels").mkdir(parents=True)
    os.utime(folders["numba-unmarked"], (old, old))
    os.utime(folders["written"], (old, old))
    for name, when in (("numba-old", old), ("numba-recent", recent)):
        (folders[name] / _compile_cache.LAST_USED).touch()
        os.utime(folders[name] / _compile_cache.LAST_USED, (when, when))
    os.utime(folders["numba-recent"], (old, old))  # its marker, not its own time, says when it was used

    cache = _compile_cache.cache_folder()
    assert sorted(p.name for p in tmp_path.iterdir()) == sorted(["numba-recent", "written", cache.name])
    assert (cache / _compile_cache.LAST_USED).exists()
    (tmp_path / "numba-old").mkdir()
    os.utime(tmp_path / "numba-old", (old, old))
    assert _compile_cache.cache_folder() == cache and (tmp_path / "numba-old").exists()  # not a new folder: kept


#: A process calling a small cached kernel (its folder the first argument), printing Numba's counts of cache
#: misses and hits and the value.
SMALL_KERNEL = ("import json, sys\nsys.path.insert(0, sys.argv[1])\nimport small_kernel\nvalue = small_kernel.f(0.5)\n"
                "stats = small_kernel.f.stats\n"
                "print(json.dumps([sum(stats.cache_misses.values()), sum(stats.cache_hits.values()), value]))")


def _small_kernel_process(folder: Path) -> tuple[list, str]:
    """Run :data:`SMALL_KERNEL` on the kernel cache ``folder / "cache"``: its counts and value, and its stderr."""
    if not (folder / "small_kernel.py").exists():
        (folder / "small_kernel.py").write_text("from pkmlab._compile_cache import njit\n\n\n@njit(cache=True)\n"
                                                "def f(x):\n    return 2.0 * x + 1.0\n")
    env = {**os.environ, "PKMLAB_CACHE_DIR": str(folder / "cache")}
    env.pop("PKMLAB_INTERPRETED", None)
    done = subprocess.run([sys.executable, "-c", SMALL_KERNEL, str(folder)], env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0 and "Traceback" not in done.stderr, done.stderr
    return json.loads(done.stdout), done.stderr


def _small_kernel_files(folder: Path) -> list[Path]:
    return sorted(p for p in (folder / "cache").rglob("small_kernel.*") if p.suffix in (".nbi", ".nbc"))


def test_a_kernel_cache_whose_files_are_cut_short_is_compiled_again_and_mended(tmp_path):
    """A cached kernel whose files were cut short (a full disk, a process killed while writing them): the next
    process compiles it again, silently, and saves it over them; the one after loads it."""
    assert _small_kernel_process(tmp_path) == ([1, 0, 2.0], "")
    files = _small_kernel_files(tmp_path)
    assert sorted(p.suffix for p in files) == [".nbc", ".nbi"]
    for path in files:
        path.write_bytes(path.read_bytes()[:len(path.read_bytes()) // 2])
    assert _small_kernel_process(tmp_path) == ([1, 0, 2.0], "")
    assert _small_kernel_process(tmp_path) == ([0, 1, 2.0], "")


def test_a_kernel_cache_that_cannot_be_written_is_said_in_one_line_and_the_run_goes_on(tmp_path):
    """Where a kernel's cache files cannot be written (here: a folder stands where its index goes, which no user,
    root either, can write over), the process compiles it, gives its value, and says once, in one line, what to do."""
    _small_kernel_process(tmp_path)
    files = _small_kernel_files(tmp_path)
    for path in files:
        path.unlink()
    next(p for p in files if p.suffix == ".nbi").mkdir()
    (counts, err) = _small_kernel_process(tmp_path)
    assert counts == [1, 0, 2.0]
    assert len(err.splitlines()) == 1 and "cannot write the kernel cache" in err and "PKMLAB_CACHE_DIR" in err, err


def test_a_cache_folder_that_cannot_be_written_gives_way_to_the_temporary_folders(tmp_path, monkeypatch):
    """A cache folder this process cannot write into (a read-only home, a folder under a file): the temporary
    folder's ``pkmlab-cache`` instead, with the same version's name."""
    from pkmlab import _compile_cache

    assert _compile_cache._writable(tmp_path / "new" / "cache")
    (tmp_path / "file").write_text("")
    assert not _compile_cache._writable(tmp_path / "file" / "cache")
    monkeypatch.setenv("PKMLAB_CACHE_DIR", str(tmp_path / "file" / "cache"))
    monkeypatch.setattr(_compile_cache.tempfile, "gettempdir", lambda: str(tmp_path / "temporary"))
    cache = _compile_cache.cache_folder()
    assert cache.parent == tmp_path / "temporary" / "pkmlab-cache" and cache.name.startswith("numba-")
    assert cache.is_dir() and (cache / _compile_cache.LAST_USED).exists()


def test_two_processes_reaching_one_function_at_once_compile_it_once(tmp_path):
    """Two processes started together on an empty cache, each calling the same cached kernel: one compiles it,
    the other waits for it and loads it from the cache (Numba's own counts of cache misses and hits), and both
    get its value."""
    body = "\n".join(f"    y = y * 0.999 + x * {k}.0 - (y * y) / (1.0 + {k}.0 * x * x)" for k in range(1, 300))
    (tmp_path / "slow_kernel.py").write_text("from pkmlab._compile_cache import njit\n\n\n@njit(cache=True)\n"
                                              f"def f(x):\n    y = x\n{body}\n    return y\n")
    # each process, once started, says so and waits for the other: both then call the kernel at the same moment
    code = ("import json, pathlib, sys, time\nsys.path.insert(0, sys.argv[1])\nimport slow_kernel\n"
            "folder = pathlib.Path(sys.argv[1])\n(folder / ('ready' + sys.argv[2])).touch()\n"
            "deadline = time.monotonic() + 120\n"
            "while len(list(folder.glob('ready*'))) < 2 and time.monotonic() < deadline:\n    time.sleep(0.001)\n"
            "value = slow_kernel.f(0.5)\nstats = slow_kernel.f.stats\n"
            "print(json.dumps([sum(stats.cache_misses.values()), sum(stats.cache_hits.values()), value]))")
    env = {**os.environ, "PKMLAB_CACHE_DIR": str(tmp_path / "cache")}
    env.pop("PKMLAB_INTERPRETED", None)
    processes = [subprocess.Popen([sys.executable, "-c", code, str(tmp_path), str(i)], env=env,
                                  stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) for i in range(2)]
    results = []
    for process in processes:
        out, err = process.communicate(timeout=600)
        assert process.returncode == 0, err
        results.append(json.loads(out))
    assert sorted(r[:2] for r in results) == [[0, 1], [1, 0]], results
    assert results[0][2] == results[1][2]


def test_every_non_finite_number_of_the_command_line_is_named(capsys):
    for argv, name in [(["dynamics", 0.19, 3.11, -2.64, "--near", 0.2, "inf", 0], "--near"),
                       (["ik", 0.2, 0.21, "nan"], "alpha"),
                       (["fk", "-inf", 3.11, -2.64], "theta1"), (["ik", "--mechanism", "five_bar", "nan", 0.3], "x")]:
        message = assert_user_error(*run(capsys, *argv))
        assert f"{name} must be finite" in message, message


def test_json_helper_never_writes_nan():
    from pkmlab.cli import _strict_json

    value = {"a": [1.0, float("nan")], "b": {"c": float("inf")}, "d": np.float64(2.0).item()}
    assert json.dumps(_strict_json(value), allow_nan=False) == '{"a": [1.0, null], "b": {"c": null}, "d": 2.0}'


def test_promise_refused_before_anything_is_computed(capsys, tmp_path, monkeypatch):
    """Output folders: "Anything else is refused, with exit code 1, before anything is computed"."""
    def must_not_run(*_args, **_kwargs):
        raise AssertionError("simulated although the output folder is refused")

    monkeypatch.setattr(pkmlab.simulation.run, "simulate", must_not_run)
    monkeypatch.setattr(pkmlab.report, "run_cases", must_not_run)
    out = tmp_path / "mine"
    before = user_folder(out)
    for argv in (["simulate", EXAMPLES / "fast.toml"], ["reproduce"]):
        assert_user_error(*run(capsys, *argv, "--out", out))
    assert snapshot(out) == before


# ------------------------------------------------------------------ every promise of the documentation has its test
#: The documentation's pages that promise (``docs/`` paths; a page that includes a reference page shipped with the
#: package, ``--8<-- "src/pkmlab/help/TOPIC.md"``, is read with it), each promise's text and the test that backs it.
OUTPUTS, CLI_OUTPUT = "reference/outputs.md", "reference/cli-output.md"
SCENARIO_FILES, PARAMETER_FILES = "reference/scenario-files.md", "reference/parameter-files.md"
PROMISES = {
    "a folder holding\nanything else is refused, never deleted":
        (SCENARIO_FILES, "test_promise_a_folder_holding_anything_else_is_refused_never_deleted"),
    "before anything is computed, and\nnothing is touched":
        (OUTPUTS, "test_promise_refused_before_anything_is_computed"),
    "a result in which you edited or added a file":
        (OUTPUTS, "test_an_earlier_result_with_a_file_added_or_changed_is_refused"),
    "a result of another command": (OUTPUTS, "test_results_of_another_command_are_not_replaced"),
    "a folder\nthat holds the run's own input file": (OUTPUTS, "test_an_input_inside_the_output_folder_survives"),
    "a note on stderr says what\nwas replaced":
        (OUTPUTS, "test_replacing_an_earlier_result_of_the_same_command_is_said"),
    "never a mix": (OUTPUTS, "test_kill_9_mid_write_leaves_the_old_result_or_the_new_one"),
    "removed by the next run into `DIR`": (OUTPUTS, "test_kill_9_mid_write_leaves_the_old_result_or_the_new_one"),
    "an error or Ctrl-C leaves nothing behind": (SCENARIO_FILES, "test_interrupt_during_the_simulation_leaves_nothing"),
    "JSON output is strict JSON": (OUTPUTS, "test_json_output_is_strict_json_even_for_errors"),
    "`141` the reader of the\noutput went away": (OUTPUTS, "test_a_closed_pipe_ends_quietly"),
    "`130` interrupted (Ctrl-C, start-up included)": (OUTPUTS, "test_ctrl_c_during_start_up_is_no_traceback"),
    "`2` a\nmalformed command line": (OUTPUTS, "test_malformed_command_line_exits_2"),
    "a number that is NaN or infinite": (OUTPUTS, "test_every_non_finite_number_of_the_command_line_is_named"),
    "A mistake in the file is reported in one line that names the file and the key, and nothing is\nwritten":
        (SCENARIO_FILES, "test_bad_scenario_is_refused_with_one_line_and_writes_nothing"),
    "at a gain-type singularity (`|S| < 1e-6`) it\n  refuses":
        (CLI_OUTPUT, "test_dynamics_at_a_singularity_is_refused"),
    "exit code 1 and one line, for every machine": (CLI_OUTPUT, "test_no_assembly_mode_is_exit_1_and_one_line"),
    "that these are not the paper's numbers":
        (PARAMETER_FILES, "test_reproduce_with_params_runs_the_cases_on_that_machine_and_says_so"),
    "said once on stderr: on a terminal, in a log or in a notebook":
        ("getting-started.md", "test_first_run_says_it_compiles"),
    "a file of yours of the same name is refused":
        (OUTPUTS, "test_a_file_pkmlab_did_not_write_is_not_replaced_without_force"),
}


@pytest.mark.parametrize(("command", "suffix"), [
    (["singularity-map", "--resolution", "21", "--quiet"], ".png"),
    (["workspace", "--resolution", "21", "--quiet"], ".svg"),
    (["export-mjcf"], ".xml"),
    (["view", "RESULT"], ".html"),
    (["animate", "RESULT", "--stride", "400", "--quiet"], ".gif"),
])
def test_a_file_pkmlab_did_not_write_is_not_replaced_without_force(capsys, tmp_path, quick, command, suffix):
    """A file of the user's is refused untouched; ``--force`` replaces it; pkmlab's own output, unchanged, is
    replaced again without it; edited, it is the user's again."""
    result = tmp_path / "result"
    assert run(capsys, "simulate", EXAMPLES / "fast.toml", "--no-figures", "--out", result)[0] == 0
    argv = [str(result) if a == "RESULT" else a for a in command]
    mine = tmp_path / f"mine{suffix}"
    mine.write_bytes(b"precious")
    before = snapshot(tmp_path)
    code, _out, err = run(capsys, *argv, "--out", mine)
    assert code == 1 and f"--out {mine}: the file exists and pkmlab did not write it" in err and "--force" in err
    assert snapshot(tmp_path) == before  # nothing written, no temporary file left
    assert run(capsys, *argv, "--out", mine, "--force")[0] == 0
    written = mine.read_bytes()
    assert written != b"precious"
    assert run(capsys, *argv, "--out", mine)[0] == 0  # its own output, unchanged: replaced again
    mine.write_bytes(written + b" edited")
    code, _out, err = run(capsys, *argv, "--out", mine)
    assert code == 1 and "did not write it (or it changed since)" in err
    assert mine.read_bytes() == written + b" edited"


def documentation_page(page: str) -> str:
    """The text of the documentation's page ``docs/PAGE`` as the site shows it: an included file (a reference page
    shipped with the package) read in place of its include line."""
    text = (ROOT / "docs" / page).read_text(encoding="utf-8")
    return re.sub(r'^--8<-- "([^"]+)"$', lambda m: (ROOT / m.group(1)).read_text(encoding="utf-8"), text,
                  flags=re.MULTILINE)


def test_every_documented_promise_about_outputs_errors_and_exit_codes_has_a_test():
    tests = " ".join((ROOT / "tests" / name).read_text() for name in sorted(os.listdir(ROOT / "tests"))
                     if name.startswith("test_") and name.endswith(".py"))
    nav = (ROOT / "mkdocs.yml").read_text(encoding="utf-8")
    for promise, (page, test) in PROMISES.items():
        assert f": {page}\n" in nav, f"{page} is not a page of the documentation site"
        text = " ".join(documentation_page(page).split())
        assert " ".join(promise.split()) in text, f"docs/{page} no longer says: {promise!r}"
        assert f"def {test}(" in tests, f"no test {test} backs docs/{page}'s {promise!r}"


# ------------------------------------------------------------------ output folders fuzzed
FOLDER_FUZZ = {"runs": 0, "replaced": 0, "refused": 0}


def state(folder: Path) -> dict:
    """Everything in ``folder``, links not followed: relative path -> bytes, "folder" or "link"."""
    out = {}
    for root, dirs, files in os.walk(folder):
        for name in dirs + files:
            p = Path(root, name)
            out[p.relative_to(folder).as_posix()] = ("link" if p.is_symlink() else "folder" if p.is_dir()
                                                     else p.read_bytes())
    return out


@settings(max_examples=150, deadline=None, suppress_health_check=[HealthCheck.function_scoped_fixture])
@given(data=st.data())
def test_fuzz_output_folders(tmp_path_factory, data):
    """Random histories of a folder — results written by pkmlab commands, then a user's edits — and one
    more write: it succeeds only into an empty folder or an unchanged result of the same command, and
    otherwise leaves every byte as it was."""
    base = tmp_path_factory.mktemp("folders")
    out = base / "out"
    written = None  # (command, state) of the last result pkmlab wrote there
    for _ in range(data.draw(st.integers(0, 5), label="steps")):
        step = data.draw(st.sampled_from(["write", "add", "change", "delete", "subfolder", "link", "manifest",
                                          "mkdir"]), label="step")
        if step == "write":
            command = data.draw(st.sampled_from(["simulate", "reproduce"]), label="command")
            try:
                with warnings.catch_warnings():
                    warnings.simplefilter("ignore", outputs.ResultReplacedWarning)
                    with outputs.atomic_output_dir(out, command) as tmp:
                        (tmp / "summary.json").write_text(data.draw(st.text(max_size=20), label="content"))
                written = (command, state(out))
            except outputs.OutputFolderError:
                pass
            continue
        if step == "mkdir":
            out.mkdir(exist_ok=True)
            continue
        if not out.is_dir():
            continue
        files = sorted(p for p in out.rglob("*") if p.is_file() and not p.is_symlink())
        if step == "add":
            (out / data.draw(st.sampled_from(["notes.md", "summary.json.bak", "x.ipynb"]))).write_text("mine")
        elif step == "change" and files:
            with open(data.draw(st.sampled_from(files)), "a") as f:
                f.write("edited")
        elif step == "delete" and files:
            data.draw(st.sampled_from(files)).unlink()
        elif step == "subfolder":
            (out / "data").mkdir(exist_ok=True)
            (out / "data" / "raw.csv").write_text("1,2")
        elif step == "link":
            if not (out / "link").exists():
                (out / "link").symlink_to(base)
        elif step == "manifest" and (out / MANIFEST).exists():
            (out / MANIFEST).write_text(data.draw(st.sampled_from(["{}", "not json", '{"files": {}, "command": 1}'])))
    command = data.draw(st.sampled_from(["simulate", "reproduce"]), label="final command")
    # the oracle: the folder holds an unchanged result of `command` when it is exactly as pkmlab left it
    pristine = written[0] if written is not None and out.is_dir() and state(out) == written[1] else None
    empty = out.is_dir() and not any(out.iterdir())
    before = snapshot(out) if out.is_dir() else None
    links = sorted(p.name for p in out.iterdir() if p.is_symlink()) if out.is_dir() else []
    FOLDER_FUZZ["runs"] += 1
    try:
        with warnings.catch_warnings(record=True) as notes:
            warnings.simplefilter("always")
            with outputs.atomic_output_dir(out, command) as tmp:
                (tmp / "summary.json").write_text("new")
    except outputs.OutputFolderError:
        FOLDER_FUZZ["refused"] += 1
        assert before is not None and not empty and pristine != command
        assert snapshot(out) == before and sorted(p.name for p in out.iterdir() if p.is_symlink()) == links
    else:
        replaced = before is not None and not empty
        FOLDER_FUZZ["replaced"] += replaced
        assert before is None or empty or pristine == command, (before, pristine, command)
        assert [n.category for n in notes] == [outputs.ResultReplacedWarning] * replaced  # said, not silent
        assert (out / "summary.json").read_text() == "new"
    assert hidden(base) == []


def test_zz_report_how_many_folders_were_fuzzed():
    print(f"\noutput-folder fuzzer: {FOLDER_FUZZ}")
    assert FOLDER_FUZZ["runs"] == 0 or (FOLDER_FUZZ["refused"] > 10 and FOLDER_FUZZ["replaced"] > 10)


def test_a_file_added_while_the_run_writes_is_never_deleted(tmp_path, monkeypatch):
    out = tmp_path / "r"
    with outputs.atomic_output_dir(out, "test") as tmp:
        (tmp / "a.txt").write_text("old")
    # during the run: refused at the end, the new result is dropped, the user's file kept
    with pytest.raises(outputs.OutputFolderError, match="late.txt"):
        with outputs.atomic_output_dir(out, "test") as tmp:
            (out / "late.txt").write_text("mine")
            (tmp / "a.txt").write_text("new")
    assert (out / "late.txt").read_text() == "mine" and (out / "a.txt").read_text() == "old"
    (out / "late.txt").unlink()
    # in the instant between the last check and the swap: the earlier folder is kept beside, announced
    exchange = outputs._exchange

    def user_writes_first(a, b):
        (out / "later.txt").write_text("mine")
        return exchange(a, b)

    monkeypatch.setattr(outputs, "_exchange", user_writes_first)
    notes = []
    with outputs.atomic_output_dir(out, "test", note=notes.append) as tmp:
        (tmp / "a.txt").write_text("new")
    assert "changed while the run was writing" in notes[0] and "replaced the earlier results" in notes[1]
    kept = [p for p in tmp_path.iterdir() if p.name.startswith("r.previous-")]
    assert len(kept) == 1 and (kept[0] / "later.txt").read_text() == "mine"
    assert (out / "a.txt").read_text() == "new"


def test_an_empty_folder_of_the_users_inside_a_result_is_kept(capsys, tmp_path, quick):
    out = tmp_path / "r"
    argv = ["simulate", EXAMPLES / "fast.toml", "--out", out, "--no-figures", "--quiet"]
    assert run(capsys, *argv)[0] == 0
    (out / "figures-to-come").mkdir()
    assert "figures-to-come" in assert_user_error(*run(capsys, *argv))
    assert (out / "figures-to-come").is_dir()


@pytest.mark.parametrize("at", range(4))
def test_a_kill_while_view_adds_its_page_leaves_a_valid_result(capsys, tmp_path, quick, at):
    """``pkmlab view`` adds REPORT.html to a result and lists it in the manifest; killed (``os._exit``, no
    clean-up) after any of its renames (each manifest write, the page's own), the folder is still a result its
    command may replace, the page old or new, and the next view completes the addition."""
    folder = tmp_path / "r"
    assert run(capsys, "simulate", EXAMPLES / "fast.toml", "--no-figures", "--out", folder)[0] == 0
    child = textwrap.dedent(f"""
        import os, sys
        from pkmlab import outputs
        real, count = os.replace, [0]
        def replace(src, dst):
            real(src, dst)
            count[0] += 1
            if count[0] > {at}:
                os._exit(9)
        outputs.os.replace = replace
        outputs.add_to_result(sys.argv[1], "REPORT.html", lambda tmp: tmp.write_text("<html>new</html>"))
    """)
    killed = subprocess.run([sys.executable, "-c", child, str(folder)], capture_output=True, text=True)
    assert killed.returncode == 9, killed.stderr  # four renames in all: killed after each
    page = folder / "REPORT.html"
    assert not page.exists() or page.read_text() == "<html>new</html>"
    outputs.read_manifest(folder)  # valid at the instant of the kill
    outputs.add_to_result(folder, "REPORT.html", lambda tmp: tmp.write_text("<html>again</html>"))
    assert "pending" not in outputs.read_manifest(folder) and page.read_text() == "<html>again</html>"
    assert not [p for p in folder.iterdir() if p.name.startswith(".pending-")]
    assert run(capsys, "simulate", EXAMPLES / "fast.toml", "--no-figures", "--out", folder)[0] == 0
