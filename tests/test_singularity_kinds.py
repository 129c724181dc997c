"""The three kinds of singularity (pkmlab.algorithms.singularities), each checked where theory or an
independent model puts it.

* Inverse (serial): at the boundary of a Delta leg's reach its two working modes meet (their arm angles
  coincide) — found by bisection on the inverse kinematics' reachability, not by the measure.
* Constraint: Tsai's 3-UPU loses its hold on the platform's orientation where its legs' constraint couples
  ``n_i = a_i1 × a_i2`` (each leg's base-joint axes in the world) are dependent; with the catalogue's
  geometry that is where two legs stand vertical in their radial planes, at ``(x, y) = (0, -0.30)`` for every
  height — and there MuJoCo's weld Jacobian of the machine as built (``test_upu``) loses rank too.
* Forward: the measure is ``S`` itself.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_upu import _as_built_mjcf, _as_built_state

import pkmlab
from pkmlab.algorithms.singularities import singularity_kinds
from pkmlab.model import mechanism_model as mm

UPU = Path(__file__).resolve().parents[1] / "examples" / "mechanisms" / "3upu.toml"


@pytest.fixture(scope="module")
def upu():
    return pkmlab.load(UPU)


def _q(model, pose, mode=None):
    return pkmlab.inverse_kinematics(model, pose, mode).q.reshape(-1, len(model.coordinates))[0]


@pytest.mark.parametrize("name, pose", [("paper", [0.25, 0.2, 0.0]), ("delta", [0.02, -0.01, -0.8]),
                                        ("stewart", [0.0, 0.0, 0.85, 0.05, -0.03, 0.1])])
def test_measures_are_scaled_and_the_forward_one_is_s(name, pose):
    model = pkmlab.load(name)
    q = _q(model, pose)
    kinds = singularity_kinds(model, q)
    assert 1e-3 < abs(float(kinds.inverse)) <= 1.0 and 1e-3 < float(kinds.constraint) <= 1.0
    assert float(kinds.forward) == float(pkmlab.singularity_measure(model, q))
    batch = singularity_kinds(model, np.stack([q, q]))
    assert batch.inverse.shape == (2,) and np.all(batch.constraint == kinds.constraint)


def test_the_inverse_measure_vanishes_where_a_deltas_working_modes_meet():
    delta = pkmlab.load("delta")
    start, direction = np.array([0.02, -0.01, -0.8]), np.array([0.0, 0.0, -1.0])
    inside, outside = 0.0, 1.0  # reachable at inside, not at outside (along the ray, m)
    with pytest.raises(pkmlab.UnreachablePoseError):
        _q(delta, start + outside * direction, (1, 1, 1))
    for _ in range(60):
        middle = (inside + outside) / 2
        try:
            _q(delta, start + middle * direction, (1, 1, 1))
            inside = middle
        except pkmlab.UnreachablePoseError:
            outside = middle
    edge = start + inside * direction
    knee_out = _q(delta, edge, (1, 1, 1))
    flipped = [_q(delta, edge, tuple(-1 if k == i else 1 for k in range(3)))[i] for i in range(3)]
    gaps = np.abs(np.array(flipped) - knee_out[:3])
    assert gaps.min() < 1e-5 < 1e-2 < np.sort(gaps)[1]  # one leg's two working modes meet at its reach's boundary
    at_edge = singularity_kinds(delta, knee_out)
    away = singularity_kinds(delta, _q(delta, start, (1, 1, 1)))
    assert abs(float(at_edge.inverse)) < 1e-4 < 0.1 < abs(float(away.inverse))
    assert abs(float(at_edge.forward)) > 1e-2  # a singularity of one kind only


def _couples(model, q) -> float:
    """det[n_1, n_2, n_3] of the legs' unit constraint couples, from each leg's base joint in the world."""
    from pkmlab.description.spatial import axis_rotation

    couples = []
    for leg, values in zip(model.description.legs, mm.leg_joint_values(model, q), strict=True):
        a1, a2 = (np.array(a) for a in leg.joints[0].axes)
        n = np.cross(a1, axis_rotation(a1, values[0]) @ a2)
        couples.append(n / np.linalg.norm(n))
    return float(np.linalg.det(np.array(couples)))


@pytest.mark.parametrize("z", [0.5, 0.6, 0.7])
def test_the_constraint_measure_vanishes_where_the_3upus_constraint_couples_are_dependent(upu, z):
    mujoco = pytest.importorskip("mujoco")
    m = mujoco.MjModel.from_xml_string(_as_built_mjcf(upu.description))
    d = mujoco.MjData(m)

    def weld_rank_ratio(q):
        d.qpos[:] = _as_built_state(upu, q, np.zeros_like(q))[0]
        mujoco.mj_forward(m, d)
        sv = np.linalg.svd(d.efc_J.reshape(d.nefc, m.nv), compute_uv=False)
        return sv[-1] / sv[0]

    # the description's coordinates have 12 digits: the couples of the singular pose cancel to about 1e-12
    singular, regular = _q(upu, [0.0, -0.30, z]), _q(upu, [0.0, -0.25, z])
    assert abs(_couples(upu, singular)) < 1e-10 < 1e-3 < abs(_couples(upu, regular))
    kinds = singularity_kinds(upu, np.stack([singular, regular]))
    assert kinds.constraint[0] < 1e-10 and kinds.constraint[1] > 1e-4
    assert np.all(np.abs(kinds.forward) > 1e-2) and np.all(np.abs(kinds.inverse) > 1e-2)  # only the constraint kind
    assert weld_rank_ratio(singular) < 1e-10 and weld_rank_ratio(regular) > 1e-3  # MuJoCo's as-built machine agrees
    assert kinds.nearest() == "constraint"


def test_ik_and_fk_report_every_kind_on_the_command_line(upu, capsys):
    """``--kinds`` adds the inverse and constraint measures beside S: the function's values, the constraint one
    zero where the 3-UPU's constraint couples are dependent and not at its home height."""
    import json

    from pkmlab.cli import main

    reports = []
    for pose in ([0.0, -0.30, 0.62], [0.02, -0.01, 0.62]):
        assert main(["ik", "--mechanism", str(UPU), *map(str, pose), "--kinds", "--json"]) == 0
        (solution,) = json.loads(capsys.readouterr().out)["solutions"]
        q = mm.inverse_kinematics(upu, pose, ())
        kinds = singularity_kinds(upu, q)
        assert solution["inverse"] == pytest.approx(float(kinds.inverse), rel=1e-12)
        assert solution["constraint"] == pytest.approx(float(kinds.constraint), rel=1e-12, abs=1e-15)
        reports.append(solution)
    assert reports[0]["constraint"] < 1e-12 < 1e-4 < reports[1]["constraint"]
    assert main(["fk", "--mechanism", str(UPU), *map(str, reports[1]["theta"]), "--kinds"]) == 0
    out = capsys.readouterr().out
    assert out.splitlines()[1].split()[-3:] == ["S", "inverse", "constraint"]
    assert main(["fk", "--mechanism", str(UPU), *map(str, reports[1]["theta"])]) == 0
    assert "constraint" not in capsys.readouterr().out  # only when asked
