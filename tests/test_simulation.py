"""Trajectories, controllers and closed-loop runs (paper §4–5, conventions §3–§8)."""

import csv
import json

import numpy as np
import pytest

import pkmlab
from pkmlab.cli import main
from pkmlab.control.controller import ControllerSpec
from pkmlab.control.trajectory import Circle, Line, Trajectory, WaypointTrajectory, paper_trajectory
from pkmlab.errors import (
    AssemblyError,
    BranchFollowingError,
    InvalidParameterError,
    PkmlabError,
    SingularityError,
    UnreachablePoseError,
)
from pkmlab.formats.scenario import paper_scenario
from pkmlab.paper import dynamics as paper_dynamics
from pkmlab.paper import kinematics as kin
from pkmlab.paper.geometry import Planar3RRR
from pkmlab.paper.kinematics import coordinates_to_3rrr, desired_joint_motion
from pkmlab.paper.plant import ReducedPlant
from pkmlab.simulation.result import COLUMNS
from pkmlab.simulation.run import simulate
from pkmlab.simulation.scenario import Scenario, scaled_model


@pytest.fixture(scope="module")
def paper_runs():
    return {name: simulate(paper_scenario(name)) for name in ("nominal", "disturbed", "fast")}


# ------------------------------------------------------------------ trajectories
def test_paper_circle_follows_spec_section_4():
    tr = paper_trajectory(0.2)
    L = 2 * np.pi * 0.05
    assert tr.duration == pytest.approx(L / 0.2)
    pose, vel, acc = tr.desired(np.array([0.0, tr.duration / 2, tr.duration]))
    np.testing.assert_allclose(pose[0], [0.20, 0.21, 0.0], atol=1e-15)  # leftmost point
    np.testing.assert_allclose(pose[1], [0.30, 0.21, 0.0], atol=1e-15)  # half way: rightmost point
    np.testing.assert_allclose(pose[2], [0.20, 0.21, 0.0], atol=1e-15)  # one full turn
    np.testing.assert_allclose(vel[[0, 2]], 0, atol=1e-15)  # rest at both ends
    # s(t) = L (3τ² - 2τ³): speed at mid-time 1.5 L / T, counter-clockwise (going down at the leftmost point... up)
    assert np.hypot(*vel[1, :2]) == pytest.approx(1.5 * L / tr.duration)
    assert vel[1, 1] > 0  # counter-clockwise: moving up at the rightmost point


@pytest.mark.parametrize("traj", [
    paper_trajectory(0.3),
    Trajectory(Circle((0.25, 0.2), 0.03, start_angle=0.5, alpha=-0.1, alpha_end=0.2), 0.1, "quintic"),
    Trajectory(Line((0.2, 0.18, 0.0), (0.3, 0.24, 0.3)), 0.15, "quintic"),
    WaypointTrajectory(((0.2, 0.2, 0.0), (0.28, 0.2, 0.1), (0.25, 0.25, -0.1)), 0.1),
])
def test_desired_derivatives_are_exact(paper, traj):
    """Pose and joint velocities/accelerations against differences of pose and IK (Richardson)."""
    t = np.linspace(0.05, traj.duration - 0.05, 7)
    pose, vel, acc = traj.desired(t)
    jm = desired_joint_motion(paper, traj, (-1, 1, -1), t)

    def fd(fun, h):
        d1 = lambda hh: (fun(t + hh) - fun(t - hh)) / (2 * hh)  # noqa: E731
        d2 = lambda hh: (fun(t + hh) - 2 * fun(t) + fun(t - hh)) / hh**2  # noqa: E731
        return (4 * d1(h / 2) - d1(h)) / 3, (4 * d2(h / 2) - d2(h)) / 3

    v_num, a_num = fd(lambda tt: traj.desired(tt)[0], 1e-3)
    np.testing.assert_allclose(vel, v_num, atol=1e-9)
    np.testing.assert_allclose(acc, a_num, atol=1e-6)
    theta = lambda tt: np.unwrap(kin.inverse_kinematics(paper, traj.desired(tt)[0], mode=(-1, 1, -1)).theta, axis=0)  # noqa: E731
    td_num, tdd_num = fd(theta, 1e-3)
    np.testing.assert_allclose(jm.theta_dot, td_num, atol=1e-8)
    np.testing.assert_allclose(jm.theta_ddot, tdd_num, atol=1e-5)


