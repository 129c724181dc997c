"""Mechanism descriptions: the presets say what their specifications say, their TOML form reads
back as the same value, and a description that cannot be a mechanism is refused in one line that
names the leg, the joint, the body or the key."""

import math
import tomllib

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

import pkmlab
from pkmlab.description.files import load_mechanism, mechanism_from_dict, mechanism_to_toml
from pkmlab.description.mechanism import Body, Joint, Leg, Mechanism, Platform, attachment_point, leg_chain
from pkmlab.description.presets import PRESETS, preset
from pkmlab.paper import kinematics as kin
from pkmlab.paper.geometry import Planar3RRR

B = 0.52  # the paper's base side
BASE = [(0.0, 0.0), (B, 0.0), (B / 2, math.sqrt(3) / 2 * B)]
A = 0.125  # the paper's platform side


def u(x):
    return np.array([math.cos(x), math.sin(x)])


def vertices(pose):
    """The paper's platform vertices from the centroid pose, written from the paper's definitions:
    p2 = p1 + a u(alpha), p3 = p1 + a u(alpha + pi/3), centroid = p1 + (a/sqrt3) u(alpha + pi/6)."""
    x, y, alpha = pose
    p1 = np.array([x, y]) - A / math.sqrt(3) * u(alpha + math.pi / 6)
    return [p1, p1 + A * u(alpha), p1 + A * u(alpha + math.pi / 3)]


# ------------------------------------------------------------------ presets
def test_presets_are_the_specified_machines():
    expected = {"paper": ("3-R*RR", 3, ("R",) * 3), "five_bar": ("2-R*RR", 2, ("R",) * 2),
                "3rpr": ("3-RP*R", 3, ("P",) * 3), "3prr": ("3-P*RR", 3, ("P",) * 3)}
    for name, (notation, dof, actuators) in expected.items():
        m = preset(name)
        assert (m.notation, m.dof, m.actuator_kinds, m.name) == (notation, dof, actuators, name)
        assert m.gravity == (0.0, 0.0)  # all in the horizontal plane
    assert preset("3rpr").legs[0].stroke == (0.10, 0.45) and preset("3prr").legs[2].stroke == (0.0, B)
    assert set(PRESETS) == {"paper", "five_bar", "3rpr", "3prr", "delta", "stewart"}
    delta = preset("delta")
    assert (delta.notation, delta.dof, delta.actuator_kinds, delta.pose_names) == ("3-R*US", 3, ("R",) * 3,
                                                                                 ("x", "y", "z"))
    assert delta.gravity == (0.0, 0.0, -9.81)


@settings(max_examples=60, deadline=None)
@given(pose=st.tuples(st.floats(0.15, 0.35), st.floats(0.1, 0.3), st.floats(-1.0, 1.0)),
       angles=st.lists(st.floats(-math.pi, math.pi), min_size=6, max_size=6),
       strokes=st.lists(st.floats(0.1, 0.45), min_size=3, max_size=3))
def test_each_leg_chain_is_its_formula(pose, angles, strokes):
    """Every preset's legs, evaluated by the generic chain, against the machine's formulas written out."""
    theta, phi = angles[:3], angles[3:]
    for i, leg in enumerate(preset("paper").legs):  # e = b + l u(theta), p = e + r u(phi)
        end = leg_chain(leg, [theta[i], phi[i]])[-1][0]
        np.testing.assert_allclose(end, BASE[i] + 0.25 * u(theta[i]) + 0.1667 * u(phi[i]), atol=1e-15)
    for i, leg in enumerate(preset("3rpr").legs):  # p = b + rho u(psi); rod's mass centre 0.06 m back from p
        (cyl, _), (rod, rod_dir), (end, _) = leg_chain(leg, [phi[i], strokes[i]])
        np.testing.assert_allclose(end, BASE[i] + strokes[i] * u(phi[i]), atol=1e-15)
        assert cyl == BASE[i] and rod_dir == phi[i]
        np.testing.assert_allclose(np.array(rod) + leg.bodies[1].com[0] * u(rod_dir),
                                   BASE[i] + (strokes[i] - 0.06) * u(phi[i]), atol=1e-15)
    beta = (0.0, 2 * math.pi / 3, 4 * math.pi / 3)
    for i, leg in enumerate(preset("3prr").legs):  # C = b + s u(beta), p = C + r u(phi)
        (slider, _), _link, (end, _) = leg_chain(leg, [strokes[i], phi[i]])
        np.testing.assert_allclose(slider, BASE[i] + strokes[i] * u(beta[i]), atol=1e-15)
        np.testing.assert_allclose(end, BASE[i] + strokes[i] * u(beta[i]) + 0.25 * u(phi[i]), atol=1e-15)
    for i, leg in enumerate(preset("five_bar").legs):  # P = A + l u(theta) + r u(phi)
        end = leg_chain(leg, [theta[i], phi[i]])[-1][0]
        np.testing.assert_allclose(end, np.array([(-0.1, 0.0), (0.1, 0.0)][i]) + 0.25 * u(theta[i]) + 0.30 * u(phi[i]),
                                   atol=1e-15)
    # the platform: attachment points of the rigid presets are the paper's vertices, the point's is the point
    for name in ("paper", "3rpr", "3prr"):
        for i, p in enumerate(vertices(pose)):
            np.testing.assert_allclose(attachment_point(preset(name), i, pose), p, atol=1e-15)
    assert attachment_point(preset("five_bar"), 1, pose[:2]) == pose[:2]


