"""A machine's loop compiled ahead in a second process while its first run is prepared (pkmlab.simulation.ahead)."""

from __future__ import annotations

from pathlib import Path

import numpy as np
import pytest

import pkmlab
from pkmlab._files import read_toml
from pkmlab.description.files import load_mechanism
from pkmlab.simulation import ahead
from pkmlab.simulation.realism import Drives, Sensors

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
MECHANISMS = EXAMPLES / "mechanisms"


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


def _call_types(dispatcher, signature, callee) -> set:
    """The argument types of every call of ``callee`` in ``dispatcher``'s function typed for ``signature``, by a copy
    of it compiled here and not cached (a function loaded from the cache has no record of its calls' types)."""
    import numba
    from numba.core import ir, types

    options = {key: value for key, value in dispatcher.targetoptions.items() if key not in ("cache", "nopython")}
    copy = numba.njit(**options)(dispatcher.py_func)
    copy.compile(signature)
    fndesc = next(iter(copy.overloads.values())).fndesc
    return {call_type.args for expr, call_type in fndesc.calltypes.items()
            if isinstance(expr, ir.Expr) and expr.op == "call"
            and isinstance(fndesc.typemap[expr.func.name], types.Dispatcher)
            and fndesc.typemap[expr.func.name].dispatcher is callee}


@pytest.mark.parametrize("name", ["paper_drives_sensors", "4rrr"])
def test_the_plant_stage_compiled_meanwhile_is_the_one_the_loop_calls(name):
    """plant_stage_signature is the types of the loop's own call of the plant's stage (sampled_data_chunk's call of
    rk4_sample, and rk4_sample's of plant_stage, typed here), for the run's parameters and drives."""
    from pkmlab.simulation.run import prepare_run

    scenario = RUNS[name]()
    prep = prepare_run(scenario)
    pkmlab.simulate(scenario)  # (the loop compiled here or loaded: its signature)
    k = scenario.model.kernels
    (loop_signature,) = k.sampled_data_chunk.signatures
    (sample_call,) = _call_types(k.sampled_data_chunk, loop_signature, k.rk4_sample)
    stage_calls = _call_types(k.rk4_sample, sample_call, k.plant_stage)
    assert stage_calls == {ahead.plant_stage_signature(scenario.model, prep.P_plant, prep.realism.drive)}


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
    """compile_plant_stage_meanwhile compiles the plant's stage here only while a second process compiles this
    structure's loop and the stage is not in the cache: not without one, not after it ended, not for another
    structure's, not once it is saved."""
    scenario = pkmlab.paper_scenario("nominal")
    model = scenario.model
    stage = _Compiled()
    monkeypatch.setattr(model.kernels, "plant_stage", stage)
    drive = model.kernels.NO_DRIVES
    for started in ({}, {model.kernels.__name__: _Running(code=0)}, {"another structure": _Running()}):
        monkeypatch.setattr(ahead, "_STARTED", started)
        ahead.compile_plant_stage_meanwhile(model, model.P, drive)
    assert stage.signatures == []
    monkeypatch.setattr(ahead, "_STARTED", {model.kernels.__name__: _Running()})
    monkeypatch.setattr(ahead._compile_cache, "has_compiled", lambda _module, function="": function == "plant_stage")
    ahead.compile_plant_stage_meanwhile(model, model.P, drive)  # in the cache already
    assert stage.signatures == []
    monkeypatch.setattr(ahead._compile_cache, "has_compiled", lambda _module, function="": False)
    ahead.compile_plant_stage_meanwhile(model, model.P, drive)
    assert stage.signatures == [ahead.plant_stage_signature(model, model.P, drive)]


def test_a_second_process_compiles_the_loop_once_per_structure_unless_switched_off(monkeypatch):
    """The second process starts where the loop is not compiled, once per structure, compiles it (here: loads it
    from the cache the suite filled) and ends cleanly; none is started for a continuous-time run, where the loop is
    compiled already, with PKMLAB_COMPILE_AHEAD=0 (as the second process's own environment says), or on one core."""
    scenario = pkmlab.paper_scenario("fast")
    model = scenario.model
    pkmlab.simulate(scenario)  # the loop compiled here, and in the cache
    monkeypatch.setattr(ahead, "_STARTED", {})
    monkeypatch.delenv(ahead.SWITCH, raising=False)
    assert ahead.loop_is_compiled(model.kernels.__name__)
    assert ahead.compile_loop_ahead(scenario) is None  # compiled already
    monkeypatch.setattr(ahead, "loop_is_compiled", lambda _name: False)
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
    monkeypatch.setattr(ahead, "loop_is_compiled", lambda _name: False)
    monkeypatch.setattr(ahead, "available_cores", lambda: 2)
    process = ahead.compile_loop_ahead(scenario)
    assert process is not None
    process.stdin.close()
    assert process.wait(timeout=300) == 1