def test_quintic_law_starts_and_ends_with_zero_acceleration():
    tr = Trajectory(Line((0.2, 0.2, 0.0), (0.3, 0.2, 0.0)), 0.1, "quintic")
    _p, v, a = tr.desired(np.array([0.0, tr.duration]))
    np.testing.assert_allclose(v, 0, atol=1e-15)
    np.testing.assert_allclose(a, 0, atol=1e-12)


@pytest.mark.parametrize("bad", [dict(speed=0.0), dict(speed=np.nan), dict(law="linear")])
def test_bad_trajectory_parameters_are_refused(bad):
    kwargs = dict(path=Circle((0.25, 0.21), 0.05), speed=0.2, law="cubic") | bad
    with pytest.raises(InvalidParameterError):
        Trajectory(**kwargs)


# ------------------------------------------------------------------ closed loop
def test_exact_model_continuous_time_tracks_to_integration_level(paper):
    """Consistency of controller model, plant and trajectory derivatives (issue acceptance)."""
    result = simulate(paper_scenario("nominal").replace(sample_time=0.0))
    assert result.summary()["max_path_error_m"] < 1e-8
    assert result.summary()["max_joint_error_rad"] < 1e-8


def test_sampled_data_results_show_what_the_paper_reports(paper_runs):
    nominal, disturbed, fast = (paper_runs[k].summary() for k in ("nominal", "disturbed", "fast"))
    ratio = max(fast["peak_torque_Nm"]) / max(nominal["peak_torque_Nm"])
    assert 3.5 < ratio < 4.5  # "the torques are almost four times"
    assert fast["max_path_error_m"] > 2 * nominal["max_path_error_m"]
    assert disturbed["max_path_error_m"] > nominal["max_path_error_m"]
    assert max(disturbed["peak_torque_Nm"]) > max(nominal["peak_torque_Nm"])
    for s in (nominal, disturbed, fast):
        assert s["working_mode"] == [-1, 1, -1]  # conventions §3: the mode maximising min |S| on the circle


def test_sampled_run_is_self_consistent(paper, paper_runs):
    r = paper_runs["nominal"]
    assert r.t.size == 1572 and r.t[-1] == pytest.approx(1.571) and r.t[1] == pytest.approx(1e-3)
    # the plant stays on its constraint manifold; reported pose and S come from its configuration — checked in
    # the paper's own formulation (its 7 coordinates: the generic 9 without the centroid x, y)
    q7 = coordinates_to_3rrr(r.q)
    assert np.abs(kin.constraint_residual(paper, q7)).max() < 1e-13
    np.testing.assert_allclose(r.pose, kin.platform_pose(paper, q7), atol=1e-15)
    np.testing.assert_allclose(r.q[:, 6:8], r.pose[:, :2], atol=0)
    np.testing.assert_allclose(r.S, kin.singularity_measure(paper, q7), atol=1e-15)
    # torque really is the computed-torque law of conventions §5 evaluated at each sample
    k = 700
    q_ctrl = kin.branch_following(paper, q7[k], r.theta[k])
    m_theta, c_theta = paper_dynamics.actuator_space_model(paper, q_ctrl, r.theta_dot[k])
    jm = desired_joint_motion(paper, paper_trajectory(0.2), (-1, 1, -1), r.t[k:k + 1])
    e = r.theta[k] - jm.theta[0]
    e_dot = r.theta_dot[k] - jm.theta_dot[0]
    expected = m_theta @ (jm.theta_ddot[0] - 1000 * e - 2 * np.sqrt(1000) * e_dot) + c_theta
    np.testing.assert_allclose(r.tau[k], expected, rtol=1e-9, atol=1e-12)


