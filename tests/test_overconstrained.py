"""An overconstrained machine whose rows a choice of whole leg types cannot make independent: the catalogue's 4-RUU
(``examples/mechanisms/4ruu.toml``) moving in Schönflies motion (x, y, z and yaw; roll and pitch held at zero by the
legs).

Each leg — a crank about a vertical axis, a forearm between universal joints whose inner axes are parallel and
horizontal, whose outer axes are vertical — holds the platform by a couple about the horizontal axis across its
axes (every axis of the leg is vertical or along that direction): two legs keep the platform level and four
overconstrain it. Its 16 loop-closure rows (3 point rows and 1 orientation row per leg) have rank 14 at every
configuration, and the orientation rows of all four legs of its one type are one too many: the model keeps
every point row and two single legs' orientation rows (:mod:`pkmlab.description.mobility`). Independent checks:
the level platform (the geometry, not anything pkmlab was told), every row of the description's readable chain
(the rows set aside too) at the inverse kinematics' configurations, and the forward kinematics' assembly modes.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import pkmlab
from pkmlab.algorithms.assembly import assembly_modes
from pkmlab.description import mobility as mob
from pkmlab.description.files import load_mechanism
from pkmlab.model import mechanism_model as mm

#: The working mode of alternate elbows: the same on all four legs puts the forearms' lines on one regulus of a
#: hyperboloid, and every symmetric pose is singular there.
MODE = (1, -1, 1, -1)
HOME = [0.0, 0.0, -0.453, 0.0]
RUU = Path(__file__).resolve().parents[1] / "examples" / "mechanisms" / "4ruu.toml"


@pytest.fixture(scope="module")
def ruu():
    return pkmlab.load(RUU)


def test_it_keeps_every_point_row_and_two_legs_orientation_rows(ruu):
    m = ruu.description
    result = mob.mobility(m)
    assert (result.coordinates, result.constraints, result.rank, result.mobility) == (18, 16, 14, 4)
    assert result.kept == (*range(12), 12, 13) and mob.orientation_rows(m) == (0, 1)
    assert ruu.kernels.N_CONSTRAINTS == 14 and "_rows_1100" in ruu.kernels.__name__
    # two legs of one type, derived apart: one with its orientation row, one without
    source = open(ruu.kernels.__file__).read()
    assert "R*UU+row" in source and "LEGS_0 = (0, 1)" in source and "LEGS_1 = (2, 3)" in source


def test_inverse_kinematics_holds_the_platform_level_and_closes_every_row(ruu):
    m = ruu.description
    rng = np.random.default_rng(3)
    for _ in range(3):
        pose = np.array(HOME) + rng.uniform(-1, 1, 4) * [0.02, 0.02, 0.01, 0.05]
        q = mm.inverse_kinematics(ruu, pose, MODE)
        np.testing.assert_allclose(mm.pose_of(ruu, q), pose, atol=0)
        np.testing.assert_allclose(q[[ruu.coordinates.index("roll"), ruu.coordinates.index("pitch")]], 0.0,
                                   atol=1e-12)
        x = mm._description_coordinates(ruu, q[None])[0]
        assert np.abs(mob.residual(m, x)).max() < 1e-12  # all 16 rows: the two set aside hold too
    # off the machine's configurations the rows set aside do not follow from the kept ones
    assert np.abs(mob.residual(m, x + 0.05)[[14, 15]]).max() > 1e-3


def test_forward_kinematics_finds_the_configuration_among_level_assembly_modes(ruu):
    q = mm.inverse_kinematics(ruu, HOME, MODE)
    found = assembly_modes(ruu, q[:4])
    assert min(np.abs(np.angle(np.exp(1j * (qj - q)))).max() for qj, _s in found) < 1e-9
    for qj, _s in found:  # each closes every row; roll and pitch 0 or a half turn (the platform upside down)
        x = mm._description_coordinates(ruu, qj[None])[0]
        assert np.abs(mob.residual(ruu.description, x)).max() < 1e-10
        tilt = qj[[ruu.coordinates.index("roll"), ruu.coordinates.index("pitch")]]
        assert np.abs(np.sin(tilt)).max() < 1e-9


def test_a_description_file_round_trips(ruu, tmp_path):
    from pkmlab.description.files import mechanism_to_toml

    path = tmp_path / "again.toml"
    path.write_text(mechanism_to_toml(ruu.description))
    assert load_mechanism(path) == ruu.description


def test_its_working_mode_is_followed_along_a_path(ruu):
    """Its cranks turn about axes parallel to the machine's central axis, where "knee out" (the elbow farther from
    that axis) swaps with no singularity: the label is the side of the plane through the crank's axis and the
    point. Along a path through the pose where two elbows were as far from the axis, the actuators change smoothly
    (a swap is a jump of about 2.6 rad in one step)."""
    waypoints = np.array([HOME, [0.02, 0.0, -0.46, 0.05], [0.0, 0.015, -0.445, -0.05], HOME])
    s = np.linspace(0.0, 1.0, 400)[:, None]
    poses = np.concatenate([a + s * (b - a) for a, b in zip(waypoints[:-1], waypoints[1:], strict=True)])
    q, _s, failure = mm.path_inverse_kinematics(ruu, poses, MODE, follow=True)
    assert failure is None
    assert np.abs(np.diff(q[:, :4], axis=0)).max() < 0.01
