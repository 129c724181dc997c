"""Legs ending in a revolute joint under a rigid platform, their two orientation rows independent of the other loop
closures: the catalogue's 3-CRR (``examples/mechanisms/3crr.toml``), Kong and Gosselin's translational machine,
each leg's axes all parallel and the three legs' along x, y and z.

A revolute platform joint adds two rows, ``(R_leg a)·(R b_k) = 0`` for the two directions ``b_k`` across its axis
(:mod:`pkmlab.description.mobility`). The three legs' six rows have rank 3 beside the nine point rows, and no choice
of whole legs' rows is independent (two legs' four rows repeat one), so the model keeps single rows: one of each
leg. Independent checks: the generated kernels' rows against the description's readable chain, value for value at
configurations off the machine's; the platform level at inverse kinematics' configurations (geometry: a leg lets
the platform turn about its own axis only); forward kinematics' assembly modes, whose orientations can only keep
each leg's axis up to its sign — the identity and the half turns about x, y and z.
"""

from __future__ import annotations

import itertools
from pathlib import Path

import numpy as np
import pytest

import pkmlab
from pkmlab.algorithms.assembly import assembly_modes
from pkmlab.description import mobility as mob
from pkmlab.description.spatial import orientation
from pkmlab.model import mechanism_model as mm

CRR = Path(__file__).resolve().parents[1] / "examples" / "mechanisms" / "3crr.toml"
POSE = np.array([0.01, 0.02, -0.01])


@pytest.fixture(scope="module")
def crr():
    return pkmlab.load(CRR)


def _rows(model, q: np.ndarray) -> np.ndarray:
    """Every row of the description's loop closures (the rows set aside too) at configuration ``q``."""
    return mob.residual(model.description, mm._description_coordinates(model, q[None])[0])


def test_it_keeps_one_orientation_row_of_each_leg_where_no_whole_legs_rows_are_independent(crr):
    m = crr.description
    result = mob.mobility(m)
    assert (result.coordinates, result.constraints, result.rank, result.mobility) == (15, 15, 12, 3)
    assert mob.kept_leg_rows(m) == ((0,), (1,), (0,)) and result.kept == (*range(9), 9, 12, 13)
    assert crr.kernels.N_CONSTRAINTS == 12 and "_rows_xyx" in crr.kernels.__name__
    # the point rows with any two legs' four orientation rows: one too many (rank 12, not 13)
    j = mob.jacobian(m, np.array(result.configuration))
    for a, b in itertools.combinations(range(3), 2):
        rows = [*range(9), *mob.leg_rows(m, a)[3:], *mob.leg_rows(m, b)[3:]]
        assert np.linalg.matrix_rank(j[rows], tol=1e-8 * np.abs(j).max()) == 12


def test_the_kernels_rows_are_the_descriptions_rows_it_keeps(crr):
    """Off the machine's configurations (random coordinates), value for value, and the Jacobian against central
    differences of the description's rows."""
    kept = list(mob.mobility(crr.description).kept)
    rng = np.random.default_rng(4)
    for _ in range(5):
        q = rng.uniform(-1.0, 1.0, len(crr.coordinates)) * 0.5
        np.testing.assert_allclose(mm.constraint_residual(crr, q), _rows(crr, q)[kept], rtol=0, atol=1e-15)
        h = 1e-6
        differences = np.column_stack([(_rows(crr, q + h * e) - _rows(crr, q - h * e))[kept] / (2 * h)
                                       for e in np.eye(len(crr.coordinates))])
        np.testing.assert_allclose(mm.constraint_jacobian(crr, q), differences, rtol=0, atol=1e-8)


@pytest.mark.parametrize("mode", [(1, 1, 1), (1, -1, 1), (-1, -1, -1)])
def test_inverse_kinematics_holds_the_platform_level_and_closes_every_row(crr, mode):
    rng = np.random.default_rng(sum(mode) + 5)
    for _ in range(3):
        pose = POSE + rng.uniform(-0.03, 0.03, 3)
        q = mm.inverse_kinematics(crr, pose, mode)
        np.testing.assert_allclose(mm.pose_of(crr, q), pose, atol=0)
        assert np.abs(q[[crr.coordinates.index(c) for c in ("roll", "pitch", "yaw")]]).max() < 1e-12
        assert np.abs(_rows(crr, q)).max() < 1e-12  # all 15: the three rows set aside hold too


def test_forward_kinematics_gives_each_elbow_combination_for_the_four_orientations_that_keep_the_legs_axes(crr):
    """Every leg's axis kept up to its sign: the rotation is diagonal — the identity or a half turn about x, y or
    z — and, for each, the legs' elbows place the platform in 2 × 2 × 2 ways. At generic actuator values: the
    three kept orientation rows, quadrics in the orientation's three unknowns that no actuator enters, have
    Bézout's 8 solutions, each with its 8 elbow combinations."""
    from pkmlab.algorithms.general_fk import generic_solutions

    assert len(generic_solutions(crr.description)[0]) == 64
    q = mm.inverse_kinematics(crr, POSE, (1, -1, 1))
    found = assembly_modes(crr, q[:3])
    assert min(np.abs(np.angle(np.exp(1j * (qj - q)))).max() for qj, _s in found) < 1e-9
    turns = {}
    angles = [crr.coordinates.index(c) for c in ("roll", "pitch", "yaw")]
    for qj, _s in found:
        assert np.abs(_rows(crr, qj)).max() < 1e-10
        rotation = orientation(*qj[angles])
        assert np.abs(rotation - np.diag(np.diag(rotation))).max() < 1e-9
        key = tuple(np.round(np.diag(rotation)).astype(int))
        turns[key] = turns.get(key, 0) + 1
    assert turns == {(1, 1, 1): 8, (1, -1, -1): 8, (-1, 1, -1): 8, (-1, -1, 1): 8}