def test_sampled_plant_matches_an_adaptive_reference(paper, paper_runs):
    """Zero-order hold replayed through the adaptive DOP853 plant at tight tolerance."""
    r = paper_runs["fast"]
    n = 300
    held = r.tau[:n]

    def torque(t, theta, theta_dot):
        return held[min(int(t / 1e-3 + 1e-9), n - 1)]

    q0 = coordinates_to_3rrr(r.q[0])  # the paper's own formulation's 7 coordinates
    t_eval = r.t[:n]
    ref = ReducedPlant(paper, rtol=1e-12, atol=1e-13)
    # integrate sample by sample so that the discontinuities of τ fall on step boundaries
    theta = [q0[:3]]
    q, w = q0, np.zeros(3)
    for k in range(n - 1):
        run = ref.simulate(q, w, held[k], 1e-3, t_eval=[0.0, 1e-3])
        q, w = run.q[-1], run.theta_dot[-1]
        theta.append(q[:3])
    np.testing.assert_allclose(np.array(theta), r.theta[:n], atol=1e-10)
    assert isinstance(ref, ReducedPlant) and t_eval.size == n


def test_pd_controller_runs_and_tracks_worse_than_computed_torque():
    pd = simulate(paper_scenario("nominal").replace(controller=ControllerSpec("pd", kp=30.0, kv=1.0)))
    ct = simulate(paper_scenario("nominal"))
    assert pd.summary()["max_path_error_m"] > 10 * ct.summary()["max_path_error_m"]


def test_preflight_refuses_a_path_out_of_the_workspace():
    far = Trajectory(Line((0.25, 0.2, 0.0), (0.9, 0.2, 0.0)), 0.2)
    with pytest.raises(UnreachablePoseError, match=r"leaves the workspace at t = "):
        simulate(Scenario(pkmlab.load("paper"), far))


def test_preflight_refuses_a_path_near_a_singularity():
    # min |S| along the paper's circle is 1.08 in its best mode and at most 1.42 anywhere on it
    with pytest.raises(SingularityError, match=r"comes within 1\.08.* closest at t = .* pose"):
        simulate(Scenario(pkmlab.load("paper"), paper_trajectory(0.2), singularity_margin=1.2))
    with pytest.raises(SingularityError, match=r"the whole path lies within \|S\| < 5 "):
        simulate(Scenario(pkmlab.load("paper"), paper_trajectory(0.2), singularity_margin=5.0))


def test_scaled_model_follows_spec_section_7(paper):
    m = scaled_model(pkmlab.load("paper"), 1.15, 1.15).description
    for leg, base in zip(m.legs, paper.base_points, strict=True):
        active, passive = leg.bodies
        np.testing.assert_allclose(leg.base, base)
        assert np.hypot(*active.tip) == pytest.approx(0.25 * 1.15) and np.hypot(*passive.tip) == pytest.approx(
            0.1667 * 1.15)
        assert passive.mass == pytest.approx(0.312 * 1.15) and active.inertia == pytest.approx(2.438e-3 * 1.15**3)
        np.testing.assert_allclose(active.com, np.array(active.tip) / 2)
    att = np.array(m.platform.attachments)
    assert np.linalg.norm(att[1] - att[0]) == pytest.approx(0.125 * 1.15)


# ------------------------------------------------------------------ outputs
def test_result_exports(tmp_path, paper_runs):
    r = paper_runs["nominal"]
    r.to_csv(tmp_path / "run.csv")
    with open(tmp_path / "run.csv") as fh:
        rows = list(csv.reader(fh))
    assert tuple(rows[0]) == COLUMNS and len(rows) == r.t.size + 1
    np.testing.assert_allclose(np.array(rows[1:], dtype=float), r.table(), rtol=0, atol=0)
    r.to_json(tmp_path / "run.json")
    data = json.loads((tmp_path / "run.json").read_text())
    assert data["summary"] == json.loads(json.dumps(r.summary()))
    # the CSV read by pandas is the DataFrame pkmlab gives
    import pandas as pd

    frame = r.to_dataframe()
    assert tuple(frame.columns) == COLUMNS
    pd.testing.assert_frame_equal(frame, pd.read_csv(tmp_path / "run.csv"), rtol=0, atol=0)


