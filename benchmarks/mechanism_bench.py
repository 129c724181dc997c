"""Benchmarks per described mechanism (rows of ``make bench``, after the paper's cases).

For each preset — the paper's 3-RRR through the generic pipeline (its description's generated
kernels and :mod:`pkmlab.codegen.core`'s compiled loop), the five-bar, the 3-RPR and the 3-PRR:

* forward kinematics, every assembly mode (:func:`pkmlab.algorithms.assembly.assembly_modes`,
  once per actuator vector, at actuators of random reachable poses): solves per second;
* one evaluation of the actuator-space model ``(Mθ, cθ, gθ)``: the compiled core over a batch of
  states, and the public function once per state;
* the default run in-process (``simulate`` of the example scenario, or for the 3-RRR the paper's
  nominal case through the generic pipeline), its compiled loop alone, and the loop's time per
  sample against the paper's nominal loop per sample (``sim_nominal_loop``) measured in the same run.

And for the redundantly actuated machines (a 4-RRR, the paper's 3-RRR with a fourth leg, a Delta on four arms) the
first run and the loop per sample for each distribution against their twin's (the 3-RRR's, the Delta's).

And for the catalogue's machines (``examples/mechanisms``: a 3-PRS, a 3-RPS, a 3-UPU, a 3-UPU wrist, the Agile
Eye, a 3-RRS, a 6-RUS, a 6-PUS, a 3-PUU, a 3-PRRR, a 4-RUU, a 3-CRR) the same rows, their loop per sample against
the preset's with as many legs (the Delta's, the Stewart platform's, or for the planar 3-PRRR the paper's 3-RRR) in
the same run, and the general forward kinematics (:mod:`pkmlab.algorithms.general_fk`): its generic instance solved
by monodromy the first time (then read from the cache), and, for the Delta and the Stewart platform, the ratio of
their fast paths to it at the same actuators.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import operation_count

import pkmlab
from pkmlab.algorithms import assembly
from pkmlab.control.trajectory import paper_trajectory
from pkmlab.formats.scenario import load_scenario
from pkmlab.model import mechanism_model as mm
from pkmlab.simulation.run import prepare_run, simulate
from pkmlab.simulation.scenario import Scenario

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
DEFAULT_RUNS = {"paper": None, "five_bar": "five_bar_circle.toml", "3rpr": "3rpr_circle.toml",
                "3prr": "3prr_circle.toml", "delta": "delta_pick_and_place.toml", "stewart": "stewart_motion.toml",
                "3prs": "mechanisms/3prs_motion.toml", "3rps": "mechanisms/3rps_motion.toml",
                "3upu": "mechanisms/3upu_motion.toml", "3rrs": "mechanisms/3rrs_motion.toml",
                "6rus": "mechanisms/6rus_motion.toml", "6pus": "mechanisms/6pus_motion.toml",
                "3upu_wrist": "mechanisms/3upu_wrist_motion.toml", "agile_eye": "mechanisms/agile_eye_motion.toml",
                "3prrr": "mechanisms/3prrr_motion.toml", "3puu": "mechanisms/3puu_motion.toml",
                "4ruu": "mechanisms/4ruu_motion.toml", "3crr": "mechanisms/3crr_motion.toml"}
#: The catalogue's machines, each compared with the preset of as many legs.
CATALOGUE = {"3prs": "delta", "3rps": "delta", "3upu": "delta", "3rrs": "delta", "6rus": "stewart",
             "6pus": "stewart", "3upu_wrist": "delta", "agile_eye": "delta", "3prrr": "paper",
             "3puu": "delta", "4ruu": "delta", "3crr": "delta"}
#: Forward kinematics of every assembly mode solves a polynomial system (the Stewart–Gough platform's: 128
#: homotopy paths, ~0.3 s): fewer samples there.
FK_SAMPLES = {"stewart": 4, "3prs": 4, "3rps": 4, "3upu": 4, "3rrs": 4, "6rus": 4, "6pus": 4, "3upu_wrist": 4,
              "agile_eye": 4, "3puu": 4, "4ruu": 4, "3crr": 4}


def _scenario(name: str) -> Scenario:
    if DEFAULT_RUNS[name] is None:
        return Scenario(mm.MechanismModel.from_preset("paper"), paper_trajectory(0.2), name="paper nominal")
    return load_scenario(EXAMPLES / DEFAULT_RUNS[name])


def _actuator_samples(model, scenario: Scenario, count: int, rng) -> list[np.ndarray]:
    """Actuators of random poses near the default run's path, reachable in its working mode."""
    prep = prepare_run(scenario)
    out = []
    while len(out) < count:
        k = int(rng.integers(prep.t.size))
        pose = prep.desired.pose[k] + rng.normal(0.0, 0.01, prep.desired.pose.shape[1])
        try:
            out.append(mm.inverse_kinematics(model, pose, prep.mode)[:model.n_actuators])
        except pkmlab.errors.PkmlabError:
            continue
    return out


