"""Studies (pkmlab.study): definitions, draws of the plant, rows against runs done alone, failures as
results, chunk files and resumption, a real Dask cluster with a worker killed mid-study, the tuner."""

import json
import math
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import run

import pkmlab
from pkmlab.errors import InvalidParameterError
from pkmlab.formats.scenario import load_scenario
from pkmlab.model.mechanism_model import MechanismModel
from pkmlab.simulation.uncertainty import draw_factors, perturbed_plant, uncertain_parameters
from pkmlab.study import Study, StudyError, StudyInterrupted, load_study, study_from_dict, sweep

pytest.importorskip("distributed")
pytest.importorskip("pyarrow")

EXAMPLES = Path(__file__).parents[1] / "examples"
FAST = EXAMPLES / "fast.toml"


def small_study(**changes) -> Study:
    """The paper's fast case, 2 gains x 2 speeds x 3 plants drawn (masses, inertias ±15 %): 12 runs."""
    args = {"grid": {"controller.kp": [400.0, 2000.0], "trajectory.speed": [0.3, 0.4]},
            "uncertainty": {"mass": 0.15, "inertia": 0.15}, "draws": 3, "seed": 7}
    args.update(changes)
    return Study.create(FAST, **args)


@pytest.fixture(scope="module")
def reference():
    """The small study run in this process, chunk by chunk: the table every other way must reproduce."""
    return sweep(small_study(), workers=0, chunk_size=5)


# ------------------------------------------------------------------ definitions
@pytest.mark.parametrize("grid, message", [
    ({"sample_time": [1e-3]}, "'sample_time' is not a scenario value (did you mean 'controller.sample_time'?)"),
    ({"controller.kpp": [1.0]}, "did you mean 'controller.kp'?"),
    ({"controller.kp": []}, "is empty"),
    ({"controller.kp": [1.0, float("nan")]}, "[1] must be finite"),
    ({"controller.kp": {"start": 1.0, "stop": float("inf"), "num": 3}}, "stop must be a finite number"),
    ({"controller.kp": {"start": 1.0, "stop": 2.0}}, "needs num"),
    ({"controller.kp": {"start": 1.0, "stop": 2.0, "num": 2, "step": 1}}, "unknown key 'step'"),
    ({"controller.kp": [-5.0]}, "[grid] controller.kp = -5.0: "),
    ({"controller.kp": [1.0, 1.0]}, "repeats a value"),
    ({"mechanism.preset": ["delta"]}, "is not a scenario value"),
    ({"manipulator.params.l": [0.2, [0.2, 0.21, 0.2]]}, "mixes lists and numbers"),
    ({"controller.kp": {"start": 500.0, "stop": 500.0, "num": 2}}, "repeats a value"),
    ({"simulation.substeps": {"start": 1, "stop": 2, "num": 3}}, "must give whole numbers"),
])
def test_bad_axes_are_refused_naming_the_key(grid, message):
    with pytest.raises(InvalidParameterError) as info:
        Study.create(FAST, grid=grid)
    assert message in str(info.value)
    assert "\n" not in str(info.value)


def test_bad_study_files_are_refused(tmp_path):
    base = {"trajectory": {"type": "circle", "center": [0.25, 0.21], "radius": 0.05, "speed": 0.2}}
    cases = [
        ({"study": {"draws": 2}, "base": base}, "no [uncertainty]"),
        ({"study": {"base": "fast.toml"}, "base": base}, "give the base scenario once"),
        ({"base": base, "uncertainty": {"mas": 0.1}, "study": {"draws": 2}}, "did you mean 'mass'?"),
        ({"base": base, "uncertainty": {"mass": 1.5}, "study": {"draws": 2}}, "a spread must be a number in [0, 1)"),
        ({"base": base, "grids": {}}, "did you mean 'grid'?"),
        ({"base": base, "uncertainty": {"length": [0.3, 0.4]}, "study": {"draws": 20}},
         "none of the first 8 plants drawn (length in [0.3, 0.4]) can be assembled: paper: the platform can be "
         "assembled nowhere"),
        ({"base": base, "study": {"combine": "zip"}, "grid": {"controller.kp": [1.0, 2.0],
                                                                "controller.kv": [1.0]}}, "as many values"),
    ]
    for data, message in cases:
        with pytest.raises(pkmlab.PkmlabError) as info:
            study_from_dict(data, str(tmp_path / "s.toml"))
        assert message in str(info.value), (data, str(info.value))