def test_reproduce_cli_writes_everything(tmp_path, capsys):
    out = tmp_path / "out"
    assert main(["reproduce", "--out", str(out), "--no-figures", "--quiet"]) == 0
    summary = json.loads((out / "summary.json").read_text())
    assert set(summary["cases"]) == {"nominal", "disturbed", "fast"}
    for case in summary["cases"].values():
        assert set(case) == {"max_path_error_m", "rms_path_error_m", "max_alpha_error_rad", "max_joint_error_rad",
                             "peak_torque_Nm", "min_abs_S", "working_mode",
                             # the names of every mechanism's summary (conventions §8)
                             "max_orientation_error_rad", "max_joint_error", "peak_effort"}
    for name in ("nominal", "disturbed", "fast"):
        header = (out / f"{name}.csv").read_text().splitlines()[0]
        assert header == ",".join(COLUMNS)
    assert "| nominal |" in (out / "REPORT.md").read_text()
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporary folders left


def test_reproduce_refuses_an_unwritable_target(tmp_path):
    target = tmp_path / "file"
    target.write_text("x")
    from pkmlab.report import reproduce

    with pytest.raises(PkmlabError, match="not a folder"):
        reproduce(target, figures=False)
    assert target.read_text() == "x"


def test_time_laws_are_at_rest_outside_the_motion():
    tr = paper_trajectory(0.2)
    pose, vel, acc = tr.desired(np.array([-0.1, tr.duration + 1e-4, tr.duration + 1.0]))
    np.testing.assert_allclose(vel, 0, atol=0)
    np.testing.assert_allclose(acc, 0, atol=0)
    np.testing.assert_allclose(pose[1:], [[0.2, 0.21, 0.0]] * 2, atol=1e-15)


SCENARIO_LINE = """
[trajectory]
type = "line"
start = [0.25, 0.2, 0.0]
end = [{x_end}, 0.2, 0.0]
speed = 0.2
[simulation]
singularity_margin = {margin}
"""


@pytest.mark.parametrize("x_end, margin, pattern", [
    (0.9, 0.05, r"leaves the workspace at t = [0-9.]+ s.*leg"),
    (0.3, 1.3, r"comes within [0-9.]+ of a gain-type singularity .* closest at t = [0-9.]+ s, pose \("),
])
def test_simulate_cli_refuses_bad_paths_before_running(tmp_path, capsys, x_end, margin, pattern):
    path = tmp_path / "bad.toml"
    path.write_text(SCENARIO_LINE.format(x_end=x_end, margin=margin))
    out = tmp_path / "out"
    assert main(["simulate", str(path), "--out", str(out)]) == 1
    captured = capsys.readouterr()
    lines = captured.err.strip().splitlines()
    assert len(lines) == 1 and "Traceback" not in captured.err
    import re

    assert re.search(pattern, lines[0]), lines[0]
    assert not out.exists() and [p.name for p in tmp_path.iterdir()] == ["bad.toml"]


# ------------------------------------------------------------------ batch runs
def _uncertainty_study(n, seed=11):
    rng = np.random.default_rng(seed)
    base = paper_scenario("disturbed")
    return [base.replace(plant=pkmlab.perturbed_model(base.model, rng), name=f"draw {i}") for i in range(n)]


def test_batch_runs_are_identical_to_the_same_runs_done_alone():
    scenarios = _uncertainty_study(3) + [
        paper_scenario("nominal").replace(controller=ControllerSpec(kp=400.0)),
        paper_scenario("disturbed"),
    ]
    batch = pkmlab.simulate_batch(scenarios)
    for scenario, result in zip(scenarios, batch, strict=True):
        alone = simulate(scenario)
        assert result.scenario is scenario
        for name in ("q", "theta_dot", "tau", "pose", "S"):
            assert np.abs(getattr(result, name) - getattr(alone, name)).max() <= 1e-12, name
    # the draws really differ, so that the comparison above is not trivially between equal runs
    assert len({round(r.summary()["max_path_error_m"], 9) for r in batch}) == len(batch)


