"""Every mechanism exported to MuJoCo (pkmlab.mujoco_export) and cross-validated against pkmlab's dynamics."""

from __future__ import annotations

import numpy as np
import pytest

from pkmlab import mechanism_model as mm
from pkmlab import mujoco_export as mx
from pkmlab.errors import InvalidParameterError, UnreachablePoseError
from pkmlab.mechanism_model import MechanismModel
from pkmlab.mechanisms.presets import PRESETS

mujoco = pytest.importorskip("mujoco")
NAMES = sorted(PRESETS)


def _states(model, count: int, seed: int):
    """Configurations on the manifold near the export's home pose (inverse kinematics of poses around it,
    away from singularities), with actuator rates and the passive rates they imply."""
    rng = np.random.default_rng(seed)
    home = mx.home_configuration(model)
    mode = mm.working_modes(model)[0]
    dof = model.description.dof
    n = model.n_actuators
    out = []
    while len(out) < count:
        pose = home[-dof:] + rng.normal(0.0, 0.02, dof)
        try:
            q = mm.inverse_kinematics(model, pose, mode)
        except (UnreachablePoseError, InvalidParameterError):
            continue
        if abs(mm.singularity_measure(model, q)) < 0.05:
            continue
        theta_dot = rng.normal(0.0, 0.5, n)
        jac = mm.constraint_jacobian(model, q)
        q_dot = np.concatenate([theta_dot, np.linalg.solve(jac[:, n:], -jac[:, :n] @ theta_dot)])
        out.append((q, q_dot, rng.normal(0.0, 1.0, n)))
    return out


def _pkmlab_acceleration(model, q, q_dot, tau):
    n = model.n_actuators
    M, c, g = mm.actuator_space_model(model, q, q_dot[:n])
    return np.linalg.solve(M, tau - c - g)


def _actuated_dofs(m, n):
    return [m.jnt_dofadr[m.actuator_trnid[i, 0]] for i in range(n)]


def _set(model, m, d, q, q_dot, tau):
    d.qpos[:] = mx.qpos_from_q(model, q)
    d.qvel[:] = mx.qvel_from_q_dot(model, q, q_dot)
    d.ctrl[:] = tau
    mujoco.mj_forward(m, d)


@pytest.mark.parametrize("name", NAMES)
def test_the_exported_model_is_the_described_machine(name):
    model = MechanismModel.from_preset(name)
    m, d = mx.load_mujoco(model)
    desc = model.description
    bodies = [b for leg in desc.legs for b in leg.bodies] + [desc.platform]
    assert m.body_mass.sum() == pytest.approx(sum(b.mass for b in bodies), rel=1e-14)
    for k, body in enumerate(bodies):  # the world is body 0; the legs' bodies, then the platform, in order
        tensor = np.array(body.inertia) if desc.spatial else np.diag([body.inertia / 2, body.inertia / 2,
                                                                      body.inertia])
        if not desc.spatial and k == len(bodies) - 1 and desc.platform.kind == "point":
            tensor = np.zeros((3, 3))
        moments = np.sort(np.linalg.eigvalsh(tensor))
        floor = mx.INERTIA_FLOOR * max(moments.max(), 1.0 if moments.max() == 0 else 0.0)
        assert m.body_mass[k + 1] == pytest.approx(body.mass, rel=1e-14)
        assert np.allclose(np.sort(m.body_inertia[k + 1]), np.maximum(moments, floor), rtol=1e-12, atol=1e-18)
        com = np.array(body.com if desc.spatial else (*body.com, 0.0))
        assert np.linalg.norm(m.body_ipos[k + 1]) == pytest.approx(np.linalg.norm(com), abs=1e-15)
    # the keyframe is assembled: every loop closed to round-off
    assert d.nefc == 3 * len(desc.legs) and np.abs(d.efc_pos).max() < 1e-12
    assert m.nu == len(desc.legs) and np.allclose(m.opt.gravity, [*desc.gravity, 0.0][:3])


@pytest.mark.parametrize("name", NAMES)
def test_coordinates_map_both_ways(name):
    model = MechanismModel.from_preset(name)
    m, d = mx.load_mujoco(model)
    for q, q_dot, _tau in _states(model, 5, 1):
        assert np.allclose(mx.q_from_qpos(model, mx.qpos_from_q(model, q)), q, atol=1e-12)
        d.qpos[:] = mx.qpos_from_q(model, q)
        d.qvel[:] = mx.qvel_from_q_dot(model, q, q_dot)
        mujoco.mj_forward(m, d)
        assert np.abs(d.efc_pos).max() < 1e-12  # pkmlab's configuration closes MuJoCo's loops
        # pkmlab's consistent rates are MuJoCo's: the constraints' velocity J qvel vanishes
        jac = d.efc_J.reshape(d.nefc, m.nv)
        assert np.abs(jac @ d.qvel).max() < 1e-12 * (1 + np.abs(d.qvel).max())