def test_grid_order_ranges_and_zip():
    study = Study.create(FAST, grid={"controller.kp": {"start": 100.0, "stop": 10000.0, "num": 3, "scale": "log"},
                                     "trajectory.speed": {"start": 0.2, "stop": 0.4, "num": 3}},
                         uncertainty={"mass": 0.1}, draws=2)
    assert study.shape == (3, 3) and study.size == 18
    assert study.axes[0][1] == pytest.approx((100.0, 1000.0, 10000.0), rel=1e-12)
    assert study.axes[1][1] == pytest.approx((0.2, 0.3, 0.4), rel=1e-12)
    # runs: grid point by grid point, the first axis slowest, draws innermost
    assert study.locate(7) == (3, 1)
    assert study.point_values(3) == {"controller.kp": study.axes[0][1][1], "trajectory.speed": 0.2}
    zipped = Study.create(FAST, grid={"controller.kp": [100.0, 100.0], "controller.kv": [10.0, 30.0]},
                          combine="zip")
    assert zipped.size == 2 and zipped.point_values(1) == {"controller.kp": 100.0, "controller.kv": 30.0}
    scenario = zipped.scenario(1)
    assert (scenario.controller.kp, scenario.controller.kv) == (100.0, 30.0)
    assert study.digest != Study.create(FAST, grid={"controller.kp": [1.0]}).digest
    assert study.digest == Study.create(FAST, grid=dict((k, list(v)) for k, v in study.axes),
                                        uncertainty={"mass": 0.1}, draws=2).digest


def test_values_keep_their_kind_and_the_axes_their_order():
    study = Study.create(FAST, grid={"simulation.substeps": {"start": 1, "stop": 3, "num": 3},
                                     "controller.kp": list(np.array([100, 200]))})  # NumPy's integers too
    assert study.axes == (("simulation.substeps", (1, 2, 3)), ("controller.kp", (100.0, 200.0)))
    swapped = Study.create(FAST, grid={"controller.kp": [100.0, 200.0], "simulation.substeps": [1, 2, 3]})
    # the order of the axes says which grid point a run is: another order is another study
    assert swapped.digest != study.digest


def test_a_combination_that_is_no_scenario_is_a_failed_row_even_first():
    # each value is valid with the base, but continuous time (Ts = 0) takes no RK4 sub-steps: grid points 0, 1
    study = Study.create(FAST, grid={"controller.sample_time": [0.0, 1e-3], "simulation.substeps": [2, 1]})
    frame = sweep(study, workers=0)
    assert list(frame["status"]) == ["failed", "failed", "ok", "ok"]
    assert list(frame["reason"][:2]) == ["invalid"] * 2 and "substeps" in frame.iloc[0]["message"]


