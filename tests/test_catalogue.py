"""The catalogue of machines from the literature (``examples/mechanisms``): each description loads with its
computed mobility, solves its inverse kinematics in its working modes on the loop closures, and its default
run's scenario reads.

Independent checks: the mobility against the machines' textbook counts (a 3-PRS and a 3-RPS: 3, each leg
removing one freedom, and a 3-RRS likewise; Tsai's 3-UPU: 3, translations; a 3-UPU wrist: 3, rotations, each
leg's universal joint at the platform removing one; the Agile Eye: 3, rotations, each leg's 5 rows removing 3
freedoms; a 6-RUS and a 6-PUS: 6); the
configurations against the readable chain of :func:`~pkmlab.description.spatial.leg_frames` (not the generated
kernels); the forward kinematics' complex solution counts against the literature's (16 for the 3-RPS, Lee and
Shah's machine; 40 for a general 6-RUS and 6-PUS, as for the general Stewart-Gough platform).
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest
from test_lower_mobility import _independent_residual

import pkmlab
from pkmlab.codegen import spatial
from pkmlab.description import spatial_legs
from pkmlab.description.files import load_mechanism
from pkmlab.description.mobility import mobility
from pkmlab.model import mechanism_model as mm

CATALOGUE = Path(__file__).resolve().parents[1] / "examples" / "mechanisms"
#: file, its mobility, each leg's share, a regular pose, its working modes
MACHINES = {
    "3prs.toml": (3, 1, [0.45, 0.05, -0.03], 8),
    "3rps.toml": (3, 1, [0.5, 0.05, -0.03], 1),
    "3rrs.toml": (3, 1, [0.34, 0.05, -0.03], 8),
    "3upu.toml": (3, 0, [0.02, -0.01, 0.62], 1),
    "3upu_wrist.toml": (3, 1, [0.1, -0.05, 0.2], 1),
    "agile_eye.toml": (3, 3, [0.1, -0.05, 0.2], 8),
    "3puu.toml": (3, 0, [0.03, -0.02, 0.04], 8),
    "6rus.toml": (6, 0, [0.0, 0.0, -0.30, 0.05, -0.03, 0.1], 64),
    "6pus.toml": (6, 0, [0.0, 0.0, -0.30, 0.05, -0.03, 0.1], 64),
    "4ruu.toml": (4, 1, [0.01, -0.005, -0.45, 0.03], 16),
    "3crr.toml": (3, 2, [0.01, 0.02, -0.01], 8),
}
#: The working mode the checks of a regular pose take, where the first is not regular there: the 4-RUU's elbows
#: all out put its forearms' lines on one regulus of a hyperboloid (singular at every symmetric pose, nearly so
#: at the pose above); alternate elbows are regular.
MODES = {"4ruu.toml": (1, -1, 1, -1)}


def regular_mode(model, name: str) -> tuple:
    """The working mode of the checks at ``MACHINES[name]``'s pose."""
    return MODES.get(name, mm.working_modes(model)[0])


#: The catalogue's planar machines, checked in test_kinematic_redundancy.py.
PLANAR = {"3prrr.toml"}
#: Redundantly actuated machines, checked and run in test_actuation_redundancy.py and test_leg_of_two_actuators.py.
REDUNDANT = {"4rrr.toml", "3rrr_redundant.toml", "4delta.toml", "3rrr_elbow.toml", "3rrs_knee.toml"}


def test_every_description_of_the_catalogue_is_checked_here():
    files = {p.name for p in CATALOGUE.glob("*.toml") if not p.name.endswith("_motion.toml")}
    assert files == set(MACHINES) | PLANAR | REDUNDANT
    assert {p.name for p in CATALOGUE.glob("*_motion.toml")} == {f.replace(".toml", "_motion.toml")
                                                                 for f in set(MACHINES) | PLANAR | REDUNDANT}