def _rows_for(h, name: str, repeats: int, rng, paper_loop_per_sample_s: float | None,
              count: dict | None, speed: dict | None) -> tuple[list[dict], dict]:
    scenario = _scenario(name)
    model = scenario.model
    label = f"{name} ({model.description.notation})"
    rows = []
    seconds, result = h.time_once(lambda: simulate(scenario))
    rows.append(h.first_call_row(f"mech_{name}_first_run", f"{label}: first default run in this process", seconds))
    actuators = _actuator_samples(model, scenario, FK_SAMPLES.get(name, 20 if repeats < 5 else 200), rng)
    if getattr(model.description, "spatial", False) and name in ("delta", "stewart", *CATALOGUE):
        from pkmlab.algorithms.general_fk import solve_generic_instance

        seconds, (solutions, _p, loops) = h.time_once(lambda: solve_generic_instance(model.description))
        rows.append(h.first_call_row(f"mech_{name}_fk_generic", f"{label}: general FK, its generic instance by "
                                     f"monodromy ({len(solutions)} solutions, {loops} loops; once per machine)",
                                     seconds))
    times, _ = h.time_runs(lambda: [assembly.assembly_modes(model, t) for t in actuators], repeats)
    rows.append(h.rate_row(f"mech_{name}_fk", f"{label}: forward kinematics, every assembly mode", times,
                           len(actuators), "solve", compare=False))
    if name in ("delta", "stewart"):
        general_times, _ = h.time_runs(lambda: [assembly.general_spatial_assembly_modes(model, t)
                                                for t in actuators], repeats)
        rows.append(h.rate_row(f"mech_{name}_fk_general", f"{label}: forward kinematics, the general method",
                               general_times, len(actuators), "solve", compare=False))
        rows.append(h.metric_row(f"mech_{name}_fk_fast_vs_general", f"{label}: its fast path's time / the general "
                                 "method's", float(np.median(times)) / float(np.median(general_times)), "x"))
    stride = max(1, result.q.shape[0] // 100)
    q, rates = result.q[::stride], result.theta_dot[::stride]
    k = model.kernels
    q, rates = np.ascontiguousarray(q), np.ascontiguousarray(rates)
    n = model.n_actuators
    out = (np.empty((len(q), n, n)), np.empty((len(q), n)), np.empty((len(q), n)))
    times, _ = h.time_runs(lambda: k.actuator_space_models(q, rates, model.P, *out), repeats)
    rows.append(h.rate_row(f"mech_{name}_dynamics_kernel", f"{label}: (Mθ, cθ, gθ), compiled core over a batch",
                           times, len(q), "state", compare=False))
    times, _ = h.time_runs(lambda: [mm.actuator_space_model(model, qq, w) for qq, w in zip(q, rates, strict=True)],
                           repeats)
    rows.append(h.rate_row(f"mech_{name}_dynamics_api", f"{label}: (Mθ, cθ, gθ), mechanism_model API per call",
                           times, len(q), "state", compare=False))
    times, _ = h.time_runs(lambda: simulate(scenario), repeats)
    samples = result.t.size
    rows.append(h.rate_row(f"mech_{name}_run", f"{label}: default run, simulate() in-process ({samples} samples)",
                           times, 1, "run", compare=False))
    prep = prepare_run(scenario)
    d = prep.desired
    N = len(prep.q_ctrl0)

    def loop():
        return k.sampled_data_loop(scenario.sample_time, scenario.substeps, d.theta, d.theta_dot, d.theta_ddot,
                                   prep.q_plant0, prep.q_ctrl0, scenario.plant_model.P, model.P, prep.kind, prep.kp,
                                   prep.kv, prep.distribution, prep.singularity_guard, *prep.realism,
                                   np.zeros((samples, N)),
                                   np.zeros((samples, n)), np.zeros((samples, n)), np.zeros(samples), np.zeros((0, n)))

    times, _ = h.time_runs(loop, repeats)
    rows.append(h.rate_row(f"mech_{name}_loop", f"{label}: compiled sampled-data loop only", times, samples - 1,
                           "sample", compare=False))
    per_sample = float(np.median(times)) / (samples - 1)
    summary = result.summary()
    checks = {"samples": samples, "loop_per_sample_us": per_sample * 1e6,
              "max_path_error_m": summary["max_path_error_m"], "peak_effort": summary["peak_effort"]}
    if count and speed:
        limit = operation_count.limit_per_sample(count, speed)
        checks.update({"operations_per_sample": count["operations_per_sample"],
                       "libm_calls_per_sample": count["libm_calls_per_sample"],
                       "arithmetic_limit_per_sample_us": limit * 1e6, "loop_vs_arithmetic_limit": per_sample / limit})
        rows.append(h.metric_row(f"mech_{name}_arith_limit", f"{label}: arithmetic limit per sample "
                                 f"({count['operations_per_sample']:.0f} operations + "
                                 f"{count['libm_calls_per_sample']:.0f} libm calls)", limit * 1e6, "us"))
        rows.append(h.metric_row(f"mech_{name}_loop_vs_limit", f"{label}: loop per sample / its arithmetic limit",
                                 per_sample / limit, "x"))
    if paper_loop_per_sample_s:
        ratio = per_sample / paper_loop_per_sample_s
        checks["loop_per_sample_vs_paper_nominal"] = ratio
        rows.append(h.metric_row(f"mech_{name}_loop_ratio", f"{label}: loop per sample / the paper's nominal loop "
                                 "per sample", ratio, "x"))
    return rows, checks


def mechanism_rows(h, quick: bool, paper_loop_per_sample_s: float | None, counts: dict | None = None,
                   speed: dict | None = None) -> tuple[list[dict], dict]:
    """Rows per mechanism; ``paper_loop_per_sample_s`` is the paper's nominal loop per sample in this run,
    ``counts`` every preset's operation count (:mod:`operation_count`) and ``speed`` this machine's measured
    scalar throughput (:func:`simulation_bench.scalar_throughput`), both from the simulation's rows."""
    rng = np.random.default_rng(7)
    rows: list[dict] = [h.section_row("every mechanism (generated kernels, one compiled core)")]
    checks: dict = {}
    for name in DEFAULT_RUNS:
        more, checks[name] = _rows_for(h, name, 3 if quick else 7, rng, paper_loop_per_sample_s,
                                       (counts or {}).get(name), speed)
        rows += more
    for name, preset_name in CATALOGUE.items():
        ratio = checks[name]["loop_per_sample_us"] / checks[preset_name]["loop_per_sample_us"]
        checks[name][f"loop_per_sample_vs_{preset_name}"] = ratio
        rows.append(h.metric_row(f"mech_{name}_loop_vs_{preset_name}", f"{name}: loop per sample / the "
                                 f"{preset_name}'s (as many legs)", ratio, "x"))
    if not all(math.isfinite(c["max_path_error_m"]) for c in checks.values()):
        raise AssertionError("a default run did not finish")
    more, checks["stewart_40"] = _forty_poses_rows(h, 3 if quick else 7)
    rows += more
    more, checks["general_leg"] = _general_leg_rows(h, 3 if quick else 7)
    rows += more
    more, checks["time_optimal"] = _time_optimal_rows(h, 3 if quick else 7)
    rows += more
    more, checks["identification"] = _identification_rows(h, 3 if quick else 5)
    rows += more
    more, checks["calibration"] = _calibration_rows(h, 3 if quick else 5)
    rows += more
    more, checks["redundant"] = _redundant_rows(h, 3 if quick else 7, paper_loop_per_sample_s,
                                                checks["delta"]["loop_per_sample_us"] * 1e-6)
    return rows + more, checks


#: The catalogue's redundantly actuated machines' default runs, each against the machine of as many legs less one
#: (the driven elbow's: the paper's, of as many legs; the driven knee's: none of the presets).
REDUNDANT_RUNS = {"4rrr": ("mechanisms/4rrr_motion.toml", "paper"),
                  "3rrr_redundant": ("mechanisms/3rrr_redundant_motion.toml", "paper"),
                  "3rrr_elbow": ("mechanisms/3rrr_elbow_motion.toml", "paper"),
                  "3rrs_knee": ("mechanisms/3rrs_knee_motion.toml", None),
                  "4delta": ("mechanisms/4delta_motion.toml", "delta")}


def _redundant_rows(h, repeats: int, paper_loop_per_sample_s: float | None, delta_loop_per_sample_s: float
                    ) -> tuple[list[dict], dict]:
    """The redundantly actuated machines' default runs: the first run, the compiled loop per sample (in the pose,
    the efforts distributed with the least 2-norm; for the 4-RRR also weighted and preloaded) against its twin's
    (the paper's 3-RRR, the Delta) measured in this run; the 4-RRR's also with the least peak (the minimum ∞-norm,
    solved in the loop for its one internal effort), and that linear program per call of
    :func:`pkmlab.distribute_efforts` (SciPy's HiGHS)."""
    from pkmlab.simulation.run import loop_motion

    rows, checks = [], {}
    twins = {"paper": paper_loop_per_sample_s, "delta": delta_loop_per_sample_s}
    for name, (path, twin) in REDUNDANT_RUNS.items():
        scenario = load_scenario(EXAMPLES / path)
        model = scenario.model
        label = f"{name} ({model.description.notation}, {model.n_actuators} actuators for {model.dof} coordinates)"
        seconds, result = h.time_once(lambda scenario=scenario: simulate(scenario))
        rows.append(h.first_call_row(f"mech_{name}_first_run", f"{label}: first default run in this process", seconds))
        shares = {"minimum_norm": scenario}
        if name == "4rrr":
            n = model.n_actuators
            for method, extra in (("weighted", dict(weights=(1.0, 1.0, 4.0, 4.0))),
                                  ("preload", dict(preload=(1.5, -1.5, 1.5, -1.5)[:n])), ("minimum_peak", {})):
                shares[method] = scenario.replace(controller=pkmlab.ControllerSpec(
                    kp=scenario.controller.kp, distribution=method, **extra))
        for method, run in shares.items():
            prep = prepare_run(run)
            k, d, samples = model.kernels, prep.desired, result.t.size
            outs = (np.zeros((samples, len(prep.q_ctrl0))), np.zeros((samples, k.N_INDEPENDENT)),
                    np.zeros((samples, model.n_actuators)), np.zeros(samples), np.zeros((0, model.n_actuators)))

            desired = loop_motion(model, d)

            def loop(run=run, prep=prep, desired=desired, k=k, outs=outs):
                return k.sampled_data_loop(run.sample_time, run.substeps, *desired, prep.q_plant0, prep.q_ctrl0,
                                           run.plant_model.P, run.model.P, prep.kind, prep.kp, prep.kv,
                                           prep.distribution, prep.singularity_guard, *prep.realism, *outs)

            times, _ = h.time_runs(loop, repeats)
            rows.append(h.rate_row(f"mech_{name}_loop_{method}", f"{label}: compiled sampled-data loop, efforts "
                                   f"distributed ({method})", times, samples - 1, "sample", compare=False))
            per_sample = float(np.median(times)) / (samples - 1)
            checks[f"{name}_{method}_loop_per_sample_us"] = per_sample * 1e6
            if twins.get(twin):
                ratio = per_sample / twins[twin]
                checks[f"{name}_{method}_loop_vs_{twin}"] = ratio
                rows.append(h.metric_row(f"mech_{name}_loop_{method}_vs_{twin}", f"{name} ({method}): loop per "
                                         f"sample / the {twin}'s nominal loop per sample", ratio, "x"))
        checks[f"{name}_max_path_error_m"] = result.summary()["max_path_error_m"]
    rrrr = load_scenario(EXAMPLES / REDUNDANT_RUNS["4rrr"][0]).model
    prep = prepare_run(load_scenario(EXAMPLES / REDUNDANT_RUNS["4rrr"][0]))
    states = prep.desired.q[::20]
    wrenches = [(pkmlab.pose_space_model(rrrr, q, np.zeros(3)).W, np.array([1.0, -0.5, 0.1])) for q in states]
    times, _ = h.time_runs(lambda: [pkmlab.distribute_efforts(W, f, "minimum_peak") for W, f in wrenches], repeats)
    rows.append(h.rate_row("mech_4rrr_minimum_peak", "4rrr: minimum ∞-norm distribution, a linear program (SciPy's "
                           "HiGHS), per call of distribute_efforts", times, len(wrenches), "call", compare=False))
    checks["4rrr_minimum_peak_per_call_us"] = float(np.median(times)) / len(wrenches) * 1e6
    return rows, checks


#: Dietmaier's Stewart-Gough platform and leg lengths with 40 real poses (examples/stewart_dietmaier.toml).
DIETMAIER_THETA = [1.0, 0.645275, 1.086284, 1.503439, 1.281933, 0.771071]


def _forty_poses_rows(h, repeats: int) -> tuple[list[dict], dict]:
    """Forward kinematics of a general Stewart-Gough platform at actuators with 40 real poses: its fast path
    (the 128-path total-degree homotopy) and the general method (the parameter homotopy of 40 paths)."""
    from pkmlab.algorithms.general_fk import generic_solutions

    model = pkmlab.load(EXAMPLES / "stewart_dietmaier.toml")
    theta = np.array(DIETMAIER_THETA)
    generic_solutions(model.description)  # its monodromy, once per machine (the rows above time one)
    fast, found_fast = h.time_runs(lambda: assembly.assembly_modes(model, theta), repeats)
    general, found = h.time_runs(lambda: assembly.general_spatial_assembly_modes(model, theta), repeats)
    if len(found) != 40 or len(found_fast) != 40:
        raise AssertionError(f"Dietmaier's platform: {len(found_fast)} and {len(found)} poses, not 40")
    rows = [h.rate_row("mech_stewart40_fk", "Stewart platform, 40 real poses: forward kinematics, fast path", fast, 1,
                       "solve", compare=False),
            h.rate_row("mech_stewart40_fk_general", "Stewart platform, 40 real poses: the general method", general, 1,
                       "solve", compare=False),
            h.metric_row("mech_stewart40_fk_fast_vs_general", "Stewart platform, 40 real poses: fast path's time / "
                         "the general method's", float(np.median(fast)) / float(np.median(general)), "x")]
    return rows, {"fast_s": float(np.median(fast)), "general_s": float(np.median(general))}


def _general_leg_rows(h, repeats: int) -> tuple[list[dict], dict]:
    """Inverse kinematics of a leg without a closed form (an R*RRS leg: the 6-RUS's universal joints split into
    two hinges 2 cm apart), every real solution at 1,000 points by the general method, against the R*US leg's
    closed form at the same points."""
    import dataclasses

    from pkmlab.description import general_legs, spatial_legs
    from pkmlab.description.files import load_mechanism
    from pkmlab.description.spatial import SpatialBody, SpatialJoint

    rus = load_mechanism(EXAMPLES / "mechanisms" / "6rus.toml").legs[0]
    a1, a2 = (np.array(a) for a in rus.joints[1].axes)
    offset = 0.02 * np.cross(a1, a2) / np.linalg.norm(np.cross(a1, a2))
    leg = dataclasses.replace(
        rus, joints=(rus.joints[0], SpatialJoint("R", False, (tuple(a1),)), SpatialJoint("R", False, (tuple(a2),)),
                     rus.joints[2]),
        bodies=(rus.bodies[0], SpatialBody(tuple(offset), 0.05, tuple(offset / 2), ((1e-5, 0, 0), (0, 1e-5, 0),
                                                                                  (0, 0, 1e-5))), rus.bodies[1]))
    rng = np.random.default_rng(3)
    q = rng.uniform(-0.8, 0.8, (1000, 3))
    points = general_legs.leg_points(leg, q)[0]
    general_legs.general_leg(leg)  # its monodromy, once per leg (kept in the cache)

    def general():
        general_legs._solved.cache_clear()  # every repeat solves anew
        return general_legs.real_solutions(leg, points)

    times, found = h.time_runs(general, repeats)
    closed, _ = h.time_runs(lambda: spatial_legs.leg_inverse_kinematics_batch(rus, 0, points, 1), repeats)
    per_point = float(np.median(times)) / len(points)
    rows = [h.rate_row("leg_ik_general_rrrs", "an R*RRS leg: every real solution by the general method (1,000 "
                       "points)", times, len(points), "point", compare=False),
            h.rate_row("leg_ik_closed_rus", "an R*US leg: its closed form, one working mode (1,000 points)", closed,
                       len(points), "point", compare=False),
            h.metric_row("leg_ik_general_vs_closed", "leg inverse kinematics: the general method's time / a closed "
                         "form's", float(np.median(times)) / float(np.median(closed)), "x")]
    return rows, {"per_point_s": per_point, "mean_solutions": float(np.mean([len(f) for f in found]))}


def _measured_poses(true, offsets, count: int, rng) -> tuple[np.ndarray, np.ndarray]:
    """``count`` poses of the machine ``true`` around its home configuration and its actuators' readings there."""
    from pkmlab.algorithms.calibration import reachable_poses

    poses, q = reachable_poses(true, count, rng)
    return poses, q[:, :true.n_actuators] - offsets


def _calibration_rows(h, repeats: int) -> tuple[list[dict], dict]:
    """Kinematic calibration of a Stewart platform whose geometry is off by up to 1 mm: from 50 whole poses
    measured with 10 µm noise (the issue's target: under 2 s), and the D-optimal choice of 50 poses among 2,000
    candidates (under 5 s)."""
    from pkmlab.algorithms import calibration as cal

    rng = np.random.default_rng(11)
    model = mm.MechanismModel.from_preset("stewart")
    true, offsets = cal.perturbed_geometry(model, rng, 1e-3)
    poses, thetas = _measured_poses(true, offsets, 50, rng)
    measured = poses + 1e-5 * rng.standard_normal(poses.shape)
    times, result = h.time_runs(lambda: cal.calibrate(model, thetas, measured, measure="pose"), repeats)
    candidates, readings = _measured_poses(model, np.zeros(model.n_actuators), 2000, rng)
    select_times, _chosen = h.time_runs(lambda: cal.select_poses(model, readings, candidates, 50, measure="pose"),
                                        1, warmup=0)
    rows = [h.rate_row("calibrate_stewart_50", "calibration of a Stewart platform from 50 measured poses (1 mm "
                       "errors, 10 um noise)", times, 1, "calibration", compare=False),
            h.metric_row("calibrate_stewart_rms_after", "its RMS residual after / the measurement noise",
                         result.rms_after / 1e-5, "x"),
            h.rate_row("select_poses_stewart_2000", "D-optimal choice of 50 poses among 2,000 candidates (Stewart)",
                       select_times, 1, "selection", compare=False)]
    return rows, {"calibrate_s": float(np.median(times)), "rms_before_m": result.rms_before,
                  "rms_after_m": result.rms_after, "select_s": select_times[0]}


def _identification_rows(h, repeats: int) -> tuple[list[dict], dict]:
    """Dynamic identification of the paper's machine: the excitation trajectory optimised (5 harmonics of a 10 s
    period, once), and the whole job on its 10 s logged at 1 kHz with 1 % effort noise — the log filtered, the
    base parameters found and estimated (the issue's target: under 1 s)."""
    from pkmlab.algorithms.identification import filter_measurements, identify
    from pkmlab.algorithms.regressor import base_parameters
    from pkmlab.control.excitation import excitation_trajectory

    model = mm.MechanismModel.from_preset("paper")
    excite_times, excitation = h.time_runs(lambda: excitation_trajectory(model, iterations=40), 1, warmup=0)
    motion = excitation.motion(model, 1000.0)
    tau = pkmlab.inverse_dynamics(model, motion.q, motion.theta_dot, motion.theta_ddot)
    tau = tau + 0.01 * np.abs(tau).max() * np.random.default_rng(0).standard_normal(tau.shape)

    def job():
        data = filter_measurements(model, motion.t, motion.theta, tau, pose=motion.pose[0], mode=excitation.mode,
                                   efforts="sampled")  # the efforts at the samples' instants
        return identify(model, *data.states, data.tau, base=base_parameters(model))

    times, result = h.time_runs(job, repeats)
    large = np.abs(result.estimate) > 1e-3 * np.abs(result.estimate).max()  # the rest are zero in truth
    rows = [h.rate_row("excite_paper", "excitation trajectory of the paper's machine (5 harmonics, 40 iterations)",
                       excite_times, 1, "optimisation", compare=False),
            h.metric_row("excite_paper_condition", "its condition number / the random start's",
                         excitation.condition_number / excitation.start_condition_number, "x"),
            h.rate_row("identify_paper_10s", "identification of the paper's machine: 10 s at 1 kHz filtered, base "
                       "parameters found and estimated", times, 1, "identification", compare=False),
            h.metric_row("identify_paper_max_relative_sigma", "its largest relative sigma of a base parameter",
                         float(result.relative_sigma[large].max()), "%")]
    return rows, {"excite_s": excite_times[0], "condition_number": excitation.condition_number,
                  "start_condition_number": excitation.start_condition_number,
                  "identify_s": float(np.median(times)), "samples": len(motion.t)}


def _time_optimal_rows(h, repeats: int) -> tuple[list[dict], dict]:
    """The time-optimal timing of the paper's circle (``examples/time_optimal_circle.toml``'s limits): one solve
    of its 400 intervals, and the duration it gives against the path's own."""
    from pkmlab.control.time_optimal import time_optimal

    model = mm.MechanismModel.from_preset("paper")
    path = paper_trajectory(0.2)

    def solve():
        return time_optimal(path, model, (-1, 1, -1), velocity=2.0, effort=0.5)

    times, retimed = h.time_runs(solve, repeats)
    rows = [h.rate_row("time_optimal_paper_circle", "time-optimal timing of the paper's circle (400 intervals, "
                       "2 rad/s, 0.5 N m)", times, 1, "solve", compare=False),
            h.metric_row("time_optimal_paper_circle_duration", "its duration / the path's own timing",
                         retimed.duration / path.duration, "x")]
    return rows, {"duration_s": retimed.duration, "own_duration_s": path.duration,
                  "solve_s": float(np.median(times))}
