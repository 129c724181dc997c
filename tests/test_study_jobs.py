"""Studies whose runs identify or calibrate: identification accuracy against effort noise (the plant's own base
parameters as the truth) and calibration accuracy against the instrument's noise (the residual after least
squares at the noise, the held-out error proportional to it), as sweeps of the Dask engine; their options
checked by name."""

from __future__ import annotations

import numpy as np
import pytest

import pkmlab
from pkmlab.model import mechanism_model as mm
from pkmlab.study import Study, study_from_dict, sweep

pytest.importorskip("pyarrow")

FIVE_BAR = pkmlab.load("five_bar")


def excitation_base(sample_time=1e-3) -> dict:
    """A five-bar's scenario tables running a 2 s Fourier motion about a well-conditioned pose (at rest at both
    ends: the coefficients satisfy Σ a_k = 0 and Σ k b_k = 0)."""
    mode = mm.working_modes(FIVE_BAR)[0]
    centre = mm.well_conditioned_configuration(FIVE_BAR, mode)[-2:]
    rng = np.random.default_rng(3)
    k = np.arange(1, 4)[:, None]
    a = rng.uniform(-1, 1, (3, 2)) * 0.05
    a -= a.mean(axis=0)
    b = rng.uniform(-1, 1, (3, 2)) * 0.05
    b[0] = -(k[1:] * b[1:]).sum(axis=0)
    return {"mechanism": {"preset": "five_bar"},
            "trajectory": {"type": "fourier", "center": centre.tolist(), "period": 2.0, "a": a.tolist(),
                           "b": b.tolist()},
            "controller": {"type": "computed_torque", "kp": 1000.0, "sample_time": sample_time},
            "simulation": {"working_mode": [int(m) for m in mode]}}


def test_an_identification_study_finds_the_plants_parameters_and_loses_them_to_noise():
    study = Study.create(excitation_base(), grid={"plant.effort_noise": [0.0, 3e-3]}, job="identify")
    table = sweep(study, workers=0)
    assert list(table["status"]) == ["ok", "ok"], table["message"].tolist()
    clean, noisy = table["base_error"]
    # noise-free: the efforts, held over each sample, give the plant's base parameters back to the filter's bias
    assert clean < 2e-4
    assert noisy > 10 * clean
    assert 0.3 < table["base_error_sigma"][1] < 10  # the error, in the σ the identification reports
    assert np.all(table["condition_number"] > 1) and table.attrs["summary"]["best_point"]["point"] == 0


def test_a_calibration_study_is_as_good_as_its_instrument():
    study = Study.create(excitation_base(), grid={"calibration.noise": [1e-6, 1e-5]}, job="calibrate", draws=2,
                         options={"poses": 15, "held_out": 10})
    table = sweep(study, workers=0)
    assert (table["status"] == "ok").all(), table["message"].tolist()
    # the residual of a least-squares fit is the noise, less the parameters' share of the equations
    assert np.all((table["rms_after"] / table["calibration.noise"] > 0.7)
                  & (table["rms_after"] / table["calibration.noise"] < 1.2))
    # the same machines drawn at both noise levels: the held-out error scales with the noise
    errors = table.pivot(index="draw", columns="calibration.noise", values="held_out_error_m")
    assert np.allclose(errors[1e-5] / errors[1e-6], 10.0, rtol=0.2)
    assert np.all(table["held_out_error_noise"] < 5) and np.all(table["fixed_parameters"] >= 1)


@pytest.mark.parametrize("data, message", [
    ({"study": {"job": "calibrate"}, "calibration": {"pose": 3}}, r"unknown key 'pose' in \[calibration\].*'poses'"),
    ({"study": {"job": "simulate"}, "calibration": {"poses": 3}}, r"\[calibration\] is the options of job = "
                                                                     r"\"calibrate\""),
    ({"study": {"job": "identify"}, "grid": {"identification.polyorder": [1.5]}}, r"must be a positive integer"),
    ({"study": {"job": "calibrate", "draws": 2}, "uncertainty": {"mass": 0.1}}, r"a calibration study draws"),
    ({"study": {"job": "fit"}}, r"\[study\].job must be one of simulate, identify, calibrate"),
    ({"study": {"job": "calibrate"}, "calibration": {"poses": 30, "candidates": 10}}, r"fewer than the 30 poses"),
])
def test_a_jobs_options_are_checked_by_name(data, message):
    with pytest.raises(pkmlab.PkmlabError, match=message):
        study_from_dict({"base": excitation_base(), **data})
