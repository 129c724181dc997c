"""Benchmark rows: the accuracy-versus-speed frontier of the two plants, pkmlab's and MuJoCo's.

For each preset's default run, the same sampled-data controller (pkmlab's, on its own model) runs against

* pkmlab's plant (the exact reduced model, RK4 per sample): wall time, and its deviation from a
  tight reference — pkmlab's plant with 16 RK4 sub-steps per sample, whose own error is far below;
* MuJoCo's integration of the exported machine (:mod:`pkmlab.interop.mujoco_export`, RK4) at time steps of 2, 1,
  0.5 and 0.25 ms, with MuJoCo's default loop closures and its stiffest (solimp 0.9999, solref 2 ms):
  wall time, its largest loop-closure violation, and its deviation from the same reference.

A MuJoCo time step must divide the sample time (the effort changes at every sample): the 2 ms rows run the
scenario with a 2 ms sample time on both plants (their own reference), the others the scenario as it is.
Deviation is the largest distance between the two runs' tracked points (m). Wall times are medians of
``repeats`` runs in-process, after a first run that compiles.
"""

from __future__ import annotations

import statistics
import time
from pathlib import Path

import numpy as np

from pkmlab import load_scenario, paper_scenario, simulate
from pkmlab.interop.mujoco_plant import simulate_mujoco

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
RUNS = {"paper": lambda: paper_scenario("nominal"), "five_bar": "five_bar_circle.toml", "3rpr": "3rpr_circle.toml",
        "3prr": "3prr_circle.toml", "delta": "delta_pick_and_place.toml", "stewart": "stewart_motion.toml"}
TIMESTEPS = (2e-3, 1e-3, 5e-4, 2.5e-4)


def _scenario(name: str):
    make = RUNS[name]
    return make() if callable(make) else load_scenario(EXAMPLES / make)


def _median_time(fn, repeats: int):
    fn()  # compiles
    times = []
    result = None
    for _ in range(repeats):
        t0 = time.perf_counter()
        result = fn()
        times.append(time.perf_counter() - t0)
    return statistics.median(times), result


def _deviation(run, reference, spatial: bool) -> float:
    k = 3 if spatial else 2
    return float(np.linalg.norm(run.pose[:, :k] - reference.pose[:, :k], axis=1).max())


def frontier_rows(h, quick: bool) -> tuple[list[dict], dict]:
    """Rows ``frontier_<preset>_<plant>_<setting>_<step>`` (wall time) with their accuracy in the checks."""
    repeats = 1 if quick else 3
    rows: list[dict] = [h.section_row("two plants, one controller: wall time, loop-closure violation, deviation "
                                      "from a tight pkmlab reference")]
    checks: dict = {}
    for name in RUNS:
        base = _scenario(name)
        spatial = bool(getattr(getattr(base.model, "description", None), "spatial", False))
        entries, references = [], {}
        for step in TIMESTEPS:
            scenario = base if step <= base.sample_time else base.replace(sample_time=step)
            ts = scenario.sample_time
            if ts not in references:  # pkmlab's plant once per sample time, and the reference there
                references[ts] = reference = simulate(scenario.replace(substeps=16))
                seconds, ours = _median_time(lambda s=scenario: simulate(s), repeats)
                entries.append({"plant": "pkmlab", "setting": "exact", "step_ms": ts * 1e3, "wall_s": seconds,
                                "violation_m": 0.0, "deviation_m": _deviation(ours, reference, spatial)})
            reference = references[ts]
            for setting in ("default", "stiff"):
                try:
                    seconds, run = _median_time(lambda s=scenario, st=setting, dt=step: simulate_mujoco(
                        s, timestep=dt, closures="stiff" if st == "stiff" else "soft"), repeats)
                except Exception as exc:  # an unstable setting is a result too
                    entries.append({"plant": "mujoco", "setting": setting, "step_ms": step * 1e3,
                                    "failed": f"{type(exc).__name__}: {exc}"})
                    continue
                entries.append({"plant": "mujoco", "setting": setting, "step_ms": step * 1e3, "wall_s": seconds,
                                "violation_m": float(run.closure_violation.max()),
                                "deviation_m": _deviation(run, reference, spatial)})
        checks[name] = entries
        for e in entries:
            key = f"frontier_{name}_{e['plant']}_{e['setting']}_{e['step_ms']:g}ms"
            label = (f"{name}: {e['plant']} plant, {e['setting']}, step {e['step_ms']:g} ms")
            if "failed" in e:
                rows.append(h.metric_row(key, label + f" FAILED ({e['failed'][:60]})", float("nan"), ""))
                continue
            rows.append(h.metric_row(key, label + f" (violation {e['violation_m']:.1e} m, deviation "
                                     f"{e['deviation_m']:.1e} m)", e["wall_s"] * 1e3, "ms"))
    return rows, checks


