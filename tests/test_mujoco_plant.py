"""pkmlab's controller against MuJoCo as the plant (pkmlab.interop.mujoco_plant, pkmlab simulate --plant mujoco)."""

from __future__ import annotations

import collections
import functools
import json
import os
from pathlib import Path

import numpy as np
import pytest

import pkmlab
from pkmlab import load_scenario, paper_scenario, simulate
from pkmlab.errors import InvalidParameterError
from pkmlab.simulation.realism import Drives, Sensors

pytest.importorskip("mujoco")
from pkmlab.interop.mujoco_plant import simulate_mujoco  # noqa: E402

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
#: The default runs of three machines (planar rigid, planar point, spatial with gravity), and how far the
#: MuJoCo plant's path may stray from pkmlab's: MuJoCo's loop closures are soft, by (1 - d)/d at impedance d.
RUNS = {"nominal": lambda: paper_scenario("nominal"),
        "five_bar": lambda: load_scenario(EXAMPLES / "five_bar_circle.toml"),
        "delta": lambda: load_scenario(EXAMPLES / "delta_pick_and_place.toml")}
BOUNDS = {"stiff": (1e-6, 1e-6), "soft": (1e-2, 1e-2)}  # path deviation (m), loop-closure violation (m)


@functools.cache
def _runs(name: str):
    """pkmlab's plant, and MuJoCo's with its default closures (stiff) and with soft ones, on one run."""
    scenario = RUNS[name]()
    return simulate(scenario), {"stiff": simulate_mujoco(scenario), "soft": simulate_mujoco(scenario, closures="soft")}


def _deviation(run, ours, name: str) -> float:
    k = 3 if name == "delta" else 2
    return float(np.linalg.norm(run.pose[:, :k] - ours.pose[:, :k], axis=1).max())


@pytest.mark.parametrize("name", sorted(RUNS))
def test_default_runs_on_mujoco_stay_near_pkmlabs_plant(name):
    ours, runs = _runs(name)
    deviations = {}
    for setting, run in runs.items():
        deviation = _deviation(run, ours, name)
        path_bound, closure_bound = BOUNDS[setting]
        assert deviation < path_bound and run.closure_violation.max() < closure_bound
        assert run.summary()["max_closure_violation_m"] == run.closure_violation.max()
        assert np.array_equal(run.t, ours.t) and run.columns[-1] == "closure_violation_m"
        deviations[setting] = deviation
    assert deviations["stiff"] < 1e-2 * deviations["soft"]  # the stiffer, the closer to the rigid chain


def test_the_five_bars_default_mujoco_plant_is_the_rigid_machine():
    """The five-bar's example on MuJoCo with its default closures stays within 1 µm of pkmlab's own plant
    (measured 7e-8 m), below a tenth of the run's own tracking error (1.3e-5 m); with MuJoCo's soft defaults
    it strays 0.92 mm (its loops open by 0.36 mm), some 70 times that tracking error."""
    ours, runs = _runs("five_bar")
    bound = 1e-6
    assert bound < 0.1 * ours.summary()["max_path_error_m"]
    assert _deviation(runs["stiff"], ours, "five_bar") < bound
    assert _deviation(runs["soft"], ours, "five_bar") > 100 * bound
    assert runs["soft"].closure_violation.max() > 100 * bound > 100 * runs["stiff"].closure_violation.max()


def test_bad_settings_are_refused():
    scenario = paper_scenario("nominal")
    with pytest.raises(InvalidParameterError, match="must divide the sample time"):
        simulate_mujoco(scenario, timestep=0.0003)
    with pytest.raises(InvalidParameterError, match="integrator must be one of"):
        simulate_mujoco(scenario, integrator="Verlet")
    with pytest.raises(InvalidParameterError, match="sampled-data control"):
        simulate_mujoco(scenario.replace(sample_time=0.0))
    for bad in ("rigid", "", None):
        with pytest.raises(InvalidParameterError, match=r"^closures must be 'stiff' or 'soft', got "):
            simulate_mujoco(scenario, closures=bad)


