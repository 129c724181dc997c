"""Straight-line programs and the compiled path tracker (:mod:`pkmlab.numerics.straight_line`,
:mod:`pkmlab.numerics.tracker`), checked against independent evaluations and solvers: SymPy's own evaluation of
the expressions, NumPy's companion-matrix roots of a polynomial, and the closed-form intersections of two
circles."""

from __future__ import annotations

import numpy as np
import pytest
import sympy as sp

from pkmlab.numerics import homotopy
from pkmlab.numerics.straight_line import compile_program


def test_a_program_evaluates_its_expressions_as_sympy_does():
    x, y, p = sp.symbols("x y p")
    expressions = [
        3 * x**4 * y - sp.Rational(2, 7) * x * y**3 + p,
        (x - y) ** 3 / (1 + x**2) - sp.sqrt(2) * p * x,
        -x * y * p + 5,
        x**-2 + y,
        sp.Integer(0),
    ]
    program = compile_program(expressions, [x, y, p])
    rng = np.random.default_rng(3)
    points = rng.standard_normal((20, 3)) + 1j * rng.standard_normal((20, 3))
    expected = np.array([[complex(e.subs(dict(zip((x, y, p), row, strict=True)))) for e in expressions]
                         for row in points])
    np.testing.assert_allclose(program(points), expected, rtol=1e-13, atol=1e-13)


def test_a_program_shares_subexpressions():
    x, y = sp.symbols("x y")
    shared = (x + y) ** 8
    program = compile_program([shared + 1, shared * x, shared - y], [x, y])
    # (x + y)^8 by three squarings once, then one operation per output
    assert program.code.shape[0] <= 1 + 3 + 3 + 1


def test_a_program_refuses_what_is_no_rational_function():
    x = sp.Symbol("x")
    with pytest.raises(ValueError, match="not a rational function"):
        compile_program([sp.sin(x)], [x])


def _cubic_family():
    """``x³ + c₀ x² + c₁ x + c₂ = 0``, its three coefficients moving."""
    x, *c = sp.symbols("x c0 c1 c2")
    f = x**3 + c[0] * x**2 + c[1] * x + c[2]
    program = compile_program([f, sp.diff(f, x), *[sp.diff(f, ci) for ci in c]], [x, *c])
    return homotopy.Family(program, 1, 3)


def test_a_parameter_homotopy_finds_every_root_of_a_cubic():
    """From the roots of a generic complex cubic (NumPy's) to three real cubics."""
    family = _cubic_family()
    rng = np.random.default_rng(7)
    p0 = rng.standard_normal(3) + 1j * rng.standard_normal(3)
    generic = np.roots([1.0, *p0])[:, None]
    for target in ([-6.0, 11.0, -6.0], [0.0, -2.0, 1.0], [1.0, 1.0, 1.0]):  # roots 1, 2, 3; three real; one real
        ends = homotopy.parameter_homotopy(family, generic, p0, np.array(target, dtype=complex))
        assert ends.regular.all() and ends.reached.all()
        roots = np.roots([1.0, *target])
        found = np.sort_complex(ends.x[:, 0])
        np.testing.assert_allclose(found, np.sort_complex(roots), atol=1e-12)


def test_the_tracker_finds_both_intersections_of_two_circles():
    """Two circles of centres ``(0, 0)`` and ``(d, 0)`` and radii ``r₁``, ``r₂`` meet at
    ``x = (d² + r₁² − r₂²) / 2d``, ``y = ±√(r₁² − x²)``; from a generic complex instance solved by monodromy."""
    x, y, d, r1, r2 = sp.symbols("x y d r1 r2")
    F = sp.Matrix([x**2 + y**2 - r1**2, (x - d) ** 2 + y**2 - r2**2])
    params = [d, r1, r2]
    program = compile_program([*F, *F.jacobian([x, y]), *F.jacobian(params)], [x, y, *params])
    family = homotopy.Family(program, 2, 3)
    rng = np.random.default_rng(11)
    z0 = np.array([0.4 + 0.1j, -0.3 + 0.5j])
    dd = 1.1 + 0.3j
    p0 = np.array([dd, np.sqrt(z0 @ z0), np.sqrt((z0[0] - dd) ** 2 + z0[1] ** 2)])
    generic, _loops = homotopy.monodromy_solve(family, z0, p0, rng)
    assert len(generic) == 2
    target = np.array([1.0, 0.8, 0.6], dtype=complex)
    ends = homotopy.parameter_homotopy(family, generic, p0, target)
    xs = (1.0 + 0.8**2 - 0.6**2) / 2
    expected = sorted([(xs, np.sqrt(0.64 - xs**2)), (xs, -np.sqrt(0.64 - xs**2))], key=lambda v: v[1])
    found = sorted(ends.x.real.tolist(), key=lambda v: v[1])
    np.testing.assert_allclose(found, expected, atol=1e-12)
    assert np.abs(ends.x.imag).max() < 1e-12


def test_a_cached_program_is_derived_once_and_read_back_the_same(tmp_path, monkeypatch):
    from pkmlab import _compile_cache
    from pkmlab.numerics.straight_line import cached_program

    monkeypatch.setattr(_compile_cache, "CACHE_DIR", tmp_path)
    x, y = sp.symbols("x y")
    calls = []

    def build():
        calls.append(1)
        return compile_program([x**3 * y - sp.Rational(1, 3), x / (1 + y**2)], [x, y])

    first = cached_program("demo", build)
    second = cached_program("demo", build)
    assert len(calls) == 1 and (tmp_path / "programs" / "demo.npz").exists()
    points = np.array([[0.3 + 0.1j, -1.2 + 0.4j], [2.0, 0.5]])
    np.testing.assert_array_equal(second(points), first(points))
    np.testing.assert_array_equal(second.code, first.code)