#: The runs of the MuJoCo plant timed against MuJoCo's own stepping of the same model.
PLANT_RUNS = ("paper", "delta", "stewart")


def plant_rows(h, quick: bool) -> tuple[list[dict], dict]:
    """Rows ``mujoco_plant_<preset>`` (the default run on the MuJoCo plant, pkmlab's controller stepping MuJoCo from
    compiled code), ``mujoco_replay_<preset>`` (MuJoCo alone stepping the same exported model from the same state
    with that run's efforts, precomputed: ``mujoco.rollout``, no Python per step) and their ratio; in the checks,
    the largest difference between the two runs' configurations (the plant steps MuJoCo as its own loop does: 0)."""
    import mujoco
    from mujoco import rollout

    from pkmlab.interop import mujoco_export as mx
    from pkmlab.simulation.run import prepare_run

    repeats = 1 if quick else 9
    rows: list[dict] = [h.section_row("the MuJoCo plant against MuJoCo stepping the same model with the run's "
                                      "efforts precomputed")]
    checks: dict = {}
    for name in PLANT_RUNS:
        scenario = _scenario(name)
        run = simulate_mujoco(scenario)  # compiles
        plant, step = scenario.plant_model, min(scenario.sample_time, 1e-3)
        steps = round(scenario.sample_time / step)
        m, d = mx.load_mujoco(plant, prepare_run(scenario).q_plant0, timestep=step, drives=scenario.drives)
        spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
        start = np.empty(mujoco.mj_stateSize(m, spec))
        mujoco.mj_getState(m, d, start, spec)
        efforts = np.ascontiguousarray(np.repeat(run.tau[:-1], steps, axis=0))  # held over each sample
        plant_times, replay_times = [], []
        for _ in range(repeats):  # the two interleaved: a slower spell of the machine slows both
            t0 = time.perf_counter()
            run = simulate_mujoco(scenario)
            t1 = time.perf_counter()
            states, _sensors = rollout.rollout(m, d, start, efforts[None])
            plant_times.append(t1 - t0)
            replay_times.append(time.perf_counter() - t1)
        seconds, replay_seconds = statistics.median(plant_times), statistics.median(replay_times)
        q = []
        for state in states[0, steps - 1::steps]:
            mujoco.mj_setState(m, d, state, spec)
            q.append(mx.q_from_qpos(plant, d.qpos))
        checks[name] = {"plant_ms": seconds * 1e3, "replay_ms": replay_seconds * 1e3, "steps": len(efforts),
                        "max_q_difference": float(np.abs(np.array(q) - run.q[1:]).max())}
        rows.append(h.metric_row(f"mujoco_plant_{name}", f"{name}: default run on the MuJoCo plant ({len(efforts)} "
                                 "steps), in-process", seconds * 1e3, "ms"))
        rows.append(h.metric_row(f"mujoco_replay_{name}", f"{name}: MuJoCo alone, the same model and steps, the run's "
                                 "efforts precomputed (rollout)", replay_seconds * 1e3, "ms"))
        rows.append(h.metric_row(f"ratio_mujoco_plant_{name}", f"ratio: {name}'s MuJoCo plant run / MuJoCo alone",
                                 seconds / replay_seconds, "x"))
    return rows, checks
