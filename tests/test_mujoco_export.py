"""Every mechanism exported to MuJoCo (pkmlab.interop.mujoco_export) and cross-validated against pkmlab's dynamics."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import pkmlab
from pkmlab.description.presets import PRESETS
from pkmlab.errors import InvalidParameterError, UnreachablePoseError
from pkmlab.interop import mujoco_export as mx
from pkmlab.model import mechanism_model as mm
from pkmlab.model.mechanism_model import MechanismModel

mujoco = pytest.importorskip("mujoco")
NAMES = sorted(PRESETS)
#: The catalogue's machines (examples/mechanisms), checked as the presets are.
CATALOGUE = [str(Path(__file__).resolve().parents[1] / "examples" / "mechanisms" / name)
             for name in ("3prs.toml", "3rps.toml", "3upu.toml", "3rrs.toml", "6rus.toml", "6pus.toml",
                          # universal joints at a rigid platform (a tendon holds their axes), revolute ones (two
                          # connects on each axis, rows dependent as the machine's are)
                          "3upu_wrist.toml", "agile_eye.toml", "3puu.toml",
                          # overconstrained: two legs' orientation rows kept, two set aside
                          "4ruu.toml",
                          # revolute joints at the platform whose rows are independent: one of each leg's two kept
                          "3crr.toml",
                          # two actuators on a leg: a slider under each leg's actuated link (kinematic redundancy)
                          "3prrr.toml")] + [
    str(Path(__file__).resolve().parents[1] / "examples" / "3rrs_tilted.toml")]  # legs of the general method


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
        pose = mm.pose_of(model, home) + rng.normal(0.0, 0.02, dof)
        try:
            q = mm.inverse_kinematics(model, pose, mode)
        except (UnreachablePoseError, InvalidParameterError):
            continue
        if abs(mm.singularity_measure(model, q)) < min(0.05, 0.5 * abs(mm.singularity_measure(model, home))):
            continue  # (a machine of many passive coordinates has a small S everywhere: a 3-UPU wrist's is 0.01)
        theta_dot = rng.normal(0.0, 0.5, n)
        jac = mm.constraint_jacobian(model, q)
        q_dot = np.concatenate([theta_dot, np.linalg.solve(jac[:, n:], -jac[:, :n] @ theta_dot)])
        out.append((q, q_dot, rng.normal(0.0, 1.0, n)))
    return out


def _pkmlab_acceleration(model, q, q_dot, tau):
    n = model.n_actuators
    M, c, g = mm.actuator_space_model(model, q, q_dot[:n])
    return np.linalg.solve(M, tau - c - g)


def _actuator_accelerations(model, q, qacc):
    """pkmlab's actuator accelerations of MuJoCo's ``qacc``: the legs' joints map linearly (planar angles relative in
    MuJoCo, absolute in pkmlab), so the map of the rates maps the accelerations."""
    return mx.q_dot_from_qvel(model, q, qacc)[:model.n_actuators]


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


@pytest.mark.parametrize("name", NAMES + CATALOGUE)
def test_coordinates_map_both_ways(name):
    model = pkmlab.load(name)
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


def _site_motion(m, d, site: str) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """A site's position, linear velocity and linear acceleration (world frame)."""
    k = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, site)
    v, a = np.zeros(6), np.zeros(6)
    mujoco.mj_objectVelocity(m, d, mujoco.mjtObj.mjOBJ_SITE, k, v, 0)
    mujoco.mj_objectAcceleration(m, d, mujoco.mjtObj.mjOBJ_SITE, k, a, 0)
    return d.site_xpos[k].copy(), v[3:], a[3:]