def test_batch_refuses_runs_of_different_lengths_and_names_a_failed_run():
    nominal = paper_scenario("nominal")
    with pytest.raises(InvalidParameterError, match="same number of samples"):
        pkmlab.simulate_batch([nominal, paper_scenario("fast")])
    with pytest.raises(InvalidParameterError, match="continuous-time"):
        pkmlab.simulate_batch([nominal.replace(sample_time=0.0)])
    far = nominal.replace(working_mode=(1, 1, 1), singularity_margin=10.0, name="hopeless")
    with pytest.raises(SingularityError, match=r"run 1 \(hopeless\)"):
        pkmlab.simulate_batch([nominal, far])
    results = pkmlab.simulate_batch([nominal, far], on_error="none")
    assert results[1] is None and results[0].summary() == simulate(nominal).summary()
    assert pkmlab.simulate_batch([]) == []
    # a plant that the ±15 % draw cannot assemble at the start, and one that meets a singularity mid-run
    scenarios = _uncertainty_study(1000, seed=7)
    unassemblable, singular = scenarios[988], scenarios[999]
    returned = pkmlab.simulate_batch([unassemblable, nominal, singular], on_error="return")
    assert isinstance(returned[0], AssemblyError) and "run 0 (draw 988)" in str(returned[0])
    assert "cannot be assembled" in str(returned[0])
    assert isinstance(returned[2], BranchFollowingError) and "run 2 (draw 999)" in str(returned[2])
    assert "t = 0.3090 s" in str(returned[2])
    with pytest.raises(BranchFollowingError, match=r"run 2 \(draw 999\)"):
        pkmlab.simulate_batch([nominal, nominal, singular])
    with pytest.raises(InvalidParameterError, match="on_error"):
        pkmlab.simulate_batch([nominal], on_error="ignore")


# ------------------------------------------------------------------ the plant's integrator
def test_plant_integrator_is_fourth_order_and_one_step_per_sample_is_below_1e_12():
    """RK4 over one held-torque sample against DOP853 at rtol 1e-13, at the fast case's highest speed."""
    fast = simulate(paper_scenario("fast"))
    k = int(np.argmax(np.abs(fast.theta_dot).max(axis=1)))
    machine = fast.scenario.model
    model = Planar3RRR.paper()  # the reference: the paper's own formulation's plant
    q0, w0, tau = fast.q[k], fast.theta_dot[k], fast.tau[k]
    span = 4e-3  # four samples with the torque held, so the error is large enough to measure
    ref = ReducedPlant(model, rtol=1e-13, atol=1e-15).simulate(coordinates_to_3rrr(q0), w0, tau, span,
                                                                t_eval=[0.0, span])
    ref_state = np.concatenate([ref.q[-1, :3], ref.theta_dot[-1]])
    # the simulation's integrator: the compiled core's, on the kernels of the machine's description
    kernels = machine.kernels
    errors = []
    steps = (1, 2, 4, 8)
    for n_sub in steps:
        workspaces = kernels.make_workspaces(1)  # kept alive: ws points into it
        ws = workspaces[0]
        kernels.set_base(ws, q0, machine.P)
        x = np.concatenate([q0[:3], w0])
        assert kernels.rk4_sample(ws, x, tau, machine.P, span, n_sub, 1e-3, np.empty((5, 6)), False,
                                  kernels.NO_DRIVES) == kernels.OK
        errors.append(np.abs(x - ref_state).max())
    orders = np.log2(np.array(errors[:-1]) / np.array(errors[1:]))
    assert np.all((orders > 3.5) & (orders < 4.6)), (errors, orders)
    # one step per 1 ms sample: error per sample (h = span / 4) scaled from the h = 1 ms run
    assert errors[2] < 1e-11


