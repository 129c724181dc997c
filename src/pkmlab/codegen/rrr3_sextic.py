"""Symbolic derivation of the 3-RRR forward-kinematics sextic (paper §2.2.2, eq. (12)).

With the actuated angles θ fixed, each leg of a 3-RRR reduces to a fixed elbow ``e_i``
and a passive link of length ``r_i``: the platform vertex ``p_i`` must lie on the circle
``|p_i - e_i| = r_i``. Writing ``p_i = p1 + R(α) P_i`` (``P_i`` the vertex in the platform
frame, ``P_1 = 0``) gives three circle equations ``E_i(p1, α) = 0``.

* ``E_2 - E_1`` and ``E_3 - E_1`` are *linear* in ``p1 = (x, y)``; Cramer's rule gives
  ``x = N_x / D``, ``y = N_y / D`` with ``N_x, N_y, D`` polynomials in ``c = cos α``,
  ``s = sin α``.
* Substituting into ``E_1`` and reducing with ``c² = 1 - s²`` leaves
  ``F(c, s) = f(s) + c·g(s)`` of total degree 3.
* With ``c = (1 - t²)/(1 + t²)``, ``s = 2t/(1 + t²)``, ``t = tan(α/2)``, the numerator
  ``(1 + t²)³ F`` is a polynomial of degree 6 in ``t``: the paper's eq. (12). Its leading
  coefficient is ``F`` at ``α = π``, so it vanishes when ``α = π`` is a solution.

The paper's printed coefficients contain misprints, so they are re-derived here. To keep
the expressions short, both frames are normalised (the caller rotates into them):

* the world frame has its origin at elbow 1 and its x axis through elbow 2, so the elbows
  are ``e1 = 0``, ``e2 = (d2x, 0)``, ``e3 = (d3x, d3y)``;
* the platform frame has its origin at vertex 1 and its x axis through vertex 2, so the
  vertices are ``P1 = 0``, ``P2 = (p2x, 0)``, ``P3 = (p3x, p3y)``;
* ``α`` is then the angle of ``p1 → p2`` in the normalised world frame.

Run ``python -m pkmlab.codegen.rrr3_sextic`` to regenerate
``pkmlab/kernels/rrr3_sextic.py``; ``--check`` exits non-zero when the committed file
is not current. The test suite checks the committed file against a fresh derivation.
"""

from __future__ import annotations

import argparse
import sys
from pathlib import Path

import sympy as sp
from sympy.printing.precedence import PRECEDENCE
from sympy.printing.pycode import PythonCodePrinter

#: Symbols of the generated functions, in argument order.
INPUT_NAMES = ("d2x", "d3x", "d3y", "r1", "r2", "r3", "p2x", "p3x", "p3y")

GENERATED_PATH = Path(__file__).resolve().parents[1] / "kernels" / "rrr3_sextic.py"


def derive():
    """Return the derivation as ``(numerators, cubic, sextic, symbols)``.

    * ``numerators``: ``{"nx": N_x, "ny": N_y, "dd": D}``, polynomials in ``c, s`` (reduced on
      the unit circle) with vertex ``p1 - e1 = (N_x/D, N_y/D)``.
    * ``cubic``: ``{(i, j): k_ij}``, the coefficients of ``F(c, s) = Σ k_ij c^i s^j`` (``i ≤ 1``,
      ``i + j ≤ 3``) in the inputs ``INPUT_NAMES``.
    * ``sextic``: ``a_0 … a_6`` of ``a_0 t⁶ + … + a_6 = 0`` (highest degree first, eq. (12)) as
      expressions in symbols ``k_ij``.
    """
    syms = sp.symbols(" ".join(INPUT_NAMES), real=True)
    d2x, d3x, d3y, r1, r2, r3, p2x, p3x, p3y = syms
    d2y = p2y = sp.Integer(0)  # normalised frames, see the module docstring
    c, s, x, y, t = sp.symbols("c s x y t", real=True)

    def rotate(px, py):
        return sp.Matrix([c * px - s * py, s * px + c * py])

    p1 = sp.Matrix([x, y])
    v2 = p1 + rotate(p2x, p2y) - sp.Matrix([d2x, d2y])
    v3 = p1 + rotate(p3x, p3y) - sp.Matrix([d3x, d3y])
    e1 = p1.dot(p1) - r1**2
    e2 = v2.dot(v2) - r2**2
    e3 = v3.dot(v3) - r3**2

    lin2 = sp.expand(e2 - e1)  # linear in x, y
    lin3 = sp.expand(e3 - e1)
    a = sp.Matrix([[lin2.coeff(x), lin2.coeff(y)], [lin3.coeff(x), lin3.coeff(y)]])
    b = -sp.Matrix([lin2.subs({x: 0, y: 0}), lin3.subs({x: 0, y: 0})])
    nx = _reduce_cs(b[0] * a[1, 1] - a[0, 1] * b[1], c, s)
    ny = _reduce_cs(a[0, 0] * b[1] - a[1, 0] * b[0], c, s)
    dd = _reduce_cs(a.det(), c, s)

    # E_1 with x = N_x/D, y = N_y/D, times D², reduced on the unit circle.
    poly_cs = sp.Poly(_reduce_cs(nx**2 + ny**2 - r1**2 * dd**2, c, s), c, s)
    assert poly_cs.total_degree() <= 3, "the reduced equation should be cubic in (c, s)"
    cubic = {monom: sp.expand(poly_cs.coeff_monomial(c ** monom[0] * s ** monom[1])) for monom in MONOMIALS}

    # t = tan(α/2): (1 + t²)³ c^i s^j = (1 - t²)^i (2t)^j (1 + t²)^(3-i-j).
    numerator = sum(
        _k_symbol(i, j) * (1 - t**2) ** i * (2 * t) ** j * (1 + t**2) ** (3 - i - j)
        for i, j in MONOMIALS
    )
    poly_t = sp.Poly(sp.expand(numerator), t)
    sextic = [sp.expand(poly_t.coeff_monomial(t**n)) for n in range(6, -1, -1)]
    return {"nx": nx, "ny": ny, "dd": dd}, cubic, sextic, syms + (c, s)