def _hard_solve(m, d, legs: int):
    """MuJoCo's own mass matrix, bias forces, actuation and constraint Jacobian, with the loop closures as
    hard constraints: ``[M Jᵀ; J 0] [q̈; λ] = [τ - bias; -J̇ q̇]``, ``J̇ q̇`` from the sites' accelerations at
    ``q̈ = 0``: a connect's the difference of its two sites', a tendon's (a universal joint's axes at a rigid
    platform) the second derivative of the distance between its two sites."""
    M = np.zeros((m.nv, m.nv))
    mujoco.mj_fullM(m, d, M)
    J = d.efc_J.reshape(d.nefc, m.nv).copy()
    force = d.qfrc_actuator - d.qfrc_bias
    d.qacc[:] = 0.0
    mujoco.mj_rnePostConstraint(m, d)
    gamma = []
    for i in range(legs):
        (_p1, _v1, a1), (_p2, _v2, a2) = (_site_motion(m, d, s) for s in (f"leg{i + 1}_end", f"platform_a{i + 1}"))
        gamma += list(a1 - a2)
    for i in range(legs):  # a platform joint's axis: a revolute joint's second connect, a universal one's tendon
        if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, f"leg{i + 1}_axis") < 0:
            continue
        (p1, v1, a1), (p2, v2, a2) = (_site_motion(m, d, s) for s in (f"leg{i + 1}_axis", f"platform_axis{i + 1}"))
        r, v, a = p1 - p2, v1 - v2, a1 - a2
        if mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_TENDON, f"hold{i + 1}") < 0:
            gamma += list(a)
            continue
        length = np.linalg.norm(r)
        gamma.append((v @ v + r @ a) / length - (r @ v) ** 2 / length ** 3)
    kkt = np.block([[M, J.T], [J, np.zeros((len(J), len(J)))]])
    # the planar machines' z rows are identically zero: a least-squares solve of the consistent system
    return np.linalg.lstsq(kkt, np.concatenate([force, -np.array(gamma)]), rcond=None)[0][:m.nv]


@pytest.mark.parametrize("name", NAMES + CATALOGUE)
def test_mujocos_equations_with_hard_constraints_give_pkmlabs_accelerations(name):
    model = pkmlab.load(name)
    m, d = mx.load_mujoco(model)
    for q, q_dot, tau in _states(model, 4, 2):
        _set(model, m, d, q, q_dot, tau)
        theirs = _actuator_accelerations(model, q, _hard_solve(m, d, len(model.description.legs)))
        ours = _pkmlab_acceleration(model, q, q_dot, tau)
        assert np.abs(theirs - ours).max() < 1e-10 * (1 + np.abs(ours).max())


@pytest.mark.parametrize("name", NAMES)
def test_mujocos_soft_constraints_agree_to_their_impedance(name):
    """MuJoCo's own solver makes the loop closures soft: at a consistent state its actuated accelerations
    differ from the rigid chain's by a multiple of (1 - d)/d, d the impedance — 0.11 with its defaults
    (d = 0.9), 1.0e-4 with the stiffest (d = 0.9999). The multiple depends on the machine and the state;
    over the presets it stays below 6 (the Delta's is about 4)."""
    model = MechanismModel.from_preset(name)
    errors = {}
    for label, options, impedance in (("soft", {"closures": "soft"}, 0.9), ("stiff", {"closures": "stiff"}, 0.9999)):
        m, d = mx.load_mujoco(model, **options)
        errors[label] = []
        for q, q_dot, tau in _states(model, 3, 3):
            _set(model, m, d, q, q_dot, tau)
            ours = _pkmlab_acceleration(model, q, q_dot, tau)
            error = np.abs(_actuator_accelerations(model, q, d.qacc) - ours).max() / (1 + np.abs(ours).max())
            assert error < 6 * (1 - impedance) / impedance
            errors[label].append(error)
    # the error scales with (1 - d)/d: about 1,100 times smaller at the stiffest setting
    ratio = np.array(errors["soft"]) / np.array(errors["stiff"])
    assert np.all((500 < ratio) & (ratio < 2500))


def test_a_point_platform_without_payload_is_refused():
    from dataclasses import replace

    from pkmlab.description.presets import preset

    five_bar = preset("five_bar")
    light = MechanismModel.from_description(replace(five_bar, platform=replace(five_bar.platform, mass=0.0)))
    with pytest.raises(InvalidParameterError, match="point platform without a payload"):
        mx.mjcf(light)


