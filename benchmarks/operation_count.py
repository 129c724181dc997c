"""Floating-point operations and memory traffic of one sample of the simulation loop, counted for each
preset from the code that runs (the arithmetic limit of ``make bench``).

The count has two parts, neither estimated by hand:

* **per call**, from the source text of every function the loop calls — the generated kernels of the
  machine's structure (straight-line code from the SymPy derivation) and the compiled core appended to
  them: each ``+ - * /`` (and ``+=``...) on values is one operation, ``x**k`` is ``k - 1``; index
  arithmetic (inside subscripts and ``range``), comparisons and copies are not counted; ``sqrt`` is
  counted as an operation, ``sin``/``cos``/``atan2``... apart (a libm call costs far more). Loops over the
  structure's sizes (``range(N_ACTUATORS)``, a constant tuple of legs) are unrolled with their true trip
  counts, branches on the structure's constants (``if DIM == 3``) resolved, a branch on the run's values
  counted as its costlier side; constant expressions are folded, as the compiler folds them; a
  floating-point ``%`` is a libm call. A data-dependent loop (the chord iterations) counts its own
  operations once per call (about ten per pass: under 1 % of a sample) — its passes are the calls of
  the kernels inside it;
* **calls per sample**, counted over the whole of the preset's default run with the kernels
  interpreted (``PKMLAB_INTERPRETED=1``: the same source, run by Python) and every function wrapped by a
  counter: the chord iterations, Newton fall-backs and the controller's reuse of the plant's model are
  what the run really does.

Memory: the loop's working set (two workspaces, the parameters) stays in the first-level cache; what
streams per sample is the desired motion read and the record written (bytes reported).

Run as a script in a process of its own (the kernels must be interpreted; a whole Stewart–Gough run
takes about two minutes)::

    PKMLAB_INTERPRETED=1 .venv/bin/python benchmarks/operation_count.py [--json] [PRESET ...]
"""

from __future__ import annotations

import ast
import inspect
import json
import math
import os
import sys
import textwrap
from collections import Counter
from pathlib import Path
from types import SimpleNamespace

EXAMPLES = Path(__file__).resolve().parents[1] / "examples"
DEFAULT_RUNS = {"paper": "nominal", "five_bar": "five_bar_circle", "3rpr": "3rpr_circle", "3prr": "3prr_circle",
                "delta": "delta_pick_and_place", "stewart": "stewart_motion"}
#: calls whose cost is a libm call, counted apart from the arithmetic
TRANSCENDENTAL = {"sin", "cos", "atan2", "acos", "asin", "atan", "exp", "log", "hypot"}
#: calls counted as one arithmetic operation
ARITHMETIC_CALLS = {"sqrt", "abs", "max", "min"}