def test_drives_and_sensors_act_on_mujocos_plant_as_on_pkmlabs():
    """A geared drive with armature, viscous and stick–slip friction, saturation and effort noise, and a noisy
    delayed encoder: the readings are the same encoder counts on both plants (off by one count where the two
    integrations straddle a step) and the path error is the same to 1 %, 40 times the ideal plant's."""
    resolution = 2 * np.pi / 2**16
    drives = Drives(gear_ratio=3.0, armature=2e-5, viscous=0.01, coulomb=0.004, coulomb_rate=1e-3, stick_slip=True,
                    effort_limit=0.2, effort_noise=1e-3)
    scenario = paper_scenario("nominal").replace(drives=drives, sensors=Sensors(resolution=resolution, delay=1,
                                                                                noise=1e-5),
                                                 controller_drives=Drives(gear_ratio=3.0, armature=2e-5, viscous=0.01))
    ours, theirs = simulate(scenario), simulate_mujoco(scenario)
    counts = np.round(theirs.theta_measured / resolution) - np.round(ours.theta_measured / resolution)
    assert np.abs(counts).max() <= 1 and np.mean(counts != 0) < 0.1
    error = theirs.summary()["max_path_error_m"]
    assert error == pytest.approx(ours.summary()["max_path_error_m"], rel=0.01)
    assert error > 40 * _runs("nominal")[1]["stiff"].summary()["max_path_error_m"]


def test_mujocos_dry_friction_is_pkmlabs_stick_slip_friction():
    """Friction large enough to hold the machine for the first samples and to dominate its path error (240 times
    the ideal plant's): MuJoCo's ``frictionloss`` and pkmlab's Karnopp law give the same error to 0.1 %; a smooth
    or exact-sign law has no MuJoCo counterpart and is refused."""
    drives = Drives(coulomb=0.2, coulomb_rate=1e-3, stick_slip=True)
    scenario = paper_scenario("nominal").replace(drives=drives)
    ours, theirs = simulate(scenario), simulate_mujoco(scenario)
    error = theirs.summary()["max_path_error_m"]
    assert error == pytest.approx(ours.summary()["max_path_error_m"], rel=1e-3)
    assert error > 200 * _runs("nominal")[0].summary()["max_path_error_m"]
    for law in (Drives(coulomb=0.2), Drives(coulomb=0.2, coulomb_rate=0.0)):
        with pytest.raises(InvalidParameterError, match=r"^MuJoCo's Coulomb friction \(frictionloss\) is stick-slip "
                                                        r"friction, not pkmlab's (smooth tanh|exact sign) law"):
            simulate_mujoco(scenario.replace(drives=law))


def test_the_old_stiff_keyword_still_works_with_a_deprecation_warning():
    scenario = paper_scenario("nominal").replace(sample_time=0.0)  # refused right after the keyword is read
    for stiff in (True, False):
        with pytest.warns(DeprecationWarning, match=f"give closures='{'stiff' if stiff else 'soft'}'"), \
                pytest.raises(InvalidParameterError, match="sampled-data control"):
            simulate_mujoco(scenario, stiff=stiff)
    with pytest.raises(InvalidParameterError, match="contradicts"):
        simulate_mujoco(scenario, stiff=True, closures="soft")


