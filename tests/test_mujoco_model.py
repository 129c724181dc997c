"""The MuJoCo model of the 3-RRR (benchmarks/mujoco_model.py) against pkmlab, by independent checks.

Skipped when MuJoCo is not installed (it is an optional benchmark dependency).
"""

import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import random_reachable_poses

from pkmlab.paper import dynamics as dy
from pkmlab.paper import kinematics as kin

mujoco = pytest.importorskip("mujoco")
sys.path.insert(0, str(Path(__file__).resolve().parents[1] / "benchmarks"))
import mujoco_model as mm  # noqa: E402


def _u(x):
    return np.array([np.cos(x), np.sin(x)])


@pytest.fixture(scope="module")
def states(paper):
    """IK configurations in every working mode, |S| > 0.15 (away from gain-type singularities), random θ̇, τ."""
    rng = np.random.default_rng(20240611)
    poses = random_reachable_poses(rng, paper, 6, margin=0.15)
    ik = kin.inverse_kinematics(paper, poses, on_unreachable="nan")
    q = ik.q[np.abs(ik.S) > 0.15]
    assert len(q) >= 6
    return q, rng.normal(size=(len(q), 3)), rng.normal(size=(len(q), 3))


def _body_pos(m, d, name):
    return d.xpos[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, name)][:2]


def _site_pos(m, d, name):
    return d.site_xpos[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, name)]


def test_model_structure(paper):
    m, _d = mm.build(paper)
    assert (m.njnt, m.nq, m.nv, m.nu, m.neq) == (7, 7, 7, 3, 2)
    assert np.all(m.jnt_type == mujoco.mjtJoint.mjJNT_HINGE)
    assert np.all(m.eq_type == mujoco.mjtEq.mjEQ_CONNECT)
    assert m.opt.integrator == mujoco.mjtIntegrator.mjINT_RK4 and m.opt.timestep == 1e-3
    assert np.all(m.opt.gravity == 0) and m.opt.disableflags & mujoco.mjtDisableBit.mjDSBL_CONTACT
    assert not np.any(m.dof_damping) and not np.any(m.dof_armature) and not np.any(m.dof_frictionloss)
    assert np.all(m.actuator_gear[:, 0] == 1) and not np.any(m.actuator_ctrllimited)
    assert m.nbody == 8 and m.body_mass.sum() == pytest.approx(3 * (0.468 + 0.312) + 0.234, rel=1e-15)


def test_loops_close_and_the_platform_pose_matches_at_ik_configurations(paper, states):
    q_all, _td, _tau = states
    m, d = mm.build(paper)
    b = np.array([(0.0, 0.0), (0.52, 0.0), (0.26, np.sqrt(3) / 2 * 0.52)])
    for q in q_all:
        d.qpos[:] = mm.qpos_from_q(q)
        mujoco.mj_kinematics(m, d)
        for i in (2, 3):
            gap = _site_pos(m, d, f"vertex{i}") - _site_pos(m, d, f"tip{i}")
            assert np.abs(gap).max() < 1e-12
        for i in range(3):  # the tree itself, from conventions §1 written out here
            e = b[i] + 0.25 * _u(q[i])
            np.testing.assert_allclose(_body_pos(m, d, f"distal{i + 1}"), e, rtol=0, atol=1e-14)
        p1 = b[0] + 0.25 * _u(q[0]) + 0.1667 * _u(q[3])
        np.testing.assert_allclose(_body_pos(m, d, "platform"), p1, rtol=0, atol=1e-14)
        centroid = p1 + 0.125 / np.sqrt(3) * _u(q[6] + np.pi / 6)
        pose = mm.platform_pose(m, d)
        np.testing.assert_allclose(pose[:2], centroid, rtol=0, atol=1e-14)
        np.testing.assert_allclose(pose, kin.platform_pose(paper, q), rtol=0, atol=1e-14)
        np.testing.assert_allclose(mm.q_from_qpos(d.qpos), q, rtol=0, atol=1e-14)


def test_kinetic_energy_and_mass_matrix_match_pkmlab(paper, states):
    """Masses, mass centres and inertias, with the constraint solver out of the picture."""
    q_all, td_all, _tau = states
    m, d = mm.build(paper)
    T = np.linalg.inv(mm.RELATIVE)  # q̇ = T qvel
    for q, td in zip(q_all, td_all, strict=True):
        qd = kin.coordinate_rates(paper, q, td)
        mm.set_state(m, d, paper, q, td)
        mujoco.mj_forward(m, d)
        mujoco.mj_energyVel(m, d)
        expected = float(dy.kinetic_energy(paper, q, qd))
        assert d.energy[1] == pytest.approx(expected, rel=1e-10)
        assert expected == pytest.approx(0.5 * td @ dy.actuator_space_model(paper, q, td)[0] @ td, rel=1e-10)
        M = np.zeros((7, 7))  # row by row (M is symmetric): mj_mulM has one signature in MuJoCo 3 and 4
        for j in range(7):
            mujoco.mj_mulM(m, d, M[j], np.eye(7)[j])
        np.testing.assert_allclose(M, T.T @ dy.mass_matrix(paper, q) @ T, rtol=0, atol=1e-14)


def test_stiff_constraints_reproduce_pkmlab_forward_dynamics(paper, states):
    """θ̈ from MuJoCo's soft constraints vs pkmlab's exact eq. (35).

    At a consistent state MuJoCo's constraint-space acceleration is ``R (A + R)⁻¹`` times the
    unconstrained one, with ``R/A ≈ (1 - d)/d = 1e-4`` at the stiffest impedance ``d = 0.9999``.
    Over 1,443 random workspace states with |S| > 0.15 (all working modes) the measured relative
    error was median 2.9e-5, 99th percentile 3.3e-4, largest 1.4e-3 (ill-conditioned ``A``); the
    default settings give median 2.9e-2. Tolerance 2e-3 per state, and the stiff model must be
    at least 30x closer than the default one over these states.
    """
    q, td, tau = states
    exact = dy.forward_dynamics(paper, q, td, tau)
    stiff = mm.mujoco_theta_ddot(paper, q, td, tau, stiff=True)
    soft = mm.mujoco_theta_ddot(paper, q, td, tau, stiff=False)
    rel = np.linalg.norm(stiff - exact, axis=1) / np.linalg.norm(exact, axis=1)
    rel_soft = np.linalg.norm(soft - exact, axis=1) / np.linalg.norm(exact, axis=1)
    assert rel.max() < 2e-3
    assert np.median(rel) < 1e-4
    assert np.median(rel_soft) > 30 * np.median(rel)
    assert mm.acceleration_error(paper, q, td, tau, stiff=True) == pytest.approx(rel.max(), rel=1e-12)