class _Counter(ast.NodeVisitor):
    """Operations of one function's own code (callees excluded), loops over constant ranges unrolled."""

    def __init__(self, constants: dict):
        self.constants = constants
        self.env: dict[str, object] = {}
        self.flops = 0
        self.transcendental = 0

    def _value(self, node):
        try:
            return eval(compile(ast.Expression(node), "<count>", "eval"), {"__builtins__": {}},
                        {**self.constants, **self.env})
        except Exception:  # data-dependent: not known before the run
            return None

    def _branch(self, statements) -> tuple[int, int, dict]:
        """Operations of ``statements`` in a copy of this counter, and the names they bind."""
        branch = _Counter(self.constants)
        branch.env = dict(self.env)
        for statement in statements:
            branch.visit(statement)
        return branch.flops, branch.transcendental, branch.env

    def visit_Assign(self, node):  # a local name for a size (n = N_ACTUATORS) or a structure constant
        value = self._value(node.value)
        targets = node.targets[0].elts if isinstance(node.targets[0], ast.Tuple) else [node.targets[0]]
        names = [t.id for t in targets if isinstance(t, ast.Name)]
        for name in names:  # a name bound again (to a value of the run) is no longer a constant
            self.env.pop(name, None)
        if isinstance(value, int) and len(targets) == 1 and names:
            self.env[names[0]] = value
        elif isinstance(value, tuple) and len(value) == len(targets) and all(isinstance(v, int) for v in value):
            self.env.update({t.id: v for t, v in zip(targets, value, strict=True) if isinstance(t, ast.Name)})
        self.visit(node.value)

    def visit_Subscript(self, node):  # the index is address arithmetic; only the subscripted value is visited
        self.visit(node.value)

    def visit_BinOp(self, node):
        if self._value(node) is not None:  # constants only: folded by the compiler
            return
        if isinstance(node.op, ast.Pow):
            exponent = self._value(node.right)
            self.flops += int(exponent) - 1 if isinstance(exponent, int | float) and exponent >= 1 else 1
        elif isinstance(node.op, ast.Add | ast.Sub | ast.Mult | ast.Div):
            self.flops += 1
        elif isinstance(node.op, ast.Mod):  # a floating-point remainder: a libm call (fmod)
            self.transcendental += 1
        self.generic_visit(node)

    def visit_AugAssign(self, node):
        if isinstance(node.op, ast.Add | ast.Sub | ast.Mult | ast.Div):
            self.flops += 1
        if isinstance(node.target, ast.Name):
            self.env.pop(node.target.id, None)
        self.visit(node.value)

    def visit_Compare(self, node):  # comparisons are not counted, nor their operands (mostly index arithmetic)
        pass

    def visit_Call(self, node):
        name = node.func.attr if isinstance(node.func, ast.Attribute) else getattr(node.func, "id", "")
        if name in TRANSCENDENTAL:
            self.transcendental += 1
        elif name in ARITHMETIC_CALLS:
            self.flops += 1
        if name == "range":
            return
        for arg in node.args:
            self.visit(arg)

    def _choose(self, test, body, orelse):
        """A branch: the one taken when its test is a constant, else the costlier (an upper bound), after which
        the names either binds are no longer constants."""
        value = self._value(test)
        if value is not None:
            for statement in (body if value else orelse):
                self.visit(statement)
            return
        counts = [self._branch(body), self._branch(orelse)]
        flops, transcendental, _env = max(counts, key=lambda c: (c[0], c[1]))
        self.flops += flops
        self.transcendental += transcendental
        for _f, _t, env in counts:
            for name, value_ in env.items():
                if self.env.get(name) is not value_:
                    self.env.pop(name, None)

    def visit_If(self, node):
        self._choose(node.test, node.body, node.orelse)

    def visit_IfExp(self, node):
        self._choose(node.test, [ast.Expr(node.body)], [ast.Expr(node.orelse)])

    def visit_For(self, node):
        bounds = None
        if isinstance(node.iter, ast.Call) and getattr(node.iter.func, "id", "") in ("range", "prange"):
            values = [self._value(a) for a in node.iter.args]
            if all(isinstance(v, int) for v in values) and isinstance(node.target, ast.Name):
                bounds = range(*values)
            if any(isinstance(a, ast.Name) and a.id.startswith("MAX_") for a in node.iter.args):
                bounds = None  # an iteration limit, not a size: one pass per call (its passes are counted calls)
        elif isinstance(node.target, ast.Name):  # over a constant tuple (a generated kernel's legs of one type)
            values = self._value(node.iter)
            if isinstance(values, tuple) and all(isinstance(v, int) for v in values):
                bounds = values
        if bounds is None:  # data-dependent: one pass (names it binds are not constants after it)
            flops, transcendental, env = self._branch(node.body)
            self.flops += flops
            self.transcendental += transcendental
            for name in env:
                if name not in self.env or self.env[name] is not env[name]:
                    self.env.pop(name, None)
            return
        for value in bounds:
            self.env[node.target.id] = value
            for statement in node.body:
                self.visit(statement)
        self.env.pop(node.target.id, None)


def own_operations(function, constants: dict, sizes: dict | None = None, loop_body: bool = False) -> tuple[int, int]:
    """``(arithmetic operations, libm calls)`` of one call of ``function``'s own code, its integer arguments
    and the shapes of its array arguments ``sizes`` (a dense kernel's ``m``) known; ``loop_body``: of one
    pass of its first loop only (the simulation loop's per-sample work)."""
    tree = ast.parse(textwrap.dedent(inspect.getsource(function)))
    counter = _Counter(constants)
    for name, value in (sizes or {}).items():  # an array argument is known by its shape only
        counter.env[name] = value if isinstance(value, int) else SimpleNamespace(shape=value[1],
                                                                                size=math.prod(value[1]))
    statements = tree.body[0].body
    if loop_body:
        statements = next(s for s in statements if isinstance(s, ast.For)).body
    for statement in statements:
        counter.visit(statement)
    return counter.flops, counter.transcendental


def _wrap(module, names, calls: Counter):
    """Every function ``names`` of ``module`` counted per call, by its name and integer arguments."""
    originals = {}
    for name in names:
        function = getattr(module, name)
        parameters = list(inspect.signature(function).parameters)

        def counted(*args, _f=function, _name=name, _parameters=parameters, **kwargs):
            sizes = tuple((p, a if isinstance(a, int) else ("shape", a.shape)) for p, a in
                          zip(_parameters, args, strict=False)
                          if isinstance(a, int) and not isinstance(a, bool) or hasattr(a, "shape"))
            calls[(_name, sizes)] += 1
            return _f(*args, **kwargs)

        originals[name] = function
        setattr(module, name, counted)
    return originals