@pytest.mark.parametrize("name", sorted(MACHINES))
def test_catalogue_machine_mobility_and_inverse_kinematics(name):
    """The first working mode and the last (every branch flipped), where within the strokes: the configuration on
    the loop closures by the readable chain. A platform of full mobility is solved leg by leg in closed form from
    the description alone; one of lower mobility through its model (its parasitic motion first)."""
    dof, share, pose, modes = MACHINES[name]
    description = load_mechanism(CATALOGUE / name)
    assert description.platform.pose_names == (("x", "y", "z", "roll", "pitch", "yaw") if dof == 6
                                                else ("x", "y", "z") if description.platform.kind == "translating"
                                                or name == "3crr.toml"  # a rigid platform the legs hold level
                                                else ("roll", "pitch", "yaw") if name in ("3upu_wrist.toml",
                                                                                          "agile_eye.toml")
                                                else ("x", "y", "z", "yaw") if dof == 4
                                                else ("z", "roll", "pitch"))
    r = mobility(description)
    assert r.mobility == dof and set(r.leg_constraints) == {share}
    if description.platform.parasitic_names:
        model = pkmlab.load(CATALOGUE / name)
        working = mm.working_modes(model)
        coordinates = model.coordinates

        def solve(mode):
            return mm.inverse_kinematics(model, pose, mode)
    else:
        working = [tuple(m) for m in itertools.product(*[spatial_legs.working_modes(leg) or (1,)
                                                          for leg in description.legs])]
        coordinates = spatial.coordinate_names(description)

        def solve(mode):
            return _closed_form_configuration(description, pose, mode)
    assert len(working) == modes
    solved = 0
    for mode in (working[0], working[-1]):
        try:
            q = solve(mode)
        except pkmlab.UnreachablePoseError as error:
            assert mode != working[0] and "outside its stroke" in str(error)
            continue
        solved += 1
        np.testing.assert_allclose(q[-dof:], pose, atol=0)
        assert _independent_residual(description, q, coordinates) < 1e-12
    assert solved >= 1


def _closed_form_configuration(description, pose, mode) -> np.ndarray:
    """``q`` (the kernels' order) of a platform of full mobility at ``pose``, leg by leg in closed form."""
    from pkmlab.description.spatial import attachment_points

    actuators, passive = [], []
    axis = spatial_legs.central_axis(description)
    for i, (leg, sigma) in enumerate(zip(description.legs, mode, strict=True)):
        solved = spatial_legs.leg_inverse_kinematics_batch(leg, i, attachment_points(description, i, np.array([pose])),
                                                           sigma, axis)
        if solved.bad[0]:
            raise pkmlab.UnreachablePoseError(solved.why(0), legs=(i + 1,))
        column = sum(j.coordinates for j in leg.joints[:leg.actuated])
        actuators.append(solved.coordinates[0, column])
        passive += [v for k, v in enumerate(solved.coordinates[0]) if k != column]
    return np.array([*actuators, *passive, *pose])


@pytest.mark.parametrize("name", sorted(MACHINES))
def test_catalogue_scenarios_name_their_machine_and_its_pose(name):
    """Each default run is of its machine, in its controlled coordinates (read in full — its kernels bound —
    for the machines of lower mobility; the six-legged ones' kernels are derived by ``make bench``)."""
    import tomllib

    dof = MACHINES[name][0]
    path = CATALOGUE / name.replace(".toml", "_motion.toml")
    table = tomllib.loads(path.read_text())
    assert table["mechanism"] == {"file": name}
    assert {len(p) for p in table["trajectory"]["points"]} == {dof}
    if dof < 6:
        scenario = pkmlab.load_scenario(path)
        assert scenario.model.description == load_mechanism(CATALOGUE / name)


def test_an_axis_that_is_not_a_unit_vector_is_refused_by_leg_joint_and_axis(tmp_path):
    """A direction written to six digits is normalised; one that is not a unit vector at all is a mistake, refused
    in one line naming where it is (it was silently normalised into another machine)."""
    text = (CATALOGUE / "3prs.toml").read_text()
    assert "axes = [[0.0, 0.0, 1.0], [-1.0, 0.0, 0.0]]" in text
    assert "[0.5, -0.866025403784, 0.0]]" in text
    (tmp_path / "six.toml").write_text(text.replace("[0.5, -0.866025403784, 0.0]]", "[0.5, -0.866025, 0.0]]", 1))
    axis = load_mechanism(tmp_path / "six.toml").legs[1].joints[1].axes[0]
    assert np.linalg.norm(axis) == pytest.approx(1.0, abs=1e-15) and axis[0] == pytest.approx(0.5, abs=1e-6)
    (tmp_path / "bad.toml").write_text(text.replace("[[0.0, 0.0, 1.0], [-1.0", "[[0.3, 0.0, 1.0], [-1.0", 1))
    with pytest.raises(pkmlab.PkmlabError) as refused:
        load_mechanism(tmp_path / "bad.toml")
    message = str(refused.value)
    assert "\n" not in message and "leg 1, joint 1 (P): axis 1 must be a unit vector, got [0.3, 0.0, 1.0]" in message