def test_the_paper_preset_closes_its_loops_at_pkmlabs_inverse_kinematics():
    """The description and the 3-RRR kernels agree: at an IK configuration, every leg reaches its vertex."""
    mech, model = preset("paper"), Planar3RRR.paper()
    for pose in ([0.2, 0.21, 0.0], [0.27, 0.18, 0.4]):
        for mode in ((-1, 1, -1), (1, 1, 1)):
            q = kin.inverse_kinematics(model, pose, mode=mode).q
            for i, leg in enumerate(mech.legs):
                end = leg_chain(leg, [q[i], q[3 + i]])[-1][0]
                np.testing.assert_allclose(end, attachment_point(mech, i, pose), atol=1e-12)


# ------------------------------------------------------------------ the TOML form
@pytest.mark.parametrize("name", sorted(PRESETS))
def test_toml_form_reads_back_as_the_same_mechanism(name, tmp_path):
    path = tmp_path / f"{name}.toml"
    path.write_text(mechanism_to_toml(preset(name), f"pkmlab preset {name}"))
    assert load_mechanism(path) == preset(name)
    assert mechanism_from_dict({"preset": name}) == preset(name)


def test_a_users_own_machine_from_its_file(tmp_path):
    """A 3-RPR whose platform is not similar to its base, in a vertical plane (gravity), from TOML."""
    path = tmp_path / "mine.toml"
    path.write_text("""
[mechanism]
name = "my 3-RPR"
gravity = [0.0, -9.81]

[mechanism.platform]
kind = "rigid"
attachments = [[-0.05, -0.02], [0.07, -0.03], [0.0, 0.06]]
mass = 0.3
com = [0.0, 0.005]
inertia = 4e-4

[[mechanism.leg]]
base = [0.0, 0.0]
joints = "RP*R"
stroke = [0.05, 0.5]
bodies = [{ mass = 0.5, com = [0.08, 0.0], inertia = 1.5e-3 }, { mass = 0.25, com = [-0.06, 0.0], inertia = 6e-4 }]

[[mechanism.leg]]
base = [0.6, 0.0]
joints = "RP*R"
stroke = [0.05, 0.5]
bodies = [{ mass = 0.5, com = [0.08, 0.0], inertia = 1.5e-3 }, { mass = 0.25, com = [-0.06, 0.0], inertia = 6e-4 }]

[[mechanism.leg]]
base = [0.2, 0.5]
joints = "RP*R"
stroke = [0.05, 0.5]
bodies = [{ mass = 0.5, com = [0.08, 0.0], inertia = 1.5e-3 }, { mass = 0.25, com = [-0.06, 0.0], inertia = 6e-4 }]
""")
    m = load_mechanism(path)
    assert m.notation == "3-RP*R" and m.gravity == (0.0, -9.81) and m.legs[2].base == (0.2, 0.5)
    assert mechanism_from_dict(tomllib.loads(mechanism_to_toml(m))["mechanism"]) == m


# ------------------------------------------------------------------ what cannot be a mechanism
def _leg(joints="R*RR", bodies=None, **kw):
    bodies = bodies if bodies is not None else [{"tip": [0.25, 0.0], "mass": 0.4, "com": [0.1, 0.0], "inertia": 2e-3},
                                                {"tip": [0.2, 0.0], "mass": 0.3, "com": [0.1, 0.0], "inertia": 1e-3}]
    return {"base": kw.pop("base", [0.0, 0.0]), "joints": joints, "bodies": bodies, **kw}


def _rigid(legs, **platform):
    return {"platform": {"attachments": [[-0.06, -0.03], [0.06, -0.03], [0.0, 0.07]], "mass": 0.2, "inertia": 3e-4,
                         **platform}, "leg": legs}


def _three(**kw):
    return [_leg(base=b, **kw) for b in ([0.0, 0.0], [0.5, 0.0], [0.25, 0.43])]