def test_simulate_on_mujoco_from_the_command_line(tmp_path, capsys):
    from conftest import assert_user_error, run

    scenario = EXAMPLES / "five_bar_circle.toml"
    out = tmp_path / "run"
    code, _out, err = run(capsys, "simulate", scenario, "--plant", "mujoco", "--mujoco-timestep", "0.0005",
                          "--no-figures", "--out", out, "--json")
    assert code == 0 and err == ""
    summary = json.loads((out / "summary.json").read_text())
    assert summary["max_closure_violation_m"] < 1e-6  # stiff closures by default
    assert "MuJoCo, time step 0.0005 s, RK4, stiffest" in summary["provenance"]["plant"]
    assert (out / "run.csv").read_text().splitlines()[0].endswith(",S,closure_violation_m")
    soft = tmp_path / "soft"
    assert run(capsys, "simulate", scenario, "--plant", "mujoco", "--mujoco-closures", "soft", "--no-figures",
               "--out", soft, "--json")[0] == 0
    summary = json.loads((soft / "summary.json").read_text())
    assert summary["max_closure_violation_m"] > 1e-4  # MuJoCo's own defaults: the loops open
    assert "RK4, MuJoCo's default (soft) loop-closure constraints" in summary["provenance"]["plant"]
    # the deprecated flag: accepted, a no-op, one note on stderr (checked before the run: the run is refused)
    bad = tmp_path / "bad"
    code, _out, err = run(capsys, "simulate", scenario, "--plant", "mujoco", "--mujoco-stiff",
                          "--mujoco-timestep", "0.0003", "--no-figures", "--out", bad)
    note, error = err.splitlines()
    assert code == 1 and not bad.exists()
    assert note.startswith("pkmlab simulate: note: --mujoco-stiff is deprecated") and "default" in note
    assert "must divide the sample time" in error
    # one line, exit 1, nothing written
    for flags, words in ((["--plant", "mujoco", "--mujoco-closures", "rigid"],
                          "--mujoco-closures must be stiff or soft, got 'rigid'"),
                         (["--plant", "mujoco", "--mujoco-stiff", "--mujoco-closures", "soft"], "contradicts"),
                         (["--mujoco-stiff"], "go with --plant mujoco"),
                         (["--mujoco-closures", "soft"], "go with --plant mujoco")):
        message = assert_user_error(*run(capsys, "simulate", scenario, "--no-figures", "--out", bad, *flags))
        assert words in message and not bad.exists()


def test_the_core_never_imports_mujoco_and_says_how_to_install_it(monkeypatch):
    import subprocess
    import sys

    code = ("import sys, pkmlab, pkmlab.simulation.run, pkmlab.interop.mujoco_export, pkmlab.cli\n"
            "from pkmlab.model.mechanism_model import MechanismModel\n"
            "pkmlab.interop.mujoco_export.mjcf(MechanismModel.from_preset('five_bar'))\n"
            "assert 'mujoco' not in sys.modules, 'mujoco was imported'\n")
    subprocess.run([sys.executable, "-c", code], check=True)
    from pkmlab.errors import PkmlabError

    monkeypatch.setitem(sys.modules, "mujoco", None)  # as if it were not installed
    with pytest.raises(PkmlabError, match=r"pip install 'pkmlab\[mujoco\]'"):
        simulate_mujoco(paper_scenario("nominal"))