def test_export_mjcf_from_the_command_line(tmp_path, capsys):
    import json

    from pkmlab.cli import main

    out = tmp_path / "delta.xml"
    assert main(["export-mjcf", "--mechanism", "delta", "--pose", "0.02", "-0.03", "-0.8", "--out",
                 str(out), "--json"]) == 0
    report = json.loads(capsys.readouterr().out)
    m = mujoco.MjModel.from_xml_path(str(out))
    d = mujoco.MjData(m)
    mujoco.mj_resetDataKeyframe(m, d, 0)
    mujoco.mj_forward(m, d)
    assert np.allclose(d.qpos, report["qpos"]) and np.abs(d.efc_pos).max() < 1e-12
    assert np.allclose(report["pose"], [0.02, -0.03, -0.8]) and report["approximations"]
    assert np.all(m.eq_solimp[:, 0] == 0.9999)  # stiff closures by default
    # bad input: one line, nothing written
    bad = tmp_path / "bad.xml"
    assert main(["export-mjcf", "--mechanism", "delta", "--pose", "0", "0", "-0.2", "--out", str(bad)]) == 1
    assert "leg 1 (R*US) cannot reach" in capsys.readouterr().err and not bad.exists()
    with pytest.raises(SystemExit) as usage:  # a malformed command line: usage, exit code 2
        main(["export-mjcf", "--mechanism", "delta", "--pose", "0", "0", "--out", str(bad)])
    assert usage.value.code == 2 and "--pose (x, y, z): 3 numbers" in capsys.readouterr().err and not bad.exists()


def test_export_mjcf_exports_the_working_mode_asked_for(tmp_path, capsys):
    """--mode without --pose: the home configuration in that working mode (it was the first mode, whatever
    --mode said). The exported pose's inverse kinematics in the mode asked for is the exported configuration."""
    import json

    from pkmlab.algorithms.kinematics import inverse_kinematics
    from pkmlab.cli import main

    model = MechanismModel.from_preset("paper")
    exported = {}
    for mode in ((1, 1, 1), (-1, 1, -1)):
        out = tmp_path / f"paper{len(exported)}.xml"
        signs = ["+" if v > 0 else "-" for v in mode]
        assert main(["export-mjcf", "--mode", *signs, "--out", str(out), "--json"]) == 0
        report = json.loads(capsys.readouterr().out)
        q = inverse_kinematics(model, report["pose"], mode=mode).q
        assert np.allclose(mx.qpos_from_q(model, q), report["qpos"], atol=1e-9)
        exported[mode] = report["qpos"]
    assert not np.allclose(exported[(1, 1, 1)], exported[(-1, 1, -1)])


def test_export_mjcf_says_its_notes_on_stderr(tmp_path, capsys):
    """The result (the file written) on stdout, what the export approximates as notes on stderr."""
    from pkmlab.cli import main

    out = tmp_path / "delta.xml"
    assert main(["export-mjcf", "--mechanism", "delta", "--out", str(out)]) == 0
    captured = capsys.readouterr()
    assert captured.out.startswith(f"wrote {out}:") and captured.out.count("\n") == 1
    notes = captured.err.strip().splitlines()
    assert notes and all(line.startswith("pkmlab export-mjcf: note: Principal") for line in notes)


#: The stiffest loop closures MuJoCo accepts: impedance at its cap mjMAXIMP = 0.9999 (width 0.001, midpoint
#: 0.5, power 2 as MuJoCo's own), time constant 2 ms (twice a 1 ms step), damping ratio 1.
STIFF = {"solref": [0.002, 1.0], "solimp": [0.9999, 0.9999, 0.001, 0.5, 2.0]}


def _closures(text: str) -> tuple[list[dict], list[str]]:
    """The ``connect`` constraints' solref and solimp (as numbers), and the comments inside ``<equality>``."""
    import xml.etree.ElementTree as ET

    root = ET.fromstring(text, parser=ET.XMLParser(target=ET.TreeBuilder(insert_comments=True)))
    equality = root.find("equality")
    connects = [{key: [float(v) for v in c.get(key).split()] for key in ("solref", "solimp")}
                for c in equality.iter("connect")]
    comments = [c.text for c in equality if c.tag is ET.Comment]
    return connects, comments


def _mujocos_own_defaults():
    """solref and solimp MuJoCo itself gives a connect constraint that sets neither."""
    m = mujoco.MjModel.from_xml_string(
        '<mujoco><worldbody><body name="b"><freejoint/><geom size="0.1"/></body></worldbody>'
        '<equality><connect body1="b" anchor="0 0 0"/></equality></mujoco>')
    return {"solref": m.eq_solref[0].tolist(), "solimp": m.eq_solimp[0].tolist()}