BAD = {
    "unknown joint type": (_rigid([_leg("R*QR")] * 3), "leg[1].joints"),
    "no actuator": (_rigid(_three(joints="RRR")), "leg 1 (RRR) has no actuated joint"),
    # a fourth joint, actuated, moves the base of an ordinary leg (RRR) with no actuator of its own
    "a moved base carrying no actuator": (
        _rigid(_three(joints="R*RRR", bodies=[{"tip": [0.1, 0.0], "mass": 0.2, "inertia": 1e-3}] * 3)),
        "leg 1 (R*RRR): the ordinary leg its first joint moves (RRR) has no actuated joint"),
    "actuated last joint": (_rigid(_three(joints="RRR*")), "leg 1: its last joint carries the platform"),
    "legs of one joint too few": (_rigid([_leg("R*R", bodies=[{"tip": [0.3, 0], "mass": 1, "inertia": 1e-3}],
                                               base=b) for b in ([0, 0], [0.5, 0], [0.25, 0.43])]),
                                  "mobility (Grübler"),
    "two legs for a rigid platform": (_rigid(_three()[:2], attachments=[[0, 0], [0.1, 0]]),
                                      "needs at least 3 actuated legs"),
    "a body too few": (_rigid([_leg(bodies=[{"tip": [0.25, 0], "mass": 0.4, "inertia": 2e-3}])] * 3), "2 bodies"),
    "zero-length link": (_rigid([_leg(bodies=[{"tip": [0.0, 0.0], "mass": 0.4, "inertia": 2e-3},
                                              {"tip": [0.2, 0.0], "mass": 0.3, "inertia": 1e-3}])] * 3),
                         "leg 1, body 1: its tip must not be at its joint"),
    "negative mass": (_rigid([_leg(bodies=[{"tip": [0.25, 0], "mass": -0.4, "inertia": 2e-3},
                                           {"tip": [0.2, 0], "mass": 0.3, "inertia": 1e-3}])] * 3),
                      "leg 1, body 1.mass must be positive"),
    "NaN inertia": (_rigid([_leg(bodies=[{"tip": [0.25, 0], "mass": 0.4, "inertia": float("nan")},
                                         {"tip": [0.2, 0], "mass": 0.3, "inertia": 1e-3}])] * 3),
                    "leg 1, body 1.inertia must be a finite number"),
    "a rotating body without inertia": (_rigid([_leg(bodies=[{"tip": [0.25, 0], "mass": 0.4, "inertia": 0.0},
                                                             {"tip": [0.2, 0], "mass": 0.3, "inertia": 1e-3}])] * 3),
                                        "it rotates, so its inertia must be positive"),
    "empty stroke": (_rigid(_three(stroke=[0.4, 0.1])), "leg 1: the stroke [0.4, 0.1] is empty"),
    "rail without axis": (_rigid(_three(joints="P*RR")), "leg 1, joint 1: a prismatic joint on the base needs"),
    "axis on a revolute": (_rigid(_three(axis=0.5)), "leg 1, joint 1: 'axis' is only for a prismatic joint"),
    "attachments that coincide": (_rigid(_three(), attachments=[[0, 0], [0, 0], [0.1, 0.1]]),
                                  "platform attachments 1 and 2 coincide"),
    "one attachment too few": (_rigid(_three(), attachments=[[0, 0], [0.1, 0]]), "3 legs, 2 attachment points"),
    "platform without mass": (_rigid(_three(), mass=0.0), "platform mass must be positive"),
    "unknown key": ({**_rigid(_three()), "gravty": [0, -9.81]}, "unknown key 'gravty' in [mechanism] (did you mean "
                                                                "'gravity'?)"),
    "unknown body key": (_rigid([_leg(bodies=[{"tip": [0.25, 0], "mas": 0.4, "inertia": 2e-3},
                                              {"tip": [0.2, 0], "mass": 0.3, "inertia": 1e-3}])] * 3),
                         "unknown key 'mas' in [mechanism].leg[1].bodies[1] (did you mean 'mass'?)"),
    "preset and description": ({"preset": "paper", "name": "x"}, "give either preset or a description"),
    "unknown preset": ({"preset": "delta_robot"}, "unknown mechanism preset 'delta_robot'"),
    "no legs": ({"platform": {"mass": 0.1}, "leg": []}, "[mechanism].leg must be a list of legs"),
}


@pytest.mark.parametrize("table, expected", BAD.values(), ids=BAD.keys())
def test_what_cannot_be_a_mechanism_is_refused_in_one_line(table, expected):
    with pytest.raises(pkmlab.InvalidParameterError) as info:
        mechanism_from_dict(table)
    message = str(info.value)
    assert expected in message and "\n" not in message, message


def test_a_file_error_names_the_file(tmp_path):
    path = tmp_path / "broken.toml"
    path.write_text('[mechanism]\nplatform = { mass = 0.1, kind = "point" }\n[[mechanism.leg]]\nbase = [0, 0]\n'
                    'joints = "RRR"\n')
    with pytest.raises(pkmlab.InvalidParameterError, match=r"^broken.toml: .*no actuated joint"):
        load_mechanism(path)


def test_values_are_immutable_and_compare_by_content():
    m = preset("five_bar")
    with pytest.raises(AttributeError):
        m.name = "other"
    assert m == preset("five_bar") and m != preset("paper")
    assert Mechanism("five_bar", m.legs, m.platform) == m
    assert isinstance(m.legs[0], Leg) and isinstance(m.legs[0].joints[0], Joint)
    assert isinstance(m.legs[0].bodies[0], Body) and isinstance(m.platform, Platform)