@pytest.mark.parametrize("failure", ["non-finite", "warning", "reset", "other warning"])
def test_mujocos_own_failure_is_one_line_naming_the_time(monkeypatch, tmp_path, capfd, failure):
    """MuJoCo's state turning non-finite (as an unstable integration leaves it) at the end of a sample, MuJoCo
    warning of a bad acceleration, or a state gone bad inside a sample (four steps of 0.25 ms), which MuJoCo resets
    at its next step with a warning: each stops the run with one line naming the sample interval, instead of NaN or
    reset results; another warning of MuJoCo's is said once, as a RuntimeWarning, and the run goes on. MuJoCo
    neither prints its warnings nor writes them to MUJOCO_LOG.TXT in the working folder meanwhile, and its log
    settings are as they were after the run. The compiled loop calls MuJoCo's step at an address: here a step that
    calls MuJoCo's and then fails."""
    import ctypes

    import mujoco

    from pkmlab.errors import UnstableControlError
    from pkmlab.interop import mujoco_export, mujoco_plant

    monkeypatch.chdir(tmp_path)  # where MuJoCo would write its warnings (MUJOCO_LOG.TXT): the reset makes it warn
    held = hasattr(mujoco, "MjLogConfig")  # (a MuJoCo without log settings logs as it always did)
    logging_before = _log_settings(mujoco) if held else None
    monkeypatch.setattr(mujoco_export, "_IDLE", collections.OrderedDict())  # a new MjData: none kept from a run before
    made, calls = [], {"n": 0}
    make = mujoco.MjData
    monkeypatch.setattr(mujoco, "MjData", lambda model: made.append(make(model)) or made[-1])
    signature = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)
    step = signature(mujoco_plant._step_address(mujoco))
    when = 398 if failure == "reset" else 100  # the reset: the 2nd of sample 99's 4 steps (t = 0.099 s on)

    @signature
    def failing(model, data):
        step(model, data)
        calls["n"] += 1
        if calls["n"] == when and failure == "warning":
            made[-1].warning.number[mujoco.mjtWarning.mjWARN_BADQACC] += 1  # as mj_warning counts
        elif calls["n"] == when and failure == "other warning":
            made[-1].warning.number[mujoco.mjtWarning.mjWARN_CNSTRFULL] += 1
        elif calls["n"] == when:
            made[-1].qvel[0] = np.nan

    monkeypatch.setattr(mujoco_plant, "_step_address", lambda _mujoco: ctypes.cast(failing, ctypes.c_void_p).value)
    if failure == "other warning":
        with pytest.warns(RuntimeWarning, match=r"MuJoCo warned 1 time\(s\) during the run: Insufficient arena"):
            result = simulate_mujoco(paper_scenario("nominal"))
        assert calls["n"] == result.t.size - 1
    else:
        with pytest.raises(UnstableControlError,
                           match=r"MuJoCo's integration failed between t = 0\.0990 and 0\.1000 s"):
            simulate_mujoco(paper_scenario("nominal"), timestep=2.5e-4 if failure == "reset" else None)
        assert calls["n"] == (400 if failure == "reset" else 100)
    if failure == "reset":
        assert np.isfinite(made[-1].qvel).all()  # MuJoCo did reset the state the run would have gone on from
    if held:
        assert not (tmp_path / "MUJOCO_LOG.TXT").exists() and "WARNING" not in capfd.readouterr().out
        assert _log_settings(mujoco) == logging_before


def _log_settings(mujoco) -> tuple[bool, bool]:
    config = mujoco.MjLogConfig.get()
    return config.logto_file, config.logto_console


def test_mujocos_log_is_held_from_the_first_run_in_to_the_last_out():
    """Runs in threads overlap: MuJoCo's log settings, the process's, are held while any of them runs, and set back
    as they were when the last ends."""
    mujoco = pytest.importorskip("mujoco")
    if not hasattr(mujoco, "MjLogConfig"):
        pytest.skip("this MuJoCo has no log settings")
    from pkmlab.interop.mujoco_export import mujoco_log_held

    before = _log_settings(mujoco)
    first, second = mujoco_log_held(mujoco), mujoco_log_held(mujoco)
    first.__enter__()
    second.__enter__()
    first.__exit__(None, None, None)
    assert _log_settings(mujoco) == (False, False)  # the second run still holds it
    second.__exit__(None, None, None)
    assert _log_settings(mujoco) == before