#: Monomials ``c^i s^j`` of the reduced equation ``F(c, s) = 0``.
MONOMIALS = ((0, 0), (1, 0), (0, 1), (1, 1), (0, 2), (1, 2), (0, 3))


def _k_symbol(i, j):
    return sp.Symbol(f"k{i}{j}", real=True)


def _reduce_cs(expr, c, s):
    """Expand and reduce modulo ``c² + s² - 1`` so that ``c`` appears at most linearly."""
    return sp.expand(sp.rem(sp.expand(expr), c**2 + s**2 - 1, c))


def _power_products(base: str, exponent: int) -> str:
    """``base**exponent`` as the products Numba computes it by (its power by a constant integer: repeated squaring,
    the squares of the exponent's set bits multiplied in from the lowest): ``x**3`` is ``(x*(x*x))``."""
    factors, square = [], base
    while True:
        if exponent & 1:
            factors.append(square)
        exponent >>= 1
        if not exponent:
            return factors[0] if len(factors) == 1 else "(" + "*".join(factors) + ")"
        square = f"({square}*{square})"


class _NumbaPowers(PythonCodePrinter):
    """Python code whose integer powers are written as the products the compiled code computes them by: the
    kernels then give the same numbers bit for bit run by Python (Python's ``pow`` rounds once), which the
    forward kinematics run interpreted at a run's start relies on (:class:`pkmlab._compile_cache.InterpretedFirst`)."""

    def _print_Pow(self, expr, rational=False):
        if expr.exp.is_Integer and abs(expr.exp) > 1:  # (a negative power: Numba divides 1.0 by the products)
            products = _power_products(self.parenthesize(expr.base, PRECEDENCE["Pow"]), abs(int(expr.exp)))
            return products if expr.exp > 0 else f"(1.0/{products})"
        return super()._print_Pow(expr, rational=rational)


def _code(expr) -> str:
    return _NumbaPowers().doprint(expr)


def _emit(lines, signature, doc, outputs, out_comments=None, prelude=()):
    lines += ["", "", "@njit(cache=True)", f"def {signature}:", f'    """{doc}"""']
    lines += [f"    {line}" for line in prelude]
    replacements, reduced = sp.cse(outputs, symbols=sp.numbered_symbols("w"), order="canonical")
    for sym, expr in replacements:
        lines.append(f"    {sym} = {_code(expr)}")
    for k, expr in enumerate(reduced):
        comment = f"  # {out_comments[k]}" if out_comments else ""
        lines.append(f"    out[{k}] = {_code(expr)}{comment}")


def generate_source() -> str:
    """The text of ``rrr3_sextic.py`` from a fresh derivation."""
    numerators, cubic, sextic, _ = derive()
    args = ", ".join(INPUT_NAMES)
    lines = [
        '"""GENERATED by ``python -m pkmlab.codegen.rrr3_sextic`` -- do not edit.',
        "",
        "Forward-kinematics sextic of the planar 3-RRR (paper eq. (12)); see",
        "``pkmlab.codegen.rrr3_sextic`` for the derivation and the meaning of the inputs.",
        f"Derived with SymPy {sp.__version__}.",
        '"""',
        "",
        "from .._compile_cache import njit",
    ]
    _emit(
        lines,
        f"cubic_coefficients({args}, out)",
        "Write k_ij of F(c, s) = sum k_ij c^i s^j = 0 into out[0:7], in the order of MONOMIALS.",
        [cubic[m] for m in MONOMIALS],
        [f"k{i}{j}" for i, j in MONOMIALS],
    )
    _emit(
        lines,
        "sextic_coefficients(k, out)",
        "Write a_0..a_6 of a_0 t^6 + ... + a_6 = 0, t = tan(alpha/2), from k = out of cubic_coefficients.",
        sextic,
        prelude=[f"k{i}{j} = k[{n}]" for n, (i, j) in enumerate(MONOMIALS)],
    )
    _emit(
        lines,
        f"vertex1_numerators({args}, c, s, out)",
        "Write (N_x, N_y, D) with vertex p1 - e1 = (N_x/D, N_y/D) at c = cos(alpha), s = sin(alpha).",
        [numerators["nx"], numerators["ny"], numerators["dd"]],
    )
    return "\n".join(lines) + "\n"


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--check", action="store_true", help="fail if the file is not current")
    args = parser.parse_args(argv)
    source = generate_source()
    if args.check:
        current = GENERATED_PATH.read_text() if GENERATED_PATH.exists() else ""
        if current != source:
            print(f"{GENERATED_PATH} is not current: run python -m pkmlab.codegen.rrr3_sextic")
            return 1
        print(f"{GENERATED_PATH} is current")
        return 0
    GENERATED_PATH.write_text(source)
    print(f"wrote {GENERATED_PATH}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
