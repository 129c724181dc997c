"""A kernel that a command may call once from Python runs interpreted until its compiled code is at hand
(``_compile_cache.InterpretedFirst``): the same numbers bit for bit, and no compile for a process's first call."""

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
        assert _leading_ratio(e, radii, vertices) < 1e-2  # the case three_circles re-parametrises
        (compiled, a1, q1), (by_python, a2, q2) = _both(e, radii, vertices)
        assert compiled == by_python and a1.tobytes() == a2.tobytes() and q1.tobytes() == q2.tobytes()
        found = [j for j in range(compiled[0]) if abs(math.remainder(a1[j] - alpha, 2 * math.pi)) < 1e-7]
        assert found and np.allclose(q1[found[0]], p1, atol=1e-7)


def _leading_ratio(e, radii, vertices) -> float:
    """|a_0| / max |a_k| of the sextic of the three circles, in its own frames (``three_circles``' first steps)."""
    from pkmlab.kernels import rrr3_sextic as sextic

    d2, d3 = e[1] - e[0], e[2] - e[0]
    beta, gamma = math.atan2(d2[1], d2[0]), math.atan2(vertices[1], vertices[0])
    n3 = [math.cos(beta) * d3[0] + math.sin(beta) * d3[1], -math.sin(beta) * d3[0] + math.cos(beta) * d3[1]]
    m3 = [math.cos(gamma) * vertices[2] + math.sin(gamma) * vertices[3],
          -math.sin(gamma) * vertices[2] + math.cos(gamma) * vertices[3]]
    k, coeffs = np.empty(7), np.empty(7)
    sextic.cubic_coefficients(np.hypot(*d2), *n3, *radii, np.hypot(*vertices[:2]), *m3, k)
    sextic.sextic_coefficients(k, coeffs)
    return abs(coeffs[0]) / np.max(np.abs(coeffs))


def test_the_vertex_from_two_legs_run_by_python_gives_its_compiled_numbers_bit_for_bit():
    """``circle_vertex1``, the vertex where Cramer's rule degenerates (a branch random placements hardly reach)."""
    from pkmlab.algorithms.three_circles import circle_vertex1

    rng = np.random.default_rng(5)
    for _ in range(300):
        e, radii, vertices = rng.uniform(-1, 1, (3, 2)), rng.uniform(0.2, 1.5, 3), rng.uniform(-0.5, 0.5, 4)
        alpha = rng.uniform(-math.pi, math.pi)
        args = (e, radii, vertices, math.cos(alpha), math.sin(alpha))
        compiled, by_python = circle_vertex1(*args), interpreted(circle_vertex1)(*args)
        assert np.array(compiled).tobytes() == np.array(by_python).tobytes()


@njit
def _twice(x):
    return 2.0 * x


@njit
def _twice_plus_one(x, out):
    out[0] = _twice(x) + 1.0


def test_a_kernel_runs_interpreted_for_its_first_calls_then_compiled():
    out = np.zeros(1)
    first = InterpretedFirst(_twice_plus_one, calls=60)
    first(3.0, out)
    assert out[0] == 7.0
    assert _twice_plus_one.signatures == [] and _twice.signatures == []  # nothing compiled, its callee neither
    once = InterpretedFirst(_twice_plus_one)  # one call interpreted (the default)
    once(4.0, out)
    assert out[0] == 9.0 and _twice_plus_one.signatures == [] and once.calls == 0
    once(5.0, out)  # compiled
    assert out[0] == 11.0 and len(_twice_plus_one.signatures) == 1
    assert first.compiled_at_hand(6.0, out)  # compiled in this process now: every caller takes the compiled code
    assert not first.compiled_at_hand(np.float32(6.0), out)  # but not for other argument types
    first(6.0, out)
    assert out[0] == 13.0 and len(_twice_plus_one.signatures) == 1


def test_a_kernel_saved_in_the_cache_is_found_there_for_its_argument_types_only():
    """What a new process's InterpretedFirst reads to take the compiled code at once: the kernel's entry in Numba's
    cache for the call's argument types, for this Numba and processor."""
    args = (np.zeros((3, 2)), np.ones(3), np.ones(4), np.empty(6), np.empty((6, 2)))
    three_circles(*args)  # compiled here, or loaded: saved in the cache either way
    signature = tuple(three_circles.typeof_pyval(a) for a in args)
    assert _compile_cache._in_cache(three_circles, signature)
    other = tuple(three_circles.typeof_pyval(a.astype(np.float32)) for a in args)
    assert not _compile_cache._in_cache(three_circles, other)
    assert not _compile_cache._in_cache(_twice, (three_circles.typeof_pyval(1.0),))  # a kernel not cached at all
