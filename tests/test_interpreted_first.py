"""A kernel called a few times from Python runs interpreted until its compiled code is at hand
(``_compile_cache.InterpretedFirst``): the same numbers bit for bit, and no compile until its budget is spent."""

from __future__ import annotations

import math

import numpy as np
import pytest

from pkmlab import _compile_cache
from pkmlab._compile_cache import InterpretedFirst, interpreted, njit
from pkmlab.algorithms.three_circles import three_circles

pytestmark = pytest.mark.skipif(_compile_cache.INTERPRETED, reason="interpreted: every kernel is a Python function")


def _both(e, radii, vertices):
    """``three_circles`` compiled and run by Python, each into arrays of NaN: ``((count, status), α, p1)`` twice."""
    runs = []
    for kernel in (three_circles, interpreted(three_circles)):
        alphas, p1 = np.full(6, np.nan), np.full((6, 2), np.nan)
        runs.append((kernel(e, radii, vertices, alphas, p1), alphas, p1))
    return runs


def test_three_circles_run_by_python_gives_its_compiled_numbers_bit_for_bit():
    rng = np.random.default_rng(7)
    roots = 0
    for _ in range(300):
        e, radii, vertices = rng.uniform(-1, 1, (3, 2)), rng.uniform(0.2, 1.5, 3), rng.uniform(-0.5, 0.5, 4)
        (compiled, a1, p1), (by_python, a2, p2) = _both(e, radii, vertices)
        assert compiled == by_python
        assert a1.tobytes() == a2.tobytes() and p1.tobytes() == p2.tobytes()
        roots += compiled[0]
    assert roots > 200  # most cases assemble


def test_a_placement_near_half_a_turn_is_found_alike_by_python_and_compiled():
    """A platform whose solution lies at ψ = π in the sextic's own frames, where its leading coefficient vanishes
    and ``three_circles`` re-parametrises it (``moebius_shift``): the placement built is found, bit for bit alike."""
    rng = np.random.default_rng(11)
    for _ in range(20):
        e, vertices = rng.uniform(-1, 1, (3, 2)), rng.uniform(-0.5, 0.5, 4)
        beta = math.atan2(e[1, 1] - e[0, 1], e[1, 0] - e[0, 0])
        gamma = math.atan2(vertices[1], vertices[0])
        alpha = math.pi - gamma + beta + rng.uniform(-1e-4, 1e-4)  # ψ = α + γ - β near π
        c, s = math.cos(alpha), math.sin(alpha)
        p1 = rng.uniform(-0.3, 0.3, 2)
        points = [p1, p1 + [c * vertices[0] - s * vertices[1], s * vertices[0] + c * vertices[1]],
                  p1 + [c * vertices[2] - s * vertices[3], s * vertices[2] + c * vertices[3]]]
        radii = np.array([np.linalg.norm(points[i] - e[i]) for i in range(3)])
        (compiled, a1, q1), (by_python, a2, q2) = _both(e, radii, vertices)
        assert compiled == by_python and a1.tobytes() == a2.tobytes() and q1.tobytes() == q2.tobytes()
        found = [j for j in range(compiled[0]) if abs(math.remainder(a1[j] - alpha, 2 * math.pi)) < 1e-7]
        assert found and np.allclose(q1[found[0]], p1, atol=1e-7)


@njit
def _twice(x):
    return 2.0 * x


@njit
def _twice_plus_one(x, out):
    out[0] = _twice(x) + 1.0


def test_a_kernel_runs_interpreted_until_its_budget_is_spent_then_compiled():
    out = np.zeros(1)
    first = InterpretedFirst(_twice_plus_one, budget=60.0)
    first(3.0, out)
    assert out[0] == 7.0
    assert _twice_plus_one.signatures == [] and _twice.signatures == []  # nothing compiled, its callee neither
    spent = InterpretedFirst(_twice_plus_one, budget=0.0)
    spent(4.0, out)
    assert out[0] == 9.0 and len(_twice_plus_one.signatures) == 1
    assert first.compiled_at_hand()  # compiled in this process now: every caller takes the compiled code
    first(5.0, out)
    assert out[0] == 11.0 and len(_twice_plus_one.signatures) == 1
