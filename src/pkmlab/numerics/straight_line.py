"""Straight-line programs: a polynomial system and its derivatives as a short list of complex additions,
subtractions, multiplications and divisions that one compiled interpreter evaluates.

Homotopy continuation evaluates a system and its Jacobians some ten times per step of every path. A machine's
forward-kinematics system (:mod:`pkmlab.algorithms.general_fk`) is built from its description at run time, so
compiling it to machine code would cost seconds of compilation per machine. A straight-line program (the
representation Bertini and HomotopyContinuation.jl evaluate) costs nothing to compile: SymPy's common
subexpressions become a table of instructions ``(operation, a, b, destination)`` over a register file
(inputs first, then constants, then intermediate values), and :func:`evaluate` — compiled once for every
machine — runs it. Every instruction has two operands; a SymPy ``Add`` or ``Mul`` of ``k`` terms becomes
``k − 1`` of them, an integer power repeated squaring.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np

#: The operations of an instruction ``(op, a, b, d)``: ``r[d] = r[a] op r[b]``.
ADD, SUB, MUL, DIV = 0, 1, 2, 3


@dataclass(frozen=True)
class Program:
    """A straight-line program: ``code`` (K, 4) int64 instructions (module docstring) over ``registers``
    complex registers, of which the first ``inputs`` are the arguments and ``constants`` (C,) holds the values
    of registers ``inputs … inputs + C − 1``; ``outputs`` (N,) the registers of the results, in order."""

    code: np.ndarray
    registers: int
    inputs: int
    constants: np.ndarray
    outputs: np.ndarray

    def register_file(self) -> np.ndarray:
        """A register file with the constants in place (the arguments and the rest to be written)."""
        r = np.zeros(self.registers, dtype=complex)
        r[self.inputs:self.inputs + len(self.constants)] = self.constants
        return r

    def __call__(self, x: np.ndarray) -> np.ndarray:
        """The outputs at the inputs of each row of ``x`` (..., inputs): (..., N) — the compiled evaluation, for
        tests and for callers outside a compiled loop."""
        from .tracker import evaluate_rows

        x = np.asarray(x, dtype=complex)
        flat = np.ascontiguousarray(x.reshape(-1, self.inputs))
        out = evaluate_rows(self.code, self.register_file(), self.outputs, flat)
        return out.reshape(*x.shape[:-1], len(self.outputs))


def compile_program(outputs, inputs) -> Program:
    """The straight-line program of the SymPy expressions ``outputs`` in the symbols ``inputs``: every output
    a register, shared subexpressions computed once. Raises ValueError for an expression that is no rational
    function of the inputs (a square root of an unknown, a sine)."""
    import sympy as sp

    subs, reduced = sp.cse(list(outputs), symbols=sp.numbered_symbols("_s"), optimizations="basic")
    register: dict = {s: k for k, s in enumerate(inputs)}
    constants: list[complex] = []
    constant_register: dict = {}
    code: list[tuple[int, int, int, int]] = []
    temporaries: list = []  # (expression) in the order they are written, after the constants

    def constant(value) -> int:
        value = complex(value)
        if value not in constant_register:
            constant_register[value] = len(constants)
            constants.append(value)
        return -1 - constant_register[value]  # placed after the inputs once all constants are known

    def new() -> int:
        temporaries.append(None)
        return 1_000_000_000 + len(temporaries) - 1  # placed after the constants

    def op(kind: int, a: int, b: int) -> int:
        d = new()
        code.append((kind, a, b, d))
        return d

    def power(base: int, e: int) -> int:
        result, square = None, base
        while e:
            if e & 1:
                result = square if result is None else op(MUL, result, square)
            e >>= 1
            if e:
                square = op(MUL, square, square)
        return result

    def emit(expr) -> int:
        if expr in register:
            return register[expr]
        if expr.is_number:
            return constant(sp.N(expr, 17))
        if expr.is_Add or expr.is_Mul:
            kind = ADD if expr.is_Add else MUL
            terms = list(expr.args)
            numbers = [t for t in terms if t.is_number]
            rest = [t for t in terms if not t.is_number]
            out = emit(rest[0])
            for t in rest[1:]:
                if kind == ADD and t.could_extract_minus_sign():
                    out = op(SUB, out, emit(-t))
                else:
                    out = op(kind, out, emit(t))
            for t in numbers:
                if kind == MUL and t == -1:
                    out = op(SUB, constant(0), out)
                else:
                    out = op(kind, out, constant(sp.N(t, 17)))
            return out
        if expr.is_Pow and expr.exp.is_Integer:
            e = int(expr.exp)
            base = emit(expr.base)
            if e == 0:
                return constant(1)
            out = power(base, abs(e))
            return op(DIV, constant(1), out) if e < 0 else out
        raise ValueError(f"not a rational function of the inputs: {expr}")

    for symbol, expr in subs:
        register[symbol] = emit(expr)
    results = [emit(e) for e in reduced]

    n_in, n_const = len(inputs), len(constants)

    def placed(r: int) -> int:
        if r < 0:
            return n_in + (-1 - r)
        if r >= 1_000_000_000:
            return n_in + n_const + (r - 1_000_000_000)
        return r

    table = np.array([(k, placed(a), placed(b), placed(d)) for k, a, b, d in code], dtype=np.int64).reshape(-1, 4)
    return Program(table, n_in + n_const + len(temporaries), n_in, np.array(constants, dtype=complex),
                   np.array([placed(r) for r in results], dtype=np.int64))


def cached_program(key: str, build: Callable[[], Program]) -> Program:
    """``build()``'s program, kept in pkmlab's cache folder under ``key``: a later process reads it instead of
    deriving it again (a second or two of SymPy per system). The folder is this version of pkmlab's own, so a
    changed derivation is derived anew."""
    from .._compile_cache import CACHE_DIR
    from ..outputs import atomic_file

    path = CACHE_DIR / "programs" / f"{key}.npz"
    if path.exists():
        with np.load(path) as data:
            return Program(data["code"], int(data["registers"]), int(data["inputs"]), data["constants"],
                           data["outputs"])
    program = build()
    with atomic_file(path) as tmp, open(tmp, "wb") as f:
        np.savez(f, code=program.code, registers=program.registers, inputs=program.inputs,
                 constants=program.constants, outputs=program.outputs)
    return program
