"""A machine's loop compiled ahead in a second process while its first run is prepared (pkmlab.simulation.ahead)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import pkmlab
from pkmlab.simulation import ahead
from pkmlab.simulation.realism import Drives, Sensors

MECHANISMS = Path(__file__).resolve().parents[1] / "examples" / "mechanisms"


def _paper_with_drives_and_sensors():
    drives = Drives(armature=1e-4, viscous=1e-3, coulomb=1e-3, coulomb_rate=0.05, effort_noise=1e-4)
    return pkmlab.paper_scenario("nominal").replace(drives=drives, controller_drives=drives,
                                                    sensors=Sensors(resolution=2 * np.pi / 2**14, delay=1, noise=1e-5))


#: Runs whose loop arguments differ in kind: the paper's ideal machine; with drives (the controller compensating
#: them), effort noise and delayed noisy sensors (rows in every array of the loop's realism); a redundantly actuated
#: machine (the desired motion its pose, fewer columns than its actuators).
RUNS = {"paper": lambda: pkmlab.paper_scenario("nominal"),
        "paper_drives_sensors": _paper_with_drives_and_sensors,
        "4rrr": lambda: pkmlab.load_scenario(MECHANISMS / "4rrr_motion.toml")}


@pytest.mark.parametrize("name", sorted(RUNS))
def test_the_loop_compiled_ahead_is_the_one_the_run_calls(name):
    """compile_loop compiles the loop for the argument types simulate passes it: after both, the loop has one
    compiled signature (a second one would be a compile of its own for the run, in whichever order they came)."""
    scenario = RUNS[name]()
    ahead.compile_loop(scenario.model)
    result = pkmlab.simulate(scenario)
    assert len(scenario.model.kernels.sampled_data_chunk.signatures) == 1
    assert np.all(np.isfinite(result.tau))


@pytest.mark.parametrize("name", sorted(RUNS))
def test_the_plant_stage_compiled_meanwhile_is_the_one_the_loop_calls(name):
    """compile_plant_stage compiles the plant's stage for the types the loop passes it: after it and the run, the
    stage has one compiled signature, and so has the loop."""
    from pkmlab.simulation.run import prepare_run

    scenario = RUNS[name]()
    prep = prepare_run(scenario)
    ahead.compile_plant_stage(scenario.model, prep.P_plant, prep.realism.drive)
    result = pkmlab.simulate(scenario)
    kernels = scenario.model.kernels
    assert len(kernels.plant_stage.signatures) == 1 and len(kernels.sampled_data_chunk.signatures) == 1
    assert np.all(np.isfinite(result.tau))


class _Compiled:
    """A stand-in for a compiled entry point that records the signatures it is asked to compile."""

    def __init__(self):
        self.signatures = []

    def compile(self, signature):
        self.signatures.append(signature)


class _Running:
    """A stand-in for a second process: running while ``code`` is None."""

    def __init__(self, code=None):
        self.code = code

    def poll(self):
        return self.code


def test_the_plant_stage_is_compiled_meanwhile_only_while_a_second_process_compiles_the_loop(monkeypatch):
    """compile_meanwhile compiles the plant's stage here only while a second process compiles this structure's loop:
    not without one, not after it ended, not for another structure's."""
    scenario = pkmlab.paper_scenario("nominal")
    model = scenario.model
    stage = _Compiled()
    monkeypatch.setattr(model.kernels, "plant_stage", stage)
    drive = model.kernels.NO_DRIVES
    for started in ({}, {model.kernels.__name__: _Running(code=0)}, {"another structure": _Running()}):
        monkeypatch.setattr(ahead, "_STARTED", started)
        ahead.compile_meanwhile(model, model.P, drive)
    assert stage.signatures == []
    monkeypatch.setattr(ahead, "_STARTED", {model.kernels.__name__: _Running()})
    ahead.compile_meanwhile(model, model.P, drive)
    assert len(stage.signatures) == 1 and len(stage.signatures[0]) == 9


def test_a_second_process_compiles_the_loop_once_per_structure_unless_switched_off(monkeypatch):
    """The second process starts where the loop is not compiled, once per structure, compiles it (here: loads it
    from the cache the suite filled) and ends cleanly; none is started for a continuous-time run, where the loop is
    compiled already, with PKMLAB_COMPILE_AHEAD=0 (as the second process's own environment says), or on one core."""
    scenario = pkmlab.paper_scenario("fast")
    model = scenario.model
    pkmlab.simulate(scenario)  # the loop compiled here, and in the cache
    monkeypatch.setattr(ahead, "_STARTED", {})
    monkeypatch.delenv(ahead.SWITCH, raising=False)
    assert ahead.loop_is_compiled(model)
    assert ahead.compile_loop_ahead(scenario) is None  # compiled already
    monkeypatch.setattr(ahead, "loop_is_compiled", lambda _model: False)
    assert ahead.compile_loop_ahead(scenario.replace(sample_time=0.0)) is None  # no loop to compile
    monkeypatch.setenv(ahead.SWITCH, "0")
    assert ahead.compile_loop_ahead(scenario) is None  # switched off
    monkeypatch.delenv(ahead.SWITCH)
    monkeypatch.setattr(ahead, "available_cores", lambda: 1)
    assert ahead.compile_loop_ahead(scenario) is None  # one core: the two would take turns on it
    monkeypatch.setattr(ahead, "available_cores", lambda: 2)
    process = ahead.compile_loop_ahead(scenario)
    assert process is not None and process.wait(timeout=300) == 0
    assert ahead.compile_loop_ahead(scenario) is None  # started once for the structure
    assert list(ahead._STARTED) == [model.kernels.__name__]
    process.stdin.close()


def test_the_second_process_ends_itself_when_the_first_has_ended(monkeypatch):
    """The first process killed (its end of the pipe closed, as the system closes it): the second ends at once,
    without finishing its compile (exit 1), rather than compiling on for nobody."""
    scenario = pkmlab.paper_scenario("fast")
    monkeypatch.setattr(ahead, "_STARTED", {})
    monkeypatch.delenv(ahead.SWITCH, raising=False)
    monkeypatch.setattr(ahead, "loop_is_compiled", lambda _model: False)
    monkeypatch.setattr(ahead, "available_cores", lambda: 2)
    process = ahead.compile_loop_ahead(scenario)
    assert process is not None
    process.stdin.close()
    assert process.wait(timeout=300) == 1