# ------------------------------------------------------------------ drawn plants
@pytest.mark.parametrize("name", ["paper", "3rpr", "delta"])
def test_drawn_plants_scale_the_mass_matrix(name):
    """Masses and inertias ×c, lengths unchanged: the same geometry, a mass matrix ×c (and gravity ×c) —
    an independent check that every body's mass and inertia went through."""
    model = MechanismModel.from_preset(name)
    c = 1.3
    factors = {p: c for p in uncertain_parameters(model, ("mass", "inertia"))}
    plant = perturbed_plant(model, factors)
    from pkmlab.model import mechanism_model as mm

    pose = {"paper": [0.25, 0.21, 0.0], "3rpr": [0.25, 0.21, -1.5707963267948966], "delta": [0.02, -0.01, -0.75]}[name]
    q = mm.inverse_kinematics(model, pose, mm.working_modes(model)[0])
    zero = np.zeros(model.n_actuators)
    (m0, _c0, g0), (m1, _c1, g1) = (mm.actuator_space_model(m, q, zero) for m in (model, plant))
    np.testing.assert_allclose(g1, c * g0, rtol=1e-12, atol=1e-15)
    assert perturbed_plant(model, {}).description == model.description
    np.testing.assert_allclose(m1, c * m0, rtol=1e-12)


def test_draws_are_reproducible_and_independent_of_order():
    model = MechanismModel.from_preset("five_bar")
    bounds = {"mass": (0.8, 1.2), "length": 0.05}
    later = draw_factors(model, bounds, seed=3, draw=5)
    first = [draw_factors(model, bounds, seed=3, draw=k) for k in range(6)]
    assert first[5] == later
    assert first[0] != first[1]
    values = np.array([list(f.values()) for f in first])
    assert set(first[0]) == set(uncertain_parameters(model, ("mass", "length")))
    masses = values[:, [i for i, n in enumerate(first[0]) if n.endswith("mass")]]
    assert masses.min() >= 0.8 and masses.max() <= 1.2
    with pytest.raises(InvalidParameterError, match="unknown uncertain parameter 'leg9.body1.mass'"):
        perturbed_plant(model, {"leg9.body1.mass": 1.1})


# ------------------------------------------------------------------ rows are runs
def test_rows_equal_runs_done_alone(reference):
    study = small_study()
    assert list(reference["run"]) == list(range(study.size))
    assert (reference["status"] == "ok").all()
    for run_ in (0, 5, 11):
        result = pkmlab.simulate(study.scenario(run_))
        summary = result.summary()
        row = reference.iloc[run_]
        assert row["max_path_error_m"] == summary["max_path_error_m"]
        assert row["rms_path_error_m"] == summary["rms_path_error_m"]
        assert row["peak_effort"] == max(summary["peak_effort"])
        assert row["min_abs_S"] == summary["min_abs_S"]
    # the drawn plants differ, and their factors are the table's
    assert reference["max_path_error_m"].nunique() == study.size
    factors = study.factors(4)
    assert all(reference.iloc[4][f"plant.{k}"] == v for k, v in factors.items())
    assert reference.attrs["summary"]["ok"] == study.size


def test_failures_are_results_with_their_reason():
    # kp = 1e7 with Ts = 1 ms: the sampled-data loop is unstable; a radius of 0.2 m leaves the workspace
    study = Study.create(FAST, grid={"controller.kp": [1000.0, 1e7], "trajectory.radius": [0.05, 0.2]})
    frame = sweep(study, workers=0)
    status = dict(zip(zip(frame["controller.kp"], frame["trajectory.radius"], strict=True),
                      zip(frame["status"], frame["reason"], strict=True), strict=True))
    assert status[(1000.0, 0.05)] == ("ok", "")
    assert status[(1e7, 0.05)] == ("failed", "unstable")
    assert status[(1000.0, 0.2)][1] in ("unreachable", "singular")
    failed = frame[frame["status"] == "failed"]
    assert failed["message"].str.len().min() > 20 and failed["max_path_error_m"].isna().all()
    assert frame.attrs["summary"]["failed"] == 3


def test_a_second_mechanism_study():
    study = Study.create(EXAMPLES / "3prr_circle.toml", grid={"controller.kp": [500.0, 2000.0]},
                         uncertainty={"mass": 0.1, "length": 0.01}, draws=2, seed=1)
    frame = sweep(study, workers=0)
    assert (frame["status"] == "ok").all() and "peak_effort_3" in frame
    summary = pkmlab.simulate(study.scenario(3)).summary()
    assert frame.iloc[3]["max_path_error_m"] == summary["max_path_error_m"]
    assert frame.iloc[3]["max_orientation_error_rad"] == summary["max_orientation_error_rad"]


