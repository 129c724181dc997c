"""The committed forward-kinematics polynomial matches a fresh symbolic derivation."""

from fractions import Fraction

import numpy as np
import sympy as sp

from pkmlab.codegen import rrr3_sextic
from pkmlab.kernels import rrr3_sextic as generated


def test_generated_file_is_current(monkeypatch):
    derived = rrr3_sextic.derive()
    # one derivation for both checks: generate_source's own call of derive() returns it (SymPy, about a second)
    monkeypatch.setattr(rrr3_sextic, "derive", lambda: derived)
    fresh = rrr3_sextic.generate_source()
    committed = rrr3_sextic.GENERATED_PATH.read_text()
    if f"Derived with SymPy {sp.__version__}." in committed:
        # same SymPy: the text must be identical (python -m pkmlab.codegen.rrr3_sextic)
        assert committed == fresh, "run `make derive` to regenerate src/pkmlab/kernels/rrr3_sextic.py"
    # any SymPy: the committed code evaluates, in exact rational arithmetic, to the fresh expressions
    numerators, cubic, sextic, symbols = derived
    rng = np.random.default_rng(7)
    for _ in range(3):
        values = [Fraction(int(v), 97) for v in rng.integers(-60, 60, len(rrr3_sextic.INPUT_NAMES))]
        subs = dict(zip(symbols, [sp.Rational(v.numerator, v.denominator) for v in values], strict=False))
        k = [Fraction(0)] * 7
        generated.cubic_coefficients.py_func(*values, k)
        for got, monom in zip(k, rrr3_sextic.MONOMIALS, strict=True):
            assert sp.Rational(got.numerator, got.denominator) == cubic[monom].subs(subs)
        a = [Fraction(0)] * 7
        generated.sextic_coefficients.py_func(k, a)
        k_subs = {sp.Symbol(f"k{i}{j}", real=True): sp.Rational(v.numerator, v.denominator)
                  for (i, j), v in zip(rrr3_sextic.MONOMIALS, k, strict=True)}
        for got, expr in zip(a, sextic, strict=True):
            assert sp.Rational(got.numerator, got.denominator) == expr.subs(k_subs)
        c, s = Fraction(3, 5), Fraction(4, 5)
        num = [Fraction(0)] * 3
        generated.vertex1_numerators.py_func(*values, c, s, num)
        cs = {symbols[-2]: sp.Rational(3, 5), symbols[-1]: sp.Rational(4, 5)}
        for got, name in zip(num, ("nx", "ny", "dd"), strict=True):
            assert sp.Rational(got.numerator, got.denominator) == numerators[name].subs({**subs, **cs})


def test_sextic_vanishes_at_the_orientation_of_an_assembled_configuration():
    """Independent of the derivation's algebra: plug a known solution into the polynomial."""
    rng = np.random.default_rng(3)
    for _ in range(20):
        # a random assembled configuration in the normalised frames of the derivation
        r = rng.uniform(0.1, 0.3, 3)
        p2x, p3 = rng.uniform(0.05, 0.2), rng.uniform(-0.2, 0.2, 2)
        psi, p1 = rng.uniform(-3, 3), rng.uniform(-0.2, 0.2, 2)
        c, s = np.cos(psi), np.sin(psi)
        verts = [p1, p1 + p2x * np.array([c, s]), p1 + np.array([c * p3[0] - s * p3[1], s * p3[0] + c * p3[1]])]
        phis = rng.uniform(-3, 3, 3)
        elbows = [v - ri * np.array([np.cos(f), np.sin(f)]) for v, ri, f in zip(verts, r, phis, strict=True)]
        # normalise: elbow 1 at the origin, elbow 2 on the x axis
        beta = np.arctan2(*(elbows[1] - elbows[0])[::-1])
        rot = np.array([[np.cos(beta), np.sin(beta)], [-np.sin(beta), np.cos(beta)]])
        d2 = rot @ (elbows[1] - elbows[0])
        d3 = rot @ (elbows[2] - elbows[0])
        k, a = np.empty(7), np.empty(7)
        generated.cubic_coefficients.py_func(d2[0], d3[0], d3[1], *r, p2x, *p3, k)
        generated.sextic_coefficients.py_func(k, a)
        t = np.tan((psi - beta) / 2)
        value = np.polyval(a, t)
        scale = np.polyval(np.abs(a), abs(t))
        assert abs(value) < 1e-10 * scale


def test_the_jacobians_differentiated_by_symengine_are_sympys_own_expressions():
    """codegen.planar.jacobian differentiates with SymEngine and converts back: entry for entry the expressions of
    SymPy's Matrix.jacobian (so the generated kernels are as SymPy would write them), on a Delta leg's loop-closure
    rows and their bias, and on its forearm's velocity rows."""
    import pkmlab
    from pkmlab.codegen import planar, spatial

    leg = next(iter(spatial.derive(pkmlab.load("delta").description)["legs"].values()))
    q, q_dot = leg["q"], leg["q_dot"]
    rows = sp.Matrix(leg["eta"])
    jac, bias = planar.jacobian_and_bias(list(rows), q, q_dot)
    assert jac == rows.jacobian(q)
    assert bias == (rows.jacobian(q) * sp.Matrix(q_dot)).jacobian(q) * sp.Matrix(q_dot)
    velocity = sp.Matrix([e for _position, v, w in leg["bodies"] for e in [*v, *w]])
    assert planar.jacobian(list(velocity), q_dot) == velocity.jacobian(q_dot)
    assert planar.jacobian(list(velocity), q) == velocity.jacobian(q)