@pytest.mark.parametrize("case", ["nominal", "disturbed", "sensors and drives"])
def test_a_run_in_pieces_is_the_run_in_one(case, monkeypatch):
    """A long run is made a piece at a time (`SIMULATION_PIECE` samples): its working mode chosen along the path
    piece by piece, its desired motion made for one piece at a time, the compiled loop's state handed from one
    piece to the next. Every recorded number is the one-piece run's, bit for bit, whatever the pieces' length —
    the model shared with the plant (nominal), a plant of its own (disturbed), delayed and quantised readings with
    noise and drives whose noise is drawn per sample."""
    from pkmlab.simulation import run as run_module
    from pkmlab.simulation.realism import Drives, Sensors

    scenario = paper_scenario("disturbed" if case == "disturbed" else "nominal")
    if case == "sensors and drives":
        scenario = scenario.replace(sensors=Sensors(resolution=2 * np.pi / 40_000, delay=3, rates="backward2",
                                                    noise=1e-5),
                                    drives=Drives(effort_noise=1e-3, viscous=0.01, coulomb=0.004, coulomb_rate=0.05))
    whole = simulate(scenario)
    assert whole.t.size < run_module.SIMULATION_PIECE  # one piece
    monkeypatch.setattr(run_module, "SIMULATION_PIECE", 97)  # 17 pieces, the last one short
    pieces = simulate(scenario)
    for name in ("q", "theta_dot", "tau", "S", "theta_d", "pose", "pose_d", "theta_measured"):
        a, b = getattr(whole, name), getattr(pieces, name)
        assert (a is None and b is None) or np.array_equal(a, b), name
    assert case != "sensors and drives" or whole.theta_measured is not None


@pytest.mark.parametrize(("scenario", "message"), [
    (Scenario(pkmlab.load("paper"), Trajectory(Line((0.25, 0.2, 0.0), (0.9, 0.2, 0.0)), 0.2)),
     r"leaves the workspace at t = "),
    (Scenario(pkmlab.load("paper"), paper_trajectory(0.2), singularity_margin=1.2), r"comes within 1\.08"),
    (Scenario(pkmlab.load("paper"), paper_trajectory(0.2), singularity_margin=5.0), r"the whole path lies within"),
], ids=["unreachable", "near a singularity", "all near a singularity"])
def test_a_path_refused_in_pieces_is_refused_in_the_same_words(scenario, message, monkeypatch):
    """The working mode chosen a piece of the path at a time: the refusal names the same time and pose."""
    from pkmlab.simulation import run as run_module

    with pytest.raises(PkmlabError, match=message) as whole:
        simulate(scenario)
    monkeypatch.setattr(run_module, "SIMULATION_PIECE", 97)
    with pytest.raises(PkmlabError, match=message) as pieces:
        simulate(scenario)
    assert str(pieces.value) == str(whole.value)


def test_a_long_run_holds_its_result_and_one_piece_of_its_path(monkeypatch):
    """Beyond the arrays its result keeps, a run holds a working set of one piece of its path, whatever its length
    (traced allocations: deterministic). The pose is a view of the configurations, not a copy."""
    import tracemalloc

    from pkmlab.simulation import run as run_module

    monkeypatch.setattr(run_module, "SIMULATION_PIECE", 500)
    nominal = paper_scenario("nominal")
    simulate(nominal)  # kernels loaded, caches filled
    beyond = []
    for samples in (10_000, 20_000):
        scenario = nominal.replace(trajectory=paper_trajectory(nominal.trajectory.duration * 0.2 / (samples * 1e-3)))
        tracemalloc.start()
        try:
            result = simulate(scenario)
            _current, peak = tracemalloc.get_traced_memory()
        finally:
            tracemalloc.stop()
        kept = sum(a.nbytes for a in (result.t, result.q, result.theta_dot, result.tau, result.S, result.theta_d,
                                       result.pose_d))
        assert np.shares_memory(result.pose, result.q)
        beyond.append(peak - kept)
    # a piece of 500 samples costs some 1.3 kB per sample while it is made; the whole path held at once, 200 B
    # per sample of the run (2 MB at 10,000 samples), would also double with the run
    assert max(beyond) < 500 * 2000
    assert abs(beyond[1] - beyond[0]) < 0.2 * beyond[0]