# ------------------------------------------------------------------ folders, chunks, resumption
def test_interrupted_study_resumes_to_the_same_table(tmp_path, reference):
    study = small_study()
    out = tmp_path / "study"

    def stop_after_two(done, total):
        if done >= 4:
            raise KeyboardInterrupt

    with pytest.raises(StudyInterrupted, match=r"4 of 12 runs are kept"):
        sweep(study, out, workers=0, chunk_size=2, on_chunk=stop_after_two)
    assert len(list((out / "chunks").glob("*.parquet"))) == 2 and not (out / "runs.parquet").exists()
    with pytest.raises(StudyError, match="unfinished: add --resume"):
        sweep(study, out, workers=0)
    counts = []
    frame = sweep(study, out, workers=0, chunk_size=3, resume=True, on_chunk=lambda d, t: counts.append(t))
    assert counts[-1] == 8  # only the runs not written
    assert frame.equals(reference)
    uninterrupted = tmp_path / "whole"
    sweep(study, uninterrupted, workers=0, figures=False)
    assert (out / "runs.parquet").read_bytes() == (uninterrupted / "runs.parquet").read_bytes()
    summary = json.loads((out / "summary.json").read_text())
    assert summary["runs"] == 12 and summary["digest"] == study.digest
    assert {p.name for p in (out / "figures").iterdir()} >= {"error_map.png", "effort_map.png",
                                                             "distributions.png", "failures.png"}


def test_study_folders_are_never_mixed(tmp_path):
    study = small_study()
    other = tmp_path / "notes"
    other.mkdir()
    (other / "mine.txt").write_text("keep me")
    with pytest.raises(StudyError, match="holds other files and no study"):
        sweep(study, other, workers=0)
    assert [p.name for p in other.iterdir()] == ["mine.txt"]
    out = tmp_path / "s"
    sweep(study, out, workers=0, figures=False)
    with pytest.raises(StudyError, match="holds another study"):
        sweep(small_study(seed=8), out, workers=0, resume=True)
    swapped = small_study(grid={"trajectory.speed": [0.3, 0.4], "controller.kp": [400.0, 2000.0]})
    with pytest.raises(StudyError, match="holds another study"):  # the same values, the axes in another order
        sweep(swapped, out, workers=0, resume=True)
    # a study that cannot start (an unreachable cluster) leaves no folder behind
    engine_timeout = pytest.MonkeyPatch()
    from pkmlab.study import engine

    engine_timeout.setattr(engine, "CONNECT_TIMEOUT", 1.0)
    with pytest.raises(StudyError, match="cannot reach"):
        sweep(study, tmp_path / "never", scheduler="tcp://127.0.0.1:9")
    engine_timeout.undo()
    assert not (tmp_path / "never").exists()


# ------------------------------------------------------------------ a real Dask cluster
@pytest.fixture(scope="module")
def cluster():
    distributed = pytest.importorskip("distributed")
    import logging

    with distributed.LocalCluster(n_workers=2, threads_per_worker=1, processes=True, dashboard_address=":0",
                                  silence_logs=logging.ERROR) as local, distributed.Client(local) as client:
        yield client


def test_the_workers_of_a_local_cluster_compile_no_loop_ahead(monkeypatch):
    """The workers of the local cluster a study starts share the cores already: none starts a second process to
    compile a first run's loop (pkmlab.simulation.ahead), whatever this process's environment says."""
    pytest.importorskip("distributed")
    from pkmlab.simulation.ahead import SWITCH
    from pkmlab.study.engine import dask_client

    monkeypatch.delenv(SWITCH, raising=False)
    with dask_client(1, None, None) as client:
        seen = client.run(lambda: os.environ.get(SWITCH))  # (the worker's environment, not a copy of this one's)
    assert list(seen.values()) == ["0"]