def test_a_run_on_the_model_and_data_of_the_last_run_is_the_same_run(monkeypatch):
    """The MuJoCo plant keeps a finished run's model and data for the next run of the same machine from the same
    start with the same options (pkmlab.interop.mujoco_export.pooled_mujoco), its data reset to the keyframe: the next
    run is the same, bit for bit, as on new ones — after a run with noisy, delayed sensors on them, after one with
    other closures, and after one that MuJoCo's integration ended."""
    import ctypes

    import mujoco

    from pkmlab.errors import UnstableControlError
    from pkmlab.interop import mujoco_export, mujoco_plant

    monkeypatch.setattr(mujoco_export, "_IDLE", collections.OrderedDict())
    made, steps = [], []
    make = mujoco.MjData
    monkeypatch.setattr(mujoco, "MjData", lambda model: made.append(make(model)) or made[-1])
    scenario = paper_scenario("nominal")
    first = simulate_mujoco(scenario)
    assert len(made) == 1
    signature = ctypes.CFUNCTYPE(None, ctypes.c_void_p, ctypes.c_void_p)
    step = signature(mujoco_plant._step_address(mujoco))

    @signature
    def failing(model, data):  # MuJoCo's step, then the kept data's state made not finite at the 100th
        step(model, data)
        steps.append(1)
        if len(steps) == 100:
            made[0].qvel[0] = np.nan

    def failed_run():
        with monkeypatch.context() as patch:
            patch.setattr(mujoco_plant, "_step_address", lambda _mujoco: ctypes.cast(failing, ctypes.c_void_p).value)
            with pytest.raises(UnstableControlError, match="MuJoCo's integration failed"):
                simulate_mujoco(scenario)

    noisy = scenario.replace(sensors=Sensors(resolution=2 * np.pi / 2**12, delay=2, noise=1e-4))
    for before in (lambda: simulate_mujoco(noisy), lambda: simulate_mujoco(scenario, closures="soft"), failed_run):
        before()
        again = simulate_mujoco(scenario)
        assert all(np.array_equal(getattr(again, f), getattr(first, f)) for f in ("q", "theta_dot", "tau",
                                                                                  "closure_violation"))
    assert len(made) == 2 and len(steps) == 100  # the first run's data (the failed run's too), the soft closures'
    assert len(mujoco_export._IDLE) == 2


@pytest.mark.parametrize("name", ["nominal", "delta"])
def test_the_controller_that_keeps_its_models_base_computes_the_efforts_of_one_that_starts_afresh(name):
    """The MuJoCo plant's compiled loop keeps the controller's workspace from sample to sample and follows the
    measurement from the base it left there, its factors and S reused (_control_effort_from). The controller called
    afresh at each sample — a new workspace, its base set from the last configuration and followed in sub-steps
    (measured_control_effort) — computes the same efforts from the run's recorded states, to round-off."""
    from pkmlab.simulation.run import loop_motion, prepare_run

    scenario = RUNS[name]()
    run = _runs(name)[1]["stiff"]
    ctrl = scenario.model
    k_, prep = ctrl.kernels, prepare_run(scenario)
    r = prep.realism
    desired = loop_motion(ctrl, prep.desired)
    columns = list(k_.INDEPENDENT)
    q_base, q_out = prep.q_ctrl0.copy(), np.empty(prep.q_ctrl0.size)
    tau, applied, none = np.empty(ctrl.n_actuators), np.empty(ctrl.n_actuators), np.zeros((0, ctrl.n_actuators))
    afresh = np.empty_like(run.tau)
    for k in range(run.t.size):
        x = np.concatenate([run.q[k, columns], run.theta_dot[k]])
        status = k_.measured_control_effort(k, scenario.sample_time, x, q_base, prep.kind, prep.kp, prep.kv,
                                            prep.distribution, *(a[k] for a in desired), ctrl.P,
                                            prep.singularity_guard, r.drive, r.ctrl_drive, r.effort_noise,
                                            r.resolution, r.theta_noise, r.sensing, r.delay, none, none, q_out, tau,
                                            applied)
        assert status == k_.OK
        afresh[k], q_base = tau, q_out.copy()
    scale = np.abs(afresh).max()
    assert np.abs(run.tau - afresh).max() < 1e-12 * scale


