"""The shortcuts taken for speed give the numbers of the long way.

* The command line's one-shot commands run their kernels interpreted in a process of their own: same
  results as the compiled kernels, and Numba is not even imported.
* A computed-torque controller whose model is the plant takes over the plant's configuration and hands
  its model to the RK4 step's first stage: the run equals, to round-off, the run whose plant differs from
  the model in the last bit of one mass (no reuse).
* The operation count behind the benchmarks' arithmetic limit counts what it claims to.

(Speed itself is measured by ``make bench``, never asserted here.)
"""

from __future__ import annotations

import json
import math
import os
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
from conftest import one_shot

import pkmlab
from pkmlab.formats.scenario import paper_scenario
from pkmlab.model import mechanism_model as mm
from pkmlab.paper.geometry import Planar3RRR
from pkmlab.paper.kinematics import forward_kinematics, inverse_kinematics
from pkmlab.simulation.run import simulate

BENCHMARKS = Path(__file__).resolve().parents[1] / "benchmarks"


def test_ik_from_the_command_line_is_interpreted_and_equals_the_compiled_kernels():
    result, numba_imported = one_shot("ik", "0.2", "0.21", "0")
    assert not numba_imported
    ik = pkmlab.inverse_kinematics(pkmlab.load("paper"), [0.2, 0.21, 0.0])
    assert len(result["solutions"]) == 8
    for solution, q, s in zip(result["solutions"], ik.q, ik.S, strict=True):
        assert solution["theta"] == q[:3].tolist() and solution["passive"] == q[3:6].tolist()
        assert solution["S"] == pytest.approx(s, rel=1e-14)
    # and the paper's own formulation (7 coordinates) agrees
    own = inverse_kinematics(Planar3RRR.paper(), [0.2, 0.21, 0.0])
    np.testing.assert_allclose([s["theta"] for s in result["solutions"]], own.q[:, :3], rtol=0, atol=1e-12)


def test_fk_from_the_command_line_is_interpreted_and_equals_the_compiled_kernels():
    theta = [0.189012, 3.112031, -2.642405]
    result, numba_imported = one_shot("fk", *map(str, theta))
    assert not numba_imported
    fk = pkmlab.forward_kinematics(pkmlab.load("paper"), theta)
    assert len(result["solutions"]) == len(fk) == len(forward_kinematics(Planar3RRR.paper(), theta))
    # to round-off (a few units in the last place: the compiled polynomial solve fuses multiplications and
    # additions where Python rounds each), not bit for bit as ik
    for solution, mode in zip(result["solutions"], fk, strict=True):
        np.testing.assert_allclose(solution["passive"], mode.q[3:6], rtol=0, atol=1e-13)
        np.testing.assert_allclose(solution["pose"], mode.pose, rtol=0, atol=1e-13)
        assert solution["S"] == pytest.approx(mode.S, rel=1e-12)


@pytest.mark.parametrize("name, theta", [("paper", [0.189, 3.112, -2.642]), ("delta", [0.2383, 0.4211, 0.3284])])
def test_dynamics_from_the_command_line_is_interpreted_and_equals_the_compiled_kernels(name, theta):
    result, numba_imported = one_shot("dynamics", "--mechanism", name, *map(str, theta), "--rates", "0.3", "-0.2",
                                      "0.5")
    assert not numba_imported
    model = pkmlab.load(name)
    fk = pkmlab.forward_kinematics(model, theta)
    assert len(result["solutions"]) == len(fk)
    for record, mode in zip(result["solutions"], fk, strict=True):
        reduced = pkmlab.actuator_space_model(model, mode.q, [0.3, -0.2, 0.5])
        np.testing.assert_allclose(record["M"], reduced.M, rtol=1e-11, atol=1e-14)
        np.testing.assert_allclose(record["c"], reduced.c, rtol=1e-9, atol=1e-13)
        np.testing.assert_allclose(record["g"], reduced.g, rtol=1e-11, atol=1e-13)


def test_ik_of_a_described_machine_is_interpreted_and_equals_the_compiled_kernels():
    result, numba_imported = one_shot("ik", "--mechanism", "delta", "0.05", "-0.02", "-0.7")
    assert not numba_imported
    model = mm.MechanismModel.from_preset("delta")
    for solution in result["solutions"]:
        q = mm.inverse_kinematics(model, [0.05, -0.02, -0.7], tuple(solution["mode"]))
        assert solution["theta"] == q[:3].tolist()
        assert solution["S"] == pytest.approx(mm.singularity_measure(model, q), rel=1e-14)


def _plant_off_by_one_bit(model):
    """The same machine but the platform's mass one unit in the last place heavier: not the model."""
    import dataclasses

    d = model.description
    platform = dataclasses.replace(d.platform, mass=float(np.nextafter(d.platform.mass, np.inf)))
    return pkmlab.load(dataclasses.replace(d, platform=platform))


@pytest.mark.parametrize("case", ["nominal", "fast"])
def test_the_controller_sharing_the_plants_model_equals_the_run_without_sharing(case):
    shared = paper_scenario(case)
    apart = shared.replace(plant=_plant_off_by_one_bit(shared.model))
    assert apart.plant_model != shared.model
    a, b = simulate(shared), simulate(apart)
    for name in ("q", "theta_dot", "tau"):
        x, y = getattr(a, name), getattr(b, name)
        assert np.abs(x - y).max() <= 1e-12 * np.abs(y).max(), name


def test_the_operation_count_counts_unrolled_loops_sizes_and_skips_index_arithmetic():
    sys.path.insert(0, str(BENCHMARKS))
    try:
        from operation_count import own_operations
    finally:
        sys.path.remove(str(BENCHMARKS))

    def kernel(a, b, out, m):
        n = N  # noqa: F821  (the structure's constants: given to the count, never run)
        for i in range(n):  # 3 passes of 2 operations (the index i + 1 is not one)
            out[i + 1] = a[i] * b[i] + 1.0
        for k in range(m):  # m passes of 1
            out[k] -= a[k]
        if DIM == 3:  # noqa: F821  (a constant branch: not taken)
            out[0] = out[0] / 2.0
        return math.sqrt(out[0] ** 3) + math.cos(a[0])

    flops, libm = own_operations(kernel, {"N": 3, "DIM": 2}, {"m": 4})
    assert (flops, libm) == (3 * 2 + 4 + 2 + 1 + 1, 1)  # ** 3 is 2 multiplications, sqrt 1, the final + 1


def test_one_sample_of_the_nominal_case_evaluates_the_model_four_times():
    """Counted in an interpreted run: the controller and the RK4 stages evaluate the model 4 times per sample
    (not 5: the first stage takes the controller's), and branch following runs 4 times (not 5)."""
    code = (f"import sys, json\nsys.path.insert(0, {str(BENCHMARKS)!r})\nimport operation_count as oc\n"
            "r = oc.count_preset('paper', samples=20)\nprint(json.dumps(r))")
    env = {**os.environ, "PKMLAB_INTERPRETED": "1"}
    out = subprocess.run([sys.executable, "-c", code], check=True, capture_output=True, text=True, env=env).stdout
    count = json.loads(out)
    calls = {f["function"]: f["calls_per_sample"] for f in count["functions"]}
    assert calls["actuator_space_model"] == 4
    assert calls["follow_branch"] == 4
    assert calls["copy_model"] == 1
    assert count["operations_per_sample"] > 0 and count["libm_calls_per_sample"] > 0