def test_a_killed_worker_loses_nothing(cluster, tmp_path, reference):
    study = small_study()
    killed = []

    def kill_a_worker(done, total):
        if not killed:
            pids = cluster.run(os.getpid)
            victim = sorted(pids.values())[0]
            os.kill(victim, signal.SIGKILL)
            killed.append(victim)

    frame = sweep(study, tmp_path / "s", client=cluster, chunk_size=1, on_chunk=kill_a_worker, figures=False)
    assert killed
    assert frame.equals(reference)  # every run once, the same numbers
    files = list((tmp_path / "s" / "chunks").glob("*.parquet"))
    assert len(files) == study.size


def test_a_study_another_process_is_running_is_refused_naming_it(tmp_path):
    """Two resumes of one folder would write overlapping chunks: while one holds the study (its lock on
    study.json, here taken by this process on an open file of its own), the other is refused, naming its pid, and
    the folder is untouched; once it lets go, the resume runs."""
    from pkmlab.study.engine import StudyFolder

    study = small_study()
    out = tmp_path / "s"

    def stop(done, total):
        if done >= 2:
            raise KeyboardInterrupt

    with pytest.raises(StudyInterrupted):
        sweep(study, out, workers=0, chunk_size=2, on_chunk=stop, figures=False)
    before = sorted(p.name for p in (out / "chunks").iterdir())
    with StudyFolder(out, study).exclusive():
        with pytest.raises(StudyError, match=rf"another process \(pid {os.getpid()}\) is running this study now"):
            sweep(study, out, workers=0, resume=True, figures=False)
    assert sorted(p.name for p in (out / "chunks").iterdir()) == before
    assert len(sweep(study, out, workers=0, resume=True, figures=False)) == study.size


def test_interrupted_on_the_cluster_and_resumed(cluster, tmp_path, reference):
    study = small_study()
    out = tmp_path / "s"

    def interrupt(done, total):
        if done >= 3:
            raise KeyboardInterrupt

    with pytest.raises(StudyInterrupted):
        sweep(study, out, client=cluster, chunk_size=3, on_chunk=interrupt, figures=False)
    frame = sweep(study, out, client=cluster, chunk_size=4, resume=True, figures=False)
    assert frame.equals(reference)


def test_a_study_on_an_existing_cluster_by_its_address(cluster, reference, tmp_path, capsys):
    """`--scheduler tcp://HOST:PORT`: the same study on a cluster someone else started gives the same table."""
    address = cluster.scheduler.address
    assert address.startswith("tcp://")
    assert sweep(small_study(), scheduler=address, chunk_size=4).equals(reference)
    spec = tmp_path / "sweep.toml"
    spec.write_text(f'[study]\nbase = "{FAST}"\n[grid]\n"controller.kp" = [400.0, 2000.0]\n')
    code, out, err = run(capsys, "sweep", spec, "--out", tmp_path / "out", "--scheduler", address, "--no-figures")
    assert code == 0 and "2 runs, 2 ok" in out, err
    code, _out, err = run(capsys, "sweep", spec, "--out", tmp_path / "o2", "--scheduler", address, "--workers", "2")
    assert code == 1 and "give one of them" in err and not (tmp_path / "o2").exists()


def _runs_that_warn(on: bool) -> None:
    """On a worker: its runs raise NumPy's overflow warning first (``on``), or run as they are."""
    import numpy

    import pkmlab.study.engine as engine

    original = getattr(engine, "_original_run_chunk", engine.run_chunk)
    engine._original_run_chunk = original

    def warned(*args, **kwargs):
        numpy.float64(1e300) * numpy.float64(1e300)  # "overflow encountered in scalar multiply"
        return original(*args, **kwargs)

    engine.run_chunk = warned if on else original