@pytest.mark.parametrize("name", ["five_bar", "delta"])
def test_the_export_closes_its_loops_stiffly_by_default_and_says_so(name):
    model = MechanismModel.from_preset(name)
    text = mx.mjcf(model)
    connects, comments = _closures(text)
    assert len(connects) == len(model.description.legs)
    assert all(c == STIFF for c in connects)
    m = mujoco.MjModel.from_xml_string(text)  # and MuJoCo reads them so
    assert np.all(m.eq_solref == STIFF["solref"]) and np.all(m.eq_solimp == STIFF["solimp"])
    (comment,) = comments  # one comment, inside <equality>, naming the values and why
    assert 'solref="0.002 1.0" solimp="0.9999 0.9999 0.001 0.5 2.0"' in comment
    assert "stiff" in comment and "rigid machine" in comment
    assert mx.mjcf(model, closures="stiff") == text


@pytest.mark.parametrize("name", ["five_bar", "delta"])
def test_soft_closures_are_mujocos_own_defaults(name):
    model = MechanismModel.from_preset(name)
    text = mx.mjcf(model, closures="soft")
    connects, (comment,) = _closures(text)
    defaults = _mujocos_own_defaults()
    assert all(c == defaults for c in connects)
    m = mujoco.MjModel.from_xml_string(text)
    assert np.allclose(m.eq_solref, defaults["solref"]) and np.allclose(m.eq_solimp, defaults["solimp"])
    assert "MuJoCo's defaults" in comment and "may open by about" in comment and "mm" in comment
    assert 'solimp="0.9 0.95 0.001 0.5 2.0"' in comment


def test_closures_given_by_value_are_said_to_be():
    model = MechanismModel.from_preset("five_bar")
    text = mx.mjcf(model, solimp=(0.99, 0.99, 0.001, 0.5, 2.0))
    connects, (comment,) = _closures(text)
    assert all(c == {"solref": STIFF["solref"], "solimp": [0.99, 0.99, 0.001, 0.5, 2.0]} for c in connects)
    assert comment.startswith(" Loop closures (custom)")


@pytest.mark.parametrize("bad", ["rigid", "Stiff", "", None, True])
def test_a_bad_closures_name_is_refused(bad):
    with pytest.raises(InvalidParameterError, match=r"^closures must be 'stiff' or 'soft', got "):
        mx.mjcf(MechanismModel.from_preset("five_bar"), closures=bad)


def test_export_mjcf_closures_on_the_command_line(tmp_path, capsys):
    from conftest import assert_user_error, run

    files = {}
    for label, flags in (("default", []), ("stiff", ["--closures", "stiff"]), ("soft", ["--closures", "soft"]),
                         ("deprecated", ["--stiff"])):
        files[label] = out = tmp_path / f"{label}.xml"
        code, _out, err = run(capsys, "export-mjcf", "--mechanism", "five_bar", "--out", out, *flags)
        assert code == 0
        # besides the notes of what the export approximates (the point platform's inertia), nothing on stderr ...
        others = [n for n in err.splitlines() if not n.startswith("pkmlab export-mjcf: note: Principal moments")]
        if label == "deprecated":  # ... but for the deprecated flag, still accepted, one note: it is the default now
            (note,) = others
            assert note.startswith("pkmlab export-mjcf: note: --stiff is deprecated") and "default" in note
        else:
            assert others == []
    assert all(c == STIFF for c in _closures(files["default"].read_text())[0])
    assert all(c == _mujocos_own_defaults() for c in _closures(files["soft"].read_text())[0])
    assert files["stiff"].read_text() == files["default"].read_text() == files["deprecated"].read_text()
    # a bad value, or the deprecated flag against --closures soft: one line, exit 1, no file
    for flags, words in ((["--closures", "rigid"], "--closures must be stiff or soft, got 'rigid'"),
                         (["--closures", "STIFF"], "got 'STIFF'"),
                         (["--stiff", "--closures", "soft"], "--stiff")):
        bad = tmp_path / "bad.xml"
        message = assert_user_error(*run(capsys, "export-mjcf", "--mechanism", "five_bar", "--out", bad, *flags))
        assert words in message and not bad.exists()