def count_preset(name: str, samples: int | None = None) -> dict:
    """Operations per sample of ``name``'s default run: the average over its samples after the first (which
    sets the loop up), or over the first ``samples`` of them."""
    import numpy as np

    from pkmlab.formats.scenario import load_scenario
    from pkmlab.numerics import closed_chain
    from pkmlab.simulation.run import loop_motion, prepare_run

    scenario = load_scenario(EXAMPLES / f"{DEFAULT_RUNS[name]}.toml")
    prep = prepare_run(scenario)
    ctrl, plant = scenario.model, scenario.plant_model
    kernels = ctrl.kernels
    functions = {k: v for k, v in vars(kernels).items()
                 if inspect.isfunction(v) and v.__module__ in (kernels.__name__, closed_chain.__name__)}
    constants = {k: v for k, v in vars(kernels).items() if k.isupper() and isinstance(v, int | float | tuple)}
    constants.update({"np": np, "math": math})
    skip = {"make_workspaces", "sampled_data_loop", "sampled_data_batch", "reduced_column"}  # the last: an index
    names = [k for k in functions if k not in skip and not k.startswith("_")]
    q_plant0, q_ctrl0 = prep.q_plant0, prep.q_ctrl0
    desired = loop_motion(ctrl, prep.desired)  # the actuators' motion, or a redundantly actuated machine's poses
    n, n_x, n_q = ctrl.n_actuators, kernels.N_INDEPENDENT, kernels.N_COORDINATES

    def run(count):
        calls = Counter()
        originals = _wrap(kernels, names, calls)
        try:
            outs = (np.zeros((count, n_q)), np.zeros((count, n_x)), np.zeros((count, n)), np.zeros(count))
            status, _k = kernels.sampled_data_loop(scenario.sample_time, scenario.substeps,
                                                   *(series[:count] for series in desired), q_plant0, q_ctrl0,
                                                   plant.P, ctrl.P, prep.kind, prep.kp, prep.kv, prep.distribution,
                                                   prep.singularity_guard, *prep.realism, *outs, np.zeros((0, n)))
        finally:
            for key, function in originals.items():
                setattr(kernels, key, function)
        assert status == kernels.OK
        return calls

    # the samples after the first: the difference of two runs, one of the first two samples only
    total = desired[0].shape[0] if samples is None else min(samples + 2, desired[0].shape[0])
    few, many = run(2), run(total)
    per_sample = {k: (many[k] - few[k]) / (total - 2) for k in many if many[k] != few[k]}
    loop_own = own_operations(kernels.sampled_data_chunk, constants, loop_body=True)
    flops, libm, rows = 0.0, 0.0, []
    for (key, sizes), calls in sorted(per_sample.items()):
        f, t = own_operations(functions[key], constants, dict(sizes))
        flops += calls * f
        libm += calls * t
        rows.append({"function": key + "".join(f", {p}={v}" for p, v in sizes if isinstance(v, int)),
                     "calls_per_sample": calls,
                     "operations_per_call": f, "libm_per_call": t})
    flops += loop_own[0]
    libm += loop_own[1]
    streamed = 8 * (3 * n_x + n_q + n_x + n + 1)  # θd, θ̇d, θ̈d read; q, θ̇, τ, S written
    # two workspaces, both machines' parameters, the state x, the RK4 stages and the effort
    working_set = 2 * kernels.WORKSPACE.itemsize + 8 * (2 * ctrl.P.size + 2 * n_x + 5 * 2 * n_x + n)
    return {"preset": name, "operations_per_sample": flops, "libm_calls_per_sample": libm,
            "bytes_streamed_per_sample": streamed, "working_set_bytes": working_set, "functions": rows}


def counts_in_subprocess() -> dict[str, dict]:
    """:func:`count_preset` of every preset, each in a process of its own with the kernels interpreted (as many
    at once as there are cores; a whole run interpreted takes from seconds to a minute or two)."""
    import subprocess
    from concurrent.futures import ThreadPoolExecutor

    env = {**os.environ, "PKMLAB_INTERPRETED": "1"}

    def one(name):
        out = subprocess.run([sys.executable, __file__, "--json", name], env=env, check=True, capture_output=True,
                             text=True)
        return json.loads(out.stdout)[0]

    with ThreadPoolExecutor(max_workers=os.cpu_count() or 1) as pool:
        return {r["preset"]: r for r in pool.map(one, DEFAULT_RUNS)}


def limit_per_sample(count: dict, speed: dict) -> float:
    """The arithmetic limit of one sample (s): its operations at the measured independent multiply-add rate,
    plus its libm calls at their measured cost."""
    return (count["operations_per_sample"] / (speed["independent_gflops"] * 1e9)
            + count["libm_calls_per_sample"] * speed["ns_per_sin_or_cos"] * 1e-9)


def main(argv=None) -> int:
    """``operation_count.py [--json] [PRESET ...]``: every preset by default."""
    argv = list(argv or [])
    if os.environ.get("PKMLAB_INTERPRETED") != "1":
        print("run with PKMLAB_INTERPRETED=1 (the kernels must be interpreted to count their calls)", file=sys.stderr)
        return 2
    names = [a for a in argv if not a.startswith("--")] or list(DEFAULT_RUNS)
    results = [count_preset(name) for name in names]
    if "--json" in argv:
        print(json.dumps(results))
        return 0
    for r in results:
        print(f"{r['preset']:>9}: {r['operations_per_sample']:8.0f} operations + {r['libm_calls_per_sample']:5.1f} "
              f"libm calls per sample; {r['bytes_streamed_per_sample']} bytes streamed, working set "
              f"{r['working_set_bytes']} bytes")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