def test_a_workers_warning_is_one_note_of_the_command(cluster, tmp_path, capsys):
    """A library's warning inside a run on a worker reaches the command, which says it once, in one note line
    (a worker's own stderr would have printed it raw, apart from the command's output)."""
    spec = tmp_path / "sweep.toml"
    spec.write_text(f'[study]\nbase = "{FAST}"\n[grid]\n"controller.kp" = [400.0, 2000.0]\n')
    cluster.run(_runs_that_warn, True)
    try:
        code, out, err = run(capsys, "sweep", spec, "--out", tmp_path / "out", "--scheduler",
                             cluster.scheduler.address, "--no-figures", "--chunk-size", "1")
    finally:
        cluster.run(_runs_that_warn, False)
    assert code == 0 and "2 runs, 2 ok" in out, err
    notes = [line for line in err.splitlines() if "RuntimeWarning" in line]
    assert len(notes) == 1 and "overflow encountered in scalar multiply" in notes[0], err
    assert "a computation warned on the way" in notes[0] and "please report it" in notes[0]


def test_unreachable_scheduler_is_one_line(monkeypatch):
    from pkmlab.study import engine

    monkeypatch.setattr(engine, "CONNECT_TIMEOUT", 1.0)  # the command line's is 5 s: the same path, sooner
    with pytest.raises(StudyError, match=r"cannot reach the Dask scheduler at tcp://127\.0\.0\.1:9 within 1 s"):
        sweep(small_study(), scheduler="tcp://127.0.0.1:9")


# ------------------------------------------------------------------ the command line
def test_sweep_command(tmp_path, capsys):
    spec = tmp_path / "sweep.toml"
    spec.write_text(f'[study]\nbase = "{FAST}"\n[grid]\n"controller.kp" = [400.0, 2000.0]\n')
    code, out, err = run(capsys, "sweep", spec, "--out", tmp_path / "out", "--workers", "0", "--csv")
    assert code == 0, err
    assert "2 runs, 2 ok, 0 failed" in out
    table = (tmp_path / "out" / "runs.csv").read_text().splitlines()
    assert len(table) == 3 and table[0].startswith("run,point,draw,controller.kp,status")
    spec.write_text(f'[study]\nbase = "{FAST}"\n[grid]\n"kp" = [400.0]\n')
    code, out, err = run(capsys, "sweep", spec, "--out", tmp_path / "other", "--workers", "0")
    assert code == 1 and err.count("\n") == 1 and "did you mean 'controller.kp'?" in err
    assert not (tmp_path / "other").exists()


def test_sweep_command_interrupted_then_resumed(tmp_path):
    """Ctrl-C at a terminal (SIGINT to the whole process group: pkmlab and its local cluster's workers) during
    `pkmlab sweep` keeps the chunks written and says, in one line, how to finish; --resume (here in-process)
    does, and the table is the study's."""
    import os
    import time

    spec = tmp_path / "sweep.toml"
    spec.write_text(f'[study]\nbase = "{FAST}"\ndraws = 40\n[uncertainty]\nmass = 0.1\n')
    out = tmp_path / "out"
    cmd = [sys.executable, "-m", "pkmlab.cli", "sweep", str(spec), "--out", str(out), "--chunk-size", "1",
           "--no-figures"]
    proc = subprocess.Popen([*cmd, "--workers", "2"], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            start_new_session=True)
    chunks = out / "chunks"
    while proc.poll() is None and len(list(chunks.glob("*.parquet")) if chunks.exists() else []) < 3:
        time.sleep(0.05)
    os.killpg(proc.pid, signal.SIGINT)
    _out, err = proc.communicate(timeout=120)
    if proc.returncode == 0:  # finished before the signal came: nothing to resume
        pytest.skip("the study finished before it could be interrupted")
    assert proc.returncode == 130 and err.count("\n") == 1 and "--resume" in err, err  # no worker's traceback
    done = len(list(chunks.glob("*.parquet")))
    resumed = subprocess.run([*cmd, "--workers", "0", "--resume"], capture_output=True, text=True, timeout=300,
                             check=False)
    assert resumed.returncode == 0, resumed.stderr
    assert f"resuming: {done} of 40 runs" in resumed.stderr
    whole = sweep(load_study(spec), workers=0)
    import pyarrow.parquet as pq

    assert pq.read_table(out / "runs.parquet").to_pandas().equals(whole)