def _hard_solve(m, d, legs: int):
    """MuJoCo's own mass matrix, bias forces, actuation and constraint Jacobian, with the loop closures as
    hard constraints: ``[M Jᵀ; J 0] [q̈; λ] = [τ - bias; -J̇ q̇]``, ``J̇ q̇`` from the sites' accelerations at
    ``q̈ = 0``."""
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    J = d.efc_J.reshape(d.nefc, m.nv).copy()
    force = d.qfrc_actuator - d.qfrc_bias
    d.qacc[:] = 0.0
    mujoco.mj_rnePostConstraint(m, d)
    gamma = []
    for i in range(legs):
        acc = []
        for site in (f"leg{i + 1}_end", f"platform_a{i + 1}"):
            a = np.zeros(6)
            mujoco.mj_objectAcceleration(m, d, mujoco.mjtObj.mjOBJ_SITE, mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE,
                                                                                            site), a, 0)
            acc.append(a[3:])
        gamma += list(acc[0] - acc[1])
    kkt = np.block([[M, J.T], [J, np.zeros((len(J), len(J)))]])
    # the planar machines' z rows are identically zero: a least-squares solve of the consistent system
    return np.linalg.lstsq(kkt, np.concatenate([force, -np.array(gamma)]), rcond=None)[0][:m.nv]


@pytest.mark.parametrize("name", NAMES)
def test_mujocos_equations_with_hard_constraints_give_pkmlabs_accelerations(name):
    model = MechanismModel.from_preset(name)
    m, d = mx.load_mujoco(model)
    n = model.n_actuators
    for q, q_dot, tau in _states(model, 4, 2):
        _set(model, m, d, q, q_dot, tau)
        theirs = _hard_solve(m, d, n)[_actuated_dofs(m, n)]
        ours = _pkmlab_acceleration(model, q, q_dot, tau)
        assert np.abs(theirs - ours).max() < 1e-10 * (1 + np.abs(ours).max())


@pytest.mark.parametrize("name", NAMES)
def test_mujocos_soft_constraints_agree_to_their_impedance(name):
    """MuJoCo's own solver makes the loop closures soft: at a consistent state its actuated accelerations
    differ from the rigid chain's by a multiple of (1 - d)/d, d the impedance — 0.11 with its defaults
    (d = 0.9), 1.0e-4 with the stiffest (d = 0.9999). The multiple depends on the machine and the state;
    over the presets it stays below 6 (the Delta's is about 4)."""
    model = MechanismModel.from_preset(name)
    n = model.n_actuators
    errors = {}
    for label, options, impedance in (("default", {}, 0.9),
                                      ("stiff", {"solref": mx.STIFF_SOLREF, "solimp": mx.STIFF_SOLIMP}, 0.9999)):
        m, d = mx.load_mujoco(model, **options)
        errors[label] = []
        for q, q_dot, tau in _states(model, 3, 3):
            _set(model, m, d, q, q_dot, tau)
            ours = _pkmlab_acceleration(model, q, q_dot, tau)
            error = np.abs(d.qacc[_actuated_dofs(m, n)] - ours).max() / (1 + np.abs(ours).max())
            assert error < 6 * (1 - impedance) / impedance
            errors[label].append(error)
    # the error scales with (1 - d)/d: about 1,100 times smaller at the stiffest setting
    ratio = np.array(errors["default"]) / np.array(errors["stiff"])
    assert np.all((500 < ratio) & (ratio < 2500))


def test_a_point_platform_without_payload_is_refused():
    from dataclasses import replace

    from pkmlab.mechanisms.presets import preset

    five_bar = preset("five_bar")
    light = MechanismModel.from_description(replace(five_bar, platform=replace(five_bar.platform, mass=0.0)))
    with pytest.raises(InvalidParameterError, match="point platform without a payload"):
        mx.mjcf(light)


def test_export_mjcf_from_the_command_line(tmp_path, capsys):
    import json

    from pkmlab.cli import main

    out = tmp_path / "delta.xml"
    assert main(["export-mjcf", "--mechanism", "delta", "--pose", "0.02", "-0.03", "-0.8", "--stiff", "--out",
                 str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    m = mujoco.MjModel.from_xml_path(str(out))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    assert np.allclose(d.qpos, report["qpos"]) and np.abs(d.efc_pos).max() < 1e-12
    assert np.allclose(report["pose"], [0.02, -0.03, -0.8]) and report["approximations"]
    assert np.allclose(m.eq_solimp[:, 0], mx.STIFF_SOLIMP[0])
    # bad input: one line, nothing written
    bad = tmp_path / "bad.xml"
    assert main(["export-mjcf", "--mechanism", "delta", "--pose", "0", "0", "-0.2", "--out", str(bad)]) == 1
    assert "leg 1 (R*US) cannot reach" in capsys.readouterr().err and not bad.exists()
    with pytest.raises(SystemExit) as usage:  # a malformed command line: usage, exit code 2
        main(["export-mjcf", "--mechanism", "delta", "--pose", "0", "0", "--out", str(bad)])
    assert usage.value.code == 2 and "--pose (x, y, z): 3 numbers" in capsys.readouterr().err and not bad.exists()