def test_a_scenario_file_starts_its_loop_compiling_before_its_machine_is_checked(monkeypatch):
    """load_scenario of a sampled-data run starts the second process for its machine's description before the
    model is bound (its assembly check compiles too); a continuous-time run starts none."""
    from pkmlab.formats import scenario as scenario_format

    calls = []
    monkeypatch.setattr(scenario_format, "compile_loop_ahead_of", lambda d: calls.append(("ahead", d.name)))
    bound = scenario_format.MechanismModel.from_description
    monkeypatch.setattr(scenario_format.MechanismModel, "from_description",
                        lambda d: calls.append(("checked", d.name)) or bound(d))
    data = read_toml(EXAMPLES / "delta_pick_and_place.toml")
    scenario_format.scenario_from_dict(data, compile_ahead=True)
    assert calls == [("ahead", "delta"), ("checked", "delta")]
    calls.clear()
    scenario_format.scenario_from_dict(data)  # a study's variant: its runs go to its workers
    assert calls == [("checked", "delta")]
    calls.clear()
    data["controller"]["sample_time"] = 0.0
    scenario_format.scenario_from_dict(data, compile_ahead=True)
    assert calls == [("checked", "delta")]


def test_a_machine_refused_by_its_check_ends_the_second_process_started_for_it(monkeypatch):
    """The second process is started before the machine's assembly check: a machine the check refuses ends it, and
    it is forgotten (the structure may be started again for a machine that assembles)."""
    import subprocess
    import sys

    from pkmlab.errors import InvalidParameterError
    from pkmlab.formats import scenario as scenario_format

    process = subprocess.Popen([sys.executable, "-c", "import time; time.sleep(60)"])
    monkeypatch.setattr(ahead, "_STARTED", {"a structure": process})
    monkeypatch.setattr(scenario_format, "compile_loop_ahead_of", lambda _d: process)

    def refused(_description):
        raise InvalidParameterError("delta: the platform can be assembled nowhere")

    monkeypatch.setattr(scenario_format.MechanismModel, "from_description", refused)
    with pytest.raises(InvalidParameterError, match="assembled nowhere"):
        scenario_format.scenario_from_dict(read_toml(EXAMPLES / "delta_pick_and_place.toml"), compile_ahead=True)
    assert process.poll() is not None and ahead._STARTED == {}


def test_a_structure_another_process_derives_is_waited_for_not_derived_again(monkeypatch, tmp_path):
    """A new structure's kernels, derived by another process (the second one, which derives while this one checks
    the machine): this one waits for that derivation's lock and imports its module, deriving nothing itself."""
    import subprocess
    import sys

    from pkmlab import _compile_cache
    from pkmlab.model import mechanism_model

    description = load_mechanism(MECHANISMS / "6rus.toml")
    name = mechanism_model.kernels_name(description)
    assert name.startswith("pkmlab_kernels_")
    loaded = sys.modules.pop(name, None)  # (imported by an earlier test of this process: put back below)
    monkeypatch.setattr(_compile_cache, "CACHE_DIR", tmp_path)
    monkeypatch.setattr(mechanism_model.derivation(description), "generate_source",
                        lambda _d: pytest.fail("derived a second time"))
    holder = subprocess.Popen(
        [sys.executable, "-c", f"""import sys, time
from pathlib import Path
from pkmlab import _compile_cache
_compile_cache.CACHE_DIR = Path(sys.argv[1])
with _compile_cache.cache_lock("{name}.py"):
    print("held", flush=True)
    time.sleep(0.5)
    (Path(sys.argv[1]) / "kernels").mkdir()
    (Path(sys.argv[1]) / "kernels" / "{name}.py").write_text("DERIVED_BY = 'the other process'\\n")
""", str(tmp_path)], stdout=subprocess.PIPE, text=True)
    try:
        assert holder.stdout.readline() == "held\n"
        module = mechanism_model._user_structure_kernels(description)
    finally:
        sys.modules.pop(name, None)
        if loaded is not None:
            sys.modules[name] = loaded
        holder.wait(timeout=60)
    assert module.DERIVED_BY == "the other process"