# ------------------------------------------------------------------ the tuner
def test_tune_finds_gains_no_worse_than_the_scenarios(tmp_path, capsys):
    code, out, err = run(capsys, "tune", FAST, "--max-effort", "1.6", "--out", tmp_path / "t", "--draws", "2",
                         "--trials", "6", "--workers", "0", "--critical", "--kp-range", "100", "1e5")
    assert code == 0, err
    summary = json.loads((tmp_path / "t" / "tuning.json").read_text())
    best, base = summary["best"], summary["baseline"]
    assert base["kp"] == 1000.0 and best["error"] <= base["error"] and best["worst_effort"] <= 1.6
    assert best["kv"] == pytest.approx(2 * math.sqrt(best["kp"]), rel=1e-12)
    tuned = load_scenario(tmp_path / "t" / "tuned.toml")
    assert (tuned.controller.kp, tuned.controller.kv) == (best["kp"], best["kv"])
    front = summary["tradeoff"]
    assert all(a["effort_limit"] <= b["effort_limit"] and a["error"] > b["error"] for a, b in zip(front, front[1:],
                                                                                                  strict=False))
    # the objective is the worst max path error of the tuned gains over the same drawn plants
    check = sweep(Study.create(FAST, grid={"controller.kp": [best["kp"]], "controller.kv": [best["kv"]]},
                               uncertainty={"mass": 0.15, "inertia": 0.15}, draws=2, seed=0), workers=0)
    assert check["max_path_error_m"].max() == best["error"]
    assert (tmp_path / "t" / "tradeoff.png").stat().st_size > 10_000
    # every effort with its unit (the 3-RRR's actuators are revolute)
    assert f"peak effort {best['worst_effort']:.4g} N m (limit 1.6 N m)" in out, out
    assert f"peak effort {base['worst_effort']:.4g} N m" in out, out


def test_the_default_kp_box_ends_at_the_sampled_data_stability_limit():
    """The default box went to kp = 1e6 whatever the sample time and the plants: with critical damping the loop
    x' = (1 - mu kp Ts^2/2) ... is stable while mu sqrt(kp) Ts < 1, so at Ts = 1 ms, plants drawn within 15 % of
    the model (mu up to 1/0.85) make kp <= (0.85 / 1 ms)^2 = 722,500 the limit; continuous control keeps 1e6."""
    from pkmlab.study.definition import scenario_tables
    from pkmlab.study.tuning import KP_RANGE, default_kp_range

    tables = scenario_tables(FAST)
    (lo, hi), reason = default_kp_range(tables, 0.15)
    assert lo == KP_RANGE[0] and 0.999 * 722_500 <= hi <= 722_500
    assert reason == "the sampled-data stability limit at Ts = 1 ms for plants drawn within 0.15 of the model"
    coarse = {**tables, "controller": {**tables["controller"], "sample_time": 0.004}}
    assert 0.999 * 62_500 <= default_kp_range(coarse)[0][1] <= 62_500  # (1 / 4 ms)^2
    continuous = {**tables, "controller": {**tables["controller"], "sample_time": 0.0}}
    assert default_kp_range(continuous) == (KP_RANGE, "")