#: The paper's fast case on the MuJoCo plant, its kernels interpreted (Python functions, which this wraps to count):
#: how often the controller found its kept base, and how often it followed in sub-steps from a base set afresh.
KEPT_BASE_COUNT = """
import json
from collections import Counter
from pkmlab import paper_scenario
from pkmlab.interop.mujoco_plant import simulate_mujoco
scenario = paper_scenario("fast")
kernels, counts = scenario.model.kernels, Counter()
is_base, in_steps = kernels.is_base, kernels.follow_branch_in_steps
def counted_is_base(ws, q):
    kept = is_base(ws, q)
    counts["kept" if kept else "not kept"] += 1
    return kept
def counted_in_steps(*args):
    counts["in steps"] += 1
    return in_steps(*args)
kernels.is_base, kernels.follow_branch_in_steps = counted_is_base, counted_in_steps
run = simulate_mujoco(scenario)
print(json.dumps({"samples": int(run.t.size), **counts}))
"""


def test_the_controller_follows_from_its_kept_base_at_every_sample_but_the_first():
    """The MuJoCo plant's controller (_control_effort_from) finds its model's base where the last sample left it,
    factored, at every sample after the first, and follows the measurement from there; in sub-steps from a base set
    afresh only at the first (counted in an interpreted run)."""
    import subprocess
    import sys

    env = {**os.environ, "PKMLAB_INTERPRETED": "1"}
    done = subprocess.run([sys.executable, "-c", KEPT_BASE_COUNT], env=env, capture_output=True, text=True,
                          timeout=600)
    assert done.returncode == 0, done.stderr
    counts = json.loads(done.stdout)
    assert counts == {"samples": counts["samples"], "kept": counts["samples"] - 1, "not kept": 1, "in steps": 1}


def test_the_loop_measures_the_loop_closures_as_mujocos_constraints_do():
    """The compiled loop measures MuJoCo's loop-closure violation from the sites and tendons of the exported
    model's equality constraints (connects between two sites, as the next test checks on a run; and a tendon held
    at a length: a universal joint's axes at a rigid platform, the 3-UPU wrist's); at every step of a run under
    random efforts that opens the loops (soft closures), that measure is MuJoCo's own largest constraint violation
    ``efc_pos``, to round-off."""
    import mujoco

    from pkmlab.interop import mujoco_export as mx
    from pkmlab.interop.mujoco_plant import _closure_rows

    model = pkmlab.load(EXAMPLES / "mechanisms" / "3upu_wrist.toml")
    m, d = mx.load_mujoco(model, closures="soft")
    connects, tendons, targets = _closure_rows(mujoco, m)
    assert len(connects) == len(tendons) == len(model.description.legs)
    rng = np.random.default_rng(2)
    largest = 0.0
    for _ in range(200):
        d.ctrl[:] = rng.normal(0.0, 2.0, m.nu)
        mujoco.mj_step(m, d)
        measured = max(np.abs(d.site_xpos[connects[:, 0]] - d.site_xpos[connects[:, 1]]).max(),
                       np.abs(d.ten_length[tendons] - targets).max(initial=0.0))
        assert measured == pytest.approx(np.abs(d.efc_pos).max(), rel=1e-12, abs=1e-15)
        largest = max(largest, measured)
    assert largest > 1e-6  # the loops did open


def test_the_runs_loop_closure_violation_is_mujocos_efc_pos_along_the_same_steps():
    """The violation the compiled loop records at each sample is MuJoCo's own ``efc_pos`` (its largest absolute
    entry) after the step before that sample: MuJoCo alone, from the same start, stepped by the run's efforts in a
    Python loop of ``mj_step``, gives the same states and those values, with soft closures and stiff ones."""
    import mujoco

    from pkmlab.interop import mujoco_export as mx
    from pkmlab.simulation.run import prepare_run

    scenario = RUNS["nominal"]()
    for closures, run in _runs("nominal")[1].items():
        m, d = mx.load_mujoco(scenario.plant_model, prepare_run(scenario).q_plant0, closures=closures)
        violation = [np.abs(d.efc_pos).max()]
        for effort in run.tau[:-1]:
            d.ctrl[:] = effort
            mujoco.mj_step(m, d)
            violation.append(np.abs(d.efc_pos).max())
        assert np.array_equal(run.closure_violation, violation), closures
        assert np.array_equal(run.q[-1], mx.q_from_qpos(scenario.plant_model, d.qpos))
