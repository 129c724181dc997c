"""The default runs of the catalogue's machines that no other file runs (``examples/mechanisms/*_motion.toml``: the
3-RPS, the 6-RUS, the 6-PUS, the 3-PUU and the 4-RUU; the others are run with their machine's own checks): each
tracked to within its sampling — computed torque on a model equal to the plant leaves the error of holding the
effort over a sample, first order in the sample time, so halving it halves the error — and each sample's
configuration on the loop closures of the description's readable chain
(:func:`pkmlab.description.spatial.leg_frames`), not the generated kernels', and none of them subnormal.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest
from test_lower_mobility import _independent_residual

import pkmlab

CATALOGUE = Path(__file__).resolve().parents[1] / "examples" / "mechanisms"
RUNS = ["3rps.toml", "6rus.toml", "6pus.toml", "3puu.toml", "4ruu.toml", "3crr.toml"]


@pytest.mark.parametrize("name", RUNS)
def test_a_default_run_is_tracked_to_its_sampling_on_the_loop_closures(name):
    scenario = pkmlab.load_scenario(CATALOGUE / name.replace(".toml", "_motion.toml"))
    result = pkmlab.simulate(scenario)
    finer = pkmlab.simulate(scenario.replace(sample_time=scenario.sample_time / 2))
    error = np.abs(result.pose - result.pose_d).max(axis=0)
    ratio = np.abs(finer.pose - finer.pose_d).max(axis=0) / error
    assert np.all((0.45 < ratio) & (ratio < 0.55)), ratio
    assert error.max() < 1e-4  # m and rad: the paths are smooth and the gains high
    model = scenario.model
    assert max(_independent_residual(model.description, q, model.coordinates) for q in result.q[::25]) < 1e-12
    # a coordinate whose solution is 0 (the 4-RUU's roll and pitch) settles at 0, not in the subnormal numbers
    # Newton's quadratic steps end in (every operation on them is microcoded: the 4-RUU's loop ran 4× slower)
    for run in (result, finer):
        assert not np.any((run.q != 0) & (np.abs(run.q) < np.finfo(float).tiny))