def test_a_tuned_gain_at_an_end_of_its_box_is_said():
    from pkmlab.study.tuning import TuningResult

    def result(kp, zeta):
        best = {"kp": kp, "kv": 2 * zeta * math.sqrt(kp), "zeta": zeta}
        return TuningResult(1.0, 1.0, [], best, best, kp_range=(10.0, 722_000.0), zeta_range=(0.3, 3.0),
                            kp_range_reason="the sampled-data stability limit at Ts = 1 ms")

    assert result(1000.0, 1.0).on_bound == []
    (said,) = result(658_133.0, 1.0).on_bound
    assert said.startswith("the tuned kp = 658133 lies at the upper end of its search box (10 to 722000: the "
                           "sampled-data stability limit at Ts = 1 ms)")
    assert [s.split(" lies")[0] for s in result(11.0, 0.3).on_bound] == ["the tuned kp = 11", "the tuned zeta = 0.3"]


def test_a_search_box_without_the_scenarios_gains_is_searched_and_they_are_the_baseline_beside_it():
    result = pkmlab.tune(FAST, 5.0, kp_range=(2000.0, 1e5), trials=3, draws=0, workers=0, critical=True)
    trials = result.trials
    assert list(trials["trial"]) == [-1, 0, 1, 2]
    assert result.baseline["kp"] == 1000.0 and result.baseline["trial"] == -1
    assert result.best is not None and 2000.0 <= result.best["kp"] <= 1e5
    assert ((trials["kp"][1:] >= 2000.0) & (trials["kp"][1:] <= 1e5)).all()


@pytest.mark.parametrize("argv, message", [
    (["--trials", "0"], "--trials must be a positive number of candidates, got 0"),
    (["--draws", "-1"], "--draws must be 0 or more plants, got -1"),
    (["--quantile", "2"], "--quantile must be in (0, 1], got 2"),
    (["--uncertainty", "2"], "--uncertainty must be in [0, 1), got 2"),
    (["--kp-range", "1e5", "2000"], "--kp-range 100000 2000: give LO then HI"),
    (["--critical", "--zeta-range", "0.5", "0.6"], "--critical tunes kp alone with zeta = 1"),
])
def test_tune_names_the_option_it_refuses(tmp_path, capsys, argv, message):
    code, _out, err = run(capsys, "tune", FAST, "--max-effort", "1", "--out", tmp_path / "t", *argv)
    assert code == 1 and message in err and len(err.strip().splitlines()) == 1
    assert not (tmp_path / "t").exists()


@pytest.mark.parametrize("call, message", [
    (lambda: sweep(42), "study must be a Study, a study file or its tables"),
    (lambda: sweep(small_study(), chunk_size=0, workers=0), "chunk_size must be a positive integer"),
    (lambda: sweep(small_study(), workers=-1), "workers must be a non-negative integer"),
    (lambda: sweep(small_study(), workers="two"), "workers must be a non-negative integer"),
    (lambda: sweep(small_study(), heatmap=("controller.kv", "draw"), workers=0), "heatmap: 'controller.kv' is not"),
    (lambda: pkmlab.tune(FAST, -1.0), "max_effort must be a positive number"),
    (lambda: pkmlab.tune(FAST, 1.0, quantile=2.0), "quantile must be in (0, 1]"),
    (lambda: pkmlab.tune(FAST, 1.0, trials=0), "trials must be an integer"),
    (lambda: pkmlab.tune(FAST, 1.0, draws=-1), "draws must be an integer"),
    (lambda: pkmlab.tune(42, 1.0), "scenario must be a scenario file or its tables"),
    (lambda: pkmlab.tune(FAST, 1.0, kp_range=(10.0, 1.0)), "kp_range = (10, 1) is no box"),
    (lambda: pkmlab.tune(FAST, 1.0, zeta_range=(0.5,)), "zeta_range must be two positive numbers"),
])
def test_sweep_and_tune_refuse_bad_arguments_by_name(call, message):
    with pytest.raises(pkmlab.PkmlabError) as info:
        call()
    assert message in str(info.value) and "\n" not in str(info.value)
