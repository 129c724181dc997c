"""A long run's memory: the desired motion's rates are computed a chunk of samples at a time and a result's CSV is
written a chunk of rows at a time. Chunks change nothing: the same numbers bit for bit as in one piece, the same
text, the rates against central differences of the path's inverse kinematics across chunk boundaries, and the
first singular sample found in a later chunk is the path's."""

from __future__ import annotations

import numpy as np

from pkmlab.formats.scenario import paper_scenario
from pkmlab.model import mechanism_model as mm
from pkmlab.simulation import result as result_module
from pkmlab.simulation.run import simulate


def _circle(model, count: int, radius: float = 0.05, alpha: float = 0.0):
    """Poses (count, 3) on a circle about (0.2, 0.21) at unit angular rate, with their rates and accelerations."""
    t = np.linspace(0.0, 2 * np.pi, count)
    pose = np.column_stack([0.2 + radius * np.cos(t), 0.21 + radius * np.sin(t), np.full(count, alpha)])
    pose_dot = np.column_stack([-radius * np.sin(t), radius * np.cos(t), np.zeros(count)])
    pose_ddot = np.column_stack([-radius * np.cos(t), -radius * np.sin(t), np.zeros(count)])
    return t, pose, pose_dot, pose_ddot


def test_the_path_rates_are_the_same_in_chunks_and_match_central_differences(monkeypatch):
    model = mm.MechanismModel.from_preset("paper")
    mode = (-1, 1, -1)
    t, pose, pose_dot, pose_ddot = _circle(model, 2001)
    q, _s, failure = mm.path_inverse_kinematics(model, pose, mode)
    assert failure is None
    whole = mm.path_rates(model, q, pose_dot, pose_ddot)
    monkeypatch.setattr(mm, "PATH_CHUNK", 7)  # 286 chunks, the last one short
    chunked = mm.path_rates(model, q, pose_dot, pose_ddot)
    np.testing.assert_array_equal(chunked[0], whole[0])
    np.testing.assert_array_equal(chunked[1], whole[1])
    assert chunked[2] == whole[2] == -1
    theta = np.unwrap(q[:, :3], axis=0)
    h = t[1] - t[0]
    np.testing.assert_allclose(chunked[0][1:-1], (theta[2:] - theta[:-2]) / (2 * h), atol=2e-5)
    np.testing.assert_allclose(chunked[1][1:-1], (theta[2:] - 2 * theta[1:-1] + theta[:-2]) / h**2, atol=2e-3)


def test_the_first_singular_sample_of_a_later_chunk_is_the_paths(monkeypatch):
    """A path whose legs' inverse-kinematic Jacobian is singular from some sample on: the index is the same whether
    that sample falls in the first chunk or a later one."""
    model = mm.MechanismModel.from_preset("paper")
    _t, pose, pose_dot, pose_ddot = _circle(model, 50)
    q, _s, _failure = mm.path_inverse_kinematics(model, pose, (-1, 1, -1))
    q = q.copy()
    q[31:, 3:6] = q[31:, :3]  # every passive link along its actuated link: a leg stretched out, A singular
    expected = mm.path_rates(model, q, pose_dot, pose_ddot)[2]
    monkeypatch.setattr(mm, "PATH_CHUNK", 8)
    assert mm.path_rates(model, q, pose_dot, pose_ddot)[2] == expected == 31


def test_a_results_csv_is_the_same_text_in_chunks(tmp_path, monkeypatch):
    result = simulate(paper_scenario("nominal"))
    whole = result.to_csv(tmp_path / "whole.csv").read_text()
    monkeypatch.setattr(result_module, "CSV_CHUNK", 100)
    chunked = result.to_csv(tmp_path / "chunked.csv").read_text()
    assert chunked == whole
    lines = chunked.splitlines()
    assert lines[0] == ",".join(result.columns) and len(lines) == result.t.size + 1
    table = np.array([[float(v) for v in line.split(",")] for line in lines[1:]])
    np.testing.assert_array_equal(table, result.table())  # every value reads back exactly
