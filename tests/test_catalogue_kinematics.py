"""Every catalogue machine's kinematics checked by round trips and differences (``examples/mechanisms``; the
3-PRRR's in ``test_kinematic_redundancy.py``): at a regular pose, in its first working mode,

* the velocity Jacobian (the controlled coordinates' rates per actuator rate) inverts the inverse kinematics'
  derivative taken by central differences;
* forward kinematics at the inverse kinematics' actuators gives back its pose (FK∘IK);
* each assembly mode forward kinematics finds gives back those actuators by the inverse kinematics of its pose in
  one of the working modes (IK∘FK) — unless no working mode reaches that pose within the strokes, or the mode
  is in another operation mode than the inverse kinematics' (a lower-mobility platform's parasitic motion).
"""

from __future__ import annotations

import warnings
from pathlib import Path

import numpy as np
import pytest
from test_catalogue import MACHINES, regular_mode

import pkmlab
from pkmlab.algorithms.assembly import assembly_modes
from pkmlab.errors import IncompleteSolutionWarning
from pkmlab.model import mechanism_model as mm

CATALOGUE = Path(__file__).resolve().parents[1] / "examples" / "mechanisms"


def _wrapped(a):
    return np.angle(np.exp(1j * np.asarray(a)))


@pytest.mark.parametrize("name", sorted(MACHINES))
def test_jacobian_and_round_trips(name):
    model = pkmlab.load(CATALOGUE / name)
    pose = np.array(MACHINES[name][2], dtype=float)
    mode = regular_mode(model, name)
    q = mm.inverse_kinematics(model, pose, mode)
    n = model.n_actuators
    theta = q[:n]
    h = 1e-6
    d_theta = np.column_stack([_wrapped(mm.inverse_kinematics(model, pose + h * e, mode)[:n]
                                        - mm.inverse_kinematics(model, pose - h * e, mode)[:n]) / (2 * h)
                               for e in np.eye(len(pose))])
    np.testing.assert_allclose(pkmlab.velocity_jacobian(model, q) @ d_theta, np.eye(len(pose)), atol=1e-6)
    with warnings.catch_warnings():
        warnings.simplefilter("error", IncompleteSolutionWarning)
        found = assembly_modes(model, theta)
    poses = np.array([mm.pose_of(model, qj) for qj, _s in found])
    assert np.abs(_wrapped(poses - pose)).max(axis=1).min() < 1e-9  # FK∘IK
    # IK∘FK, every assembly mode's pose in every working mode at once (a lower-mobility platform's parasitic motion
    # solved once for them all): a platform of lower mobility's inverse kinematics gives the parasitic motion of one
    # operation mode (the 3-UPU wrist's about its centre), and the assembly modes of its others are not compared
    configurations = np.array([qj for qj, _s in found])
    parasitic = [model.coordinates.index(c) for c in getattr(model.description.platform, "parasitic_names", ())]
    best, branches = np.full(len(found), np.inf), {}
    for other in mm.working_modes(model):
        qk, unreachable, _first = mm.inverse_kinematics_batch(model, poses, other, branches=branches)
        with np.errstate(invalid="ignore"):  # the rows a working mode does not reach are NaN
            same = (unreachable == 0) & (np.abs(_wrapped(qk[:, parasitic] - configurations[:, parasitic]))
                                         .max(axis=1, initial=0.0) < 1e-8)
        best = np.where(same, np.minimum(best, np.abs(_wrapped(qk[:, :n] - theta)).max(axis=1)), best)
    compared = np.isfinite(best)
    assert compared.any() and best[compared].max() < 1e-8, poses[compared][best[compared] >= 1e-8]
