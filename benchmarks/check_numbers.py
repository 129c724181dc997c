"""Every number a change to the compiled core could move, saved or compared .

A performance change must not change results beyond round-off. This script runs the runs whose
numbers users see — the paper's cases, every preset's default run (the example scenario files), a
PD run, a continuous-time run, a batch of disturbed runs, one evaluation of the dynamics per preset —
and either saves every array to an ``.npz`` file or compares them with one saved before::

    .venv/bin/python benchmarks/check_numbers.py --save /tmp/before.npz     # on the code before the change
    .venv/bin/python benchmarks/check_numbers.py --compare /tmp/before.npz  # after it: exits 1 above --rtol

The difference of an array is normwise, ``max |new - old| / max |old|`` (so a component that passes
through zero is not blown up), and every array must agree to ``--rtol`` (default 1e-12).
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import numpy as np
from operation_count import DEFAULT_RUNS

from pkmlab.control.controller import ControllerSpec
from pkmlab.formats.scenario import load_scenario, paper_scenario
from pkmlab.model import mechanism_model as mm
from pkmlab.paper.kinematics import coordinates_to_3rrr
from pkmlab.simulation.run import simulate, simulate_batch
from pkmlab.simulation.scenario import perturbed_model

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
#: every preset's default run (operation_count.DEFAULT_RUNS), and the paper's other two cases
SCENARIO_FILES = ("nominal", "fast", "disturbed", *(f for f in DEFAULT_RUNS.values() if f != "nominal"))


def _runs() -> dict[str, object]:
    runs = {f"paper_{name}": paper_scenario(name) for name in ("nominal", "disturbed", "fast", "disturbed_dynamics")}
    runs.update({f"file_{name}": load_scenario(EXAMPLES / f"{name}.toml") for name in SCENARIO_FILES})
    nominal = runs["paper_nominal"]
    runs["paper_pd"] = nominal.replace(controller=ControllerSpec(kind="pd", kp=400.0, kv=40.0))
    runs["paper_continuous"] = nominal.replace(sample_time=0.0)
    runs["paper_substeps_4"] = runs["paper_fast"].replace(substeps=4)
    return runs


def collect() -> dict[str, np.ndarray]:
    """Every array of the runs above, by name."""
    out: dict[str, np.ndarray] = {}
    results = {}
    for name, scenario in _runs().items():
        result = results[name] = simulate(scenario)
        for field in ("q", "theta_dot", "tau", "pose", "S"):
            out[f"{name}.{field}"] = np.asarray(getattr(result, field), float)
    batch = simulate_batch(_disturbed_batch(), on_error="none")  # a drawn plant may not assemble: None
    for k, result in enumerate(batch):
        if result is None:
            continue
        for field in ("q", "tau"):
            out[f"batch{k}.{field}"] = np.asarray(getattr(result, field), float)
    rng = np.random.default_rng(3)
    for name, file in DEFAULT_RUNS.items():
        model = mm.MechanismModel.from_preset(name)
        q = _middle_configuration(results[f"file_{file}"])
        theta_dot = rng.normal(0.0, 0.5, model.n_actuators)
        m_theta, c_theta, g_theta = mm.actuator_space_model(model, q, theta_dot)
        out[f"dyn_{name}.M"], out[f"dyn_{name}.c"], out[f"dyn_{name}.g"] = m_theta, c_theta, g_theta
    return out


def _disturbed_batch() -> list:
    base = paper_scenario("nominal")
    rng = np.random.default_rng(11)
    return [base.replace(plant=perturbed_model(base.model, rng, 0.15)) for _ in range(12)]


def _middle_configuration(result) -> np.ndarray:
    """The configuration in the middle of a run."""
    return np.asarray(result.q[len(result.q) // 2], float)


def _comparable(key: str, old: np.ndarray, new: np.ndarray) -> np.ndarray:
    """``new`` as ``old`` holds it: numbers saved before pkmlab 0.3.0 hold the paper's machine's configurations in
    its own 7 coordinates ``(θ, φ, α)``, where they are now the description's 9 ``(θ, φ, x, y, α)`` (``x, y`` are
    compared as the pose)."""
    if key.endswith(".q") and old.ndim == 2 and old.shape[1] == 7 and new.shape == (old.shape[0], 9):
        return coordinates_to_3rrr(new)
    return new


def compare(old: dict[str, np.ndarray], new: dict[str, np.ndarray], rtol: float) -> int:
    worst, bad, diffs = 0.0, [f"{key}: new (not in the saved numbers)" for key in sorted(set(new) - set(old))], []
    for key in sorted(old):
        if key in new:
            new[key] = _comparable(key, old[key], new[key])
        if key not in new or old[key].shape != new[key].shape:
            bad.append(f"{key}: missing or reshaped")
            continue
        scale = np.max(np.abs(old[key])) if old[key].size else 0.0
        diff = np.max(np.abs(new[key] - old[key])) if old[key].size else 0.0
        rel = diff / scale if scale > 0 else diff
        worst = max(worst, rel)
        diffs.append((rel, key))
        if not rel <= rtol:
            bad.append(f"{key}: {rel:.2e}")
    print(f"{len(old)} arrays compared; largest normwise relative difference {worst:.2e} (limit {rtol:g})")
    print("  largest:", ", ".join(f"{key} {rel:.1e}" for rel, key in sorted(diffs, reverse=True)[:5]))
    for line in bad:
        print("  differs:", line)
    return 1 if bad else 0


def main(argv=None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    group = parser.add_mutually_exclusive_group(required=True)
    group.add_argument("--save", type=Path)
    group.add_argument("--compare", type=Path)
    parser.add_argument("--rtol", type=float, default=1e-12)
    args = parser.parse_args(argv)
    new = collect()
    if args.save:
        np.savez_compressed(args.save, **new)
        print(f"{len(new)} arrays saved to {args.save}")
        return 0
    with np.load(args.compare) as data:
        old = {key: data[key] for key in data.files}
    return compare(old, new, args.rtol)


if __name__ == "__main__":
    sys.exit(main())
