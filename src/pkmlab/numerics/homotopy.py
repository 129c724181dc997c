"""Polynomial homotopy continuation: many solution paths of a square polynomial system tracked together.

A homotopy ``H(x, t) = 0`` (``n`` equations in ``x ∈ Cⁿ``) deforms a system whose solutions are known
(``t = 1``) into the one to solve (``t = 0``). Each known solution is followed along ``t`` — a
fourth-order Runge–Kutta predictor on the Davidenko equation ``dx/dt = −H_x⁻¹ H_t`` and a Newton corrector
that must contract fast, else the step is halved — each path with its own adaptive step. A path
stops where it reaches ``t = 0``, where it diverges (its ``|x|`` beyond a bound: a solution of the start
system with none at the target, gone to infinity) or where its step has to shrink below ``1e-9 t``
(near a singular endpoint). The paths are tracked by compiled code, shared among the cores
(:func:`pkmlab.numerics.tracker.track_paths`), on a straight-line program of the family
(:mod:`pkmlab.numerics.straight_line`): a family is data, and one compiled tracker serves every machine.

What this module offers on top of tracking:

* :func:`parameter_homotopy` — the straight line ``p(t) = t p₀ + (1 − t) p₁`` in the parameters of a
  family ``F(x; p)``: from a generic complex ``p₀`` it meets no singular system for ``t ∈ (0, 1]`` with
  probability one (the discriminant is of real codimension two), so every isolated solution at ``p₁`` is
  the end of a path from the solutions at ``p₀`` (Morgan and Sommese's coefficient-parameter theorem);
* :func:`monodromy_solve` — the solutions at a generic ``p₀`` from a single one: loops
  ``p₀ → p_a → p_b → p₀`` through random complex parameters permute the solutions, and the new
  endpoints are kept, until several loops in a row find none (the stopping rule of monodromy solvers
  such as HomotopyContinuation.jl's, stated with the count it reached);
* :func:`block_solutions` — every solution of a block of equations that no parameter enters, by a
  total-degree homotopy (Bézout's count of paths): a generic instance's monodromy starts from each
  (:func:`generic_instance`), where its loops would reach them slowly.

Why pkmlab's own tracker and not a solver library: Bertini 2's Python bindings (``bertini`` 2.0 on the
package registry) failed on a three-equation system (a precision mismatch raised by its Cauchy end
game) and are GPL-licensed; PHCpack's ``phcpy`` is not on the registry; HomotopyContinuation.jl is
Julia. The systems pkmlab solves are small (up to about ten unknowns) and their paths few: a compiled
tracker on a straight-line program follows a machine's 16 to 40 paths in some 10 to 30 ms.

Reference: A. J. Sommese and C. W. Wampler, *The Numerical Solution of Systems of Polynomials Arising
in Engineering and Science*, World Scientific, 2005 (chapters 7, 10 and 15).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

import numpy as np

from .straight_line import Program

#: Most predictor-corrector iterations per path.
MAX_STEPS = 4000
#: A path whose |x| exceeds this (relative to the system's scale) has gone to infinity.
DIVERGED = 1e7


def batched_solve(J: np.ndarray, rhs: np.ndarray) -> np.ndarray:
    """Batched ``J⁻¹ rhs``; a singular matrix gives NaN for its path instead of an exception."""
    try:
        return np.linalg.solve(J, rhs[..., None])[..., 0]
    except np.linalg.LinAlgError:
        out = np.full_like(rhs, np.nan)
        for k in range(J.shape[0]):
            try:
                out[k] = np.linalg.solve(J[k], rhs[k])
            except np.linalg.LinAlgError:
                pass
        return out


@dataclass(frozen=True)
class Family:
    """A family of square polynomial systems ``F(x; p) = 0`` (``n`` equations in ``x ∈ Cⁿ``, parameters
    ``p ∈ Cᵐ``) as a :class:`~pkmlab.numerics.straight_line.Program` of the inputs ``(x, p)`` whose outputs are
    ``F`` (n), ``∂F/∂x`` (n × n, by rows) and ``∂F/∂p`` along the first ``moving`` parameters (n × moving) — the
    ones a homotopy moves. ``scale`` is the size of a solution (what "diverged" and "converged" are relative
    to). ``block`` is, for an offset family, a block of its equations that no parameter but their offsets enters,
    in as many unknowns, with its total-degree homotopy (:class:`Block`); None where it has none."""

    program: Program
    n: int
    moving: int
    scale: float = 1.0
    block: Block | None = None

    def _outputs(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        x = np.asarray(x, dtype=complex)
        p = np.broadcast_to(np.asarray(p, dtype=complex), (x.shape[0], np.shape(p)[-1]))
        return self.program(np.concatenate([x, p], axis=1))

    def F(self, x: np.ndarray, p: np.ndarray) -> np.ndarray:
        """``F`` at the rows of ``x`` (P, n) and ``p`` (P, m) or (m,): (P, n)."""
        return self.F_and_jacobian(x, p)[0]

    def F_and_jacobian(self, x: np.ndarray, p: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """``F`` (P, n) and ``∂F/∂x`` (P, n, n) at the rows of ``x`` and ``p``, from one run of the program."""
        n = self.n
        out = self._outputs(x, p)
        return out[:, :n], out[:, n:n + n * n].reshape(-1, n, n)


@dataclass(frozen=True)
class Block:
    """A block of an offset family's equations (indices ``equations``) in as many of its unknowns (``unknowns``)
    that no parameter but their offsets enters, and its total-degree homotopy: the family
    ``λ (F_E(u) − β) + (1 − λ) γ (u_i^{d_i} − 1)`` in ``u`` with parameters ``(λ, β)`` (``degrees`` the
    ``d_i``)."""

    equations: tuple[int, ...]
    unknowns: tuple[int, ...]
    degrees: tuple[int, ...]
    homotopy: Family


#: The largest parameter-free block :func:`offset_family` looks for (equations).
BLOCK_SIZE = 4
#: The total-degree homotopy's ``γ`` (the gamma trick: a random complex number, fixed so that it is reproducible).
GAMMA = complex(0.6312, -0.7756)


def _parameter_free_block(equations, unknowns, parameters):
    """The first smallest set of ``equations`` that no parameter enters, in as many ``unknowns`` and of more than
    one solution (a nonlinear one), as ``(equation indices, unknown indices, degrees)``; None where there is none."""
    import itertools

    import sympy as sp

    params, names = set(parameters), list(unknowns)
    symbols = [sp.sympify(e).free_symbols for e in equations]
    free = [(k, frozenset(s & set(names))) for k, s in enumerate(symbols) if not s & params]
    for size in range(1, BLOCK_SIZE + 1):
        for combo in itertools.combinations(free, size):
            used = frozenset().union(*(v for _k, v in combo))
            if len(used) != size:
                continue
            order = [u for u in names if u in used]
            degrees = [sp.Poly(equations[k], *order).total_degree() for k, _v in combo]
            if max(degrees) > 1:
                return tuple(k for k, _v in combo), tuple(names.index(u) for u in order), tuple(degrees)
    return None


def offset_family(name: str, equations, unknowns, parameters, scale: float = 1.0) -> Family:
    """The offset family ``F(z; p) − b`` of the SymPy ``equations`` in ``unknowns`` and ``parameters`` (both moving:
    the form :func:`generic_instance` solves), its straight-line program derived once and kept in the cache folder
    as ``name`` (:func:`~pkmlab.numerics.straight_line.cached_program`); with its parameter-free block's
    total-degree homotopy where it has one (:class:`Block`)."""
    import sympy as sp

    from .straight_line import cached_program, compile_program

    n = len(unknowns)

    def derive():
        offsets = list(sp.symbols(f"b0:{n}"))
        moving = [*parameters, *offsets]
        F = sp.Matrix([e - b for e, b in zip(equations, offsets, strict=True)])
        return compile_program([*F, *F.jacobian(unknowns), *F.jacobian(moving)], [*unknowns, *moving])

    found = _parameter_free_block(equations, unknowns, parameters)
    block = None
    if found is not None:
        rows, columns, degrees = found
        u = [unknowns[c] for c in columns]

        def derive_block():
            lam, beta = sp.Symbol("lam"), list(sp.symbols(f"beta0:{len(rows)}"))
            G = sp.Matrix([lam * (equations[r] - b) + (1 - lam) * GAMMA * (x ** d - 1)
                           for r, b, x, d in zip(rows, beta, u, degrees, strict=True)])
            moving = [lam, *beta]
            return compile_program([*G, *G.jacobian(u), *G.jacobian(moving)], [*u, *moving])

        homotopy = Family(cached_program(f"{name}-block", derive_block), len(rows), 1 + len(rows), scale=scale)
        block = Block(rows, columns, degrees, homotopy)
    return Family(cached_program(name, derive), n, len(parameters) + n, scale=scale, block=block)


def block_solutions(block: Block, beta: np.ndarray) -> Endpoints:
    """Every solution of a parameter-free ``block`` (:class:`Block`) at its offsets ``beta``: the endpoints of its
    total-degree homotopy, one path from each of the ``∏ d_i`` solutions of ``u_i^{d_i} = 1`` (Bézout's count:
    every isolated solution is the end of one)."""
    import itertools

    roots = [np.exp(2j * np.pi * np.arange(d) / d) for d in block.degrees]
    starts = np.array(list(itertools.product(*roots)), dtype=complex)
    beta = np.asarray(beta, dtype=complex)
    return parameter_homotopy(block.homotopy, starts, np.concatenate([[0.0], beta]), np.concatenate([[1.0], beta]))


def _block_starts(family: Family, z0: np.ndarray, p0: np.ndarray) -> np.ndarray:
    """Solutions of the offset family at ``p0`` (its parameters, then its offsets): ``z0`` and one more for each
    other solution of its parameter-free block (:class:`Block`). The block's solutions at its offsets, every one,
    by its total-degree homotopy (complete: Bézout's count of paths), each put into ``z0`` in place of the block's
    unknowns — a solution at other offsets of the rest — and carried to ``p0`` by a parameter homotopy of the
    rest's offsets (the block's stay, and so do its unknowns). Monodromy starts from these: its loops reach a
    block's solutions from one another only round branch points that can lie far out (a 3-CRR's orientation
    rows, which no actuator moves)."""
    block = family.block
    m = len(p0) - family.n
    ends = block_solutions(block, p0[m + np.array(block.equations)])
    solved = distinct(ends.x[ends.regular], family.scale)
    z = np.repeat(z0[None], len(solved), axis=0)
    z[:, list(block.unknowns)] = solved
    offsets = family.F(z, np.concatenate([p0[:m], np.zeros(family.n)]))
    carried = parameter_homotopy(family, z, np.concatenate([np.broadcast_to(p0[:m], (len(z), m)), offsets], axis=1),
                                 p0)
    return distinct(np.vstack([z0[None], carried.x[carried.regular]]), family.scale)


def newton_polish(family: Family, x: np.ndarray, p: np.ndarray, iterations: int = 6):
    """Newton's method on ``F(x; p) = 0`` from ``x`` (P, n); returns the points, whether each converged to a
    regular solution (last correction at round-off, a well-conditioned Jacobian)."""
    x = np.array(x, dtype=complex)
    last = np.full(x.shape[0], np.inf)
    with np.errstate(all="ignore"):
        for _ in range(iterations):
            F, jacobian = family.F_and_jacobian(x, p)
            dx = batched_solve(jacobian, -F)
            bad = ~np.isfinite(dx).all(axis=1)
            dx[bad] = 0
            last = np.where(bad, np.inf, np.linalg.norm(dx, axis=1))
            x = x + dx
        sv = np.linalg.svd(family.F_and_jacobian(x, p)[1], compute_uv=False)
    norm = np.maximum(np.linalg.norm(x, axis=1), family.scale)
    regular = (last <= 1e-10 * norm) & (sv[:, -1] > 1e-12 * sv[:, 0]) & np.isfinite(x).all(axis=1)
    return x, regular


def distinct(points: np.ndarray, scale: float, tol: float = 1e-7) -> np.ndarray:
    """The rows of ``points`` without repeats (two within ``tol · scale`` are one)."""
    out: list[np.ndarray] = []
    for v in points:
        if not out or np.linalg.norm(np.array(out) - v, axis=1).min() > tol * scale:
            out.append(v)
    return np.array(out) if out else np.zeros((0, points.shape[1]), dtype=complex)


class Endpoints(NamedTuple):
    """The ends of a parameter homotopy's paths: the points ``x`` (P, n), polished by Newton's method at the
    target; whether each is a regular solution there, went to infinity, and reached the target at all (a path
    that stopped short of it — near a singular endpoint or stalled — is neither regular nor diverged)."""

    x: np.ndarray
    regular: np.ndarray
    diverged: np.ndarray
    reached: np.ndarray


def parameter_homotopy(family: Family, solutions: np.ndarray, p0: np.ndarray, p1: np.ndarray) -> Endpoints:
    """The endpoints at ``p₁`` of the paths from ``solutions`` (P, n) at ``p₀`` (:class:`Endpoints`), each
    polished by Newton's method at ``p₁``; ``p0`` and ``p1`` are (m,), shared by every path, or (P, m), one row
    per path (many targets at once). The paths are tracked by the compiled tracker
    (:func:`pkmlab.numerics.tracker.track_paths`)."""
    from .tracker import track_paths

    program = family.program
    solutions = np.ascontiguousarray(solutions, dtype=complex)
    rows = (solutions.shape[0], np.shape(p0)[-1])
    # copies, writable whatever the caller passed: the tracker is compiled for one kind of array
    p0, p1 = (np.broadcast_to(np.asarray(p, dtype=complex), rows).copy() for p in (p0, p1))
    x, t, diverged = track_paths(program.code, program.register_file(), program.outputs, family.n, family.moving,
                                 solutions, p0, p1, 0.0, float(family.scale), DIVERGED, MAX_STEPS, 1e-3)
    x, regular = newton_polish(family, x, p1)
    return Endpoints(x, regular & ~diverged, diverged, diverged | (t <= 1e-15))


class TooManySolutions(Exception):
    """Monodromy found more solutions than the caller takes on: ``count`` after ``loops`` loops (and more may
    follow)."""

    def __init__(self, count: int, loops: int):
        super().__init__(f"more than {count - 1} solutions ({count} after {loops} monodromy loops)")
        self.count, self.loops = count, loops


def monodromy_solve(family: Family, x0: np.ndarray, p0: np.ndarray, rng: np.random.Generator, *,
                    known: np.ndarray | None = None, free: int | None = None, stale_loops: int = 8,
                    max_loops: int = 100, max_solutions: int | None = None):
    """Every solution at the generic complex parameters ``p0`` (m,) found by monodromy from one, ``x0`` (n,)
    (or from ``known`` solutions), loops moving only the first ``free`` parameters (all by default).

    Returns ``(solutions (N, n), loops)``: the loops run. Stops after ``stale_loops`` loops in a row
    add nothing. A solve that lasts says how far it is on stderr every
    :data:`~pkmlab.progress.STATUS_EVERY` seconds (a system of many solutions takes minutes); one that finds more
    than ``max_solutions`` raises :class:`TooManySolutions`."""
    import time

    from ..progress import STATUS_EVERY, notice

    sols = (x0[None, :] if known is None else known).astype(complex)
    stale, loops = 0, 0
    said = time.monotonic()
    m = len(p0)
    free = m if free is None else free
    while stale < stale_loops and loops < max_loops:
        loops += 1
        pa, pb = p0.copy(), p0.copy()
        for p in (pa, pb):
            p[:free] += (rng.standard_normal(free) + 1j * rng.standard_normal(free)) * np.maximum(np.abs(p0[:free]),
                                                                                               1.0)
        x = sols
        ok = np.ones(len(x), dtype=bool)
        for start, end in ((p0, pa), (pa, pb), (pb, p0)):
            x, regular, _div, _reached = parameter_homotopy(family, x, start, end)
            ok &= regular
        merged = distinct(np.concatenate([sols, x[ok]]), family.scale)
        stale = stale + 1 if len(merged) == len(sols) else 0
        sols = merged
        if max_solutions is not None and len(sols) > max_solutions:
            raise TooManySolutions(len(sols), loops)
        if time.monotonic() - said >= STATUS_EVERY:
            notice(f"monodromy: {len(sols)} solutions after {loops} loops ({stale} in a row found none; it stops "
                   f"at {stale_loops})")
            said = time.monotonic()
    return sols, loops


#: Monodromy loops in the problem's own parameters that must find no new solution of a generic instance (each
#: costs some 20–40 ms for a machine: ten of them add a few tenths of a second to its first solve).
CHECK_LOOPS = 10


def generic_instance(family: Family, n: int, m: int, rng: np.random.Generator, check_loops: int = CHECK_LOOPS,
                     max_solutions: int | None = None):
    """Every solution of ``F(z; θ) = 0`` at generic complex parameters ``θ₁`` (m,), for an offset family
    ``F(z; θ) − b`` (parameters ``(θ, b)``, ``b`` of length ``n``): a random complex ``z₀`` solves it at
    ``b₀ = F(z₀; θ₀)``; monodromy finds the others at ``(θ₀, b₀)`` (starting too from one solution per solution
    of a parameter-free block, where the family has one: :func:`_block_starts`); a parameter homotopy carries them to
    ``(θ₁, 0)``, where the paths that end regular are kept (the offset family has more solutions than the
    problem: the others go to infinity or to singular points); then more monodromy loops in ``θ`` alone until
    ``check_loops`` in a row find nothing new. Returns ``(solutions, (θ₁, 0), loops)``; raises
    :class:`TooManySolutions` where the offset family has more than ``max_solutions``."""
    z0 = (rng.standard_normal(n) + 1j * rng.standard_normal(n)) * 0.5
    theta0 = rng.standard_normal(m) + 1j * rng.standard_normal(m)
    b0 = family.F(z0[None], np.concatenate([theta0, np.zeros(n)])[None])[0]
    p0 = np.concatenate([theta0, b0])
    known = _block_starts(family, z0, p0) if family.block is not None else None
    offset_solutions, loops = monodromy_solve(family, z0, p0, rng, known=known, max_solutions=max_solutions)
    p1 = np.concatenate([rng.standard_normal(m) + 1j * rng.standard_normal(m), np.zeros(n)])
    ends = parameter_homotopy(family, offset_solutions, p0, p1)
    solutions = distinct(ends.x[ends.regular], family.scale)
    if not len(solutions):
        return solutions, p1, loops
    checked, more = monodromy_solve(family, solutions[0], p1, rng, known=solutions, free=m, stale_loops=check_loops)
    return checked, p1, loops + more


def cached_arrays(name: str, compute, notice_text: str) -> dict:
    """``compute()``'s arrays (a dict), kept in pkmlab's cache folder as ``name``: a later process reads them
    instead of computing them again (a generic instance's monodromy, seconds). A process that needs them while
    another computes them waits for its result (the lock of compiled kernels, shared by processes).
    ``notice_text`` is said, once, when they are computed."""
    from .._compile_cache import CACHE_DIR, cache_lock
    from ..outputs import atomic_file
    from ..progress import notice

    path = CACHE_DIR / "generic" / f"{name}.npz"
    with cache_lock(f"generic/{name}"):
        if path.exists():
            with np.load(path) as data:
                return {k: data[k] for k in data.files}
        notice(notice_text)
        arrays = compute()
        with atomic_file(path) as tmp, open(tmp, "wb") as f:
            np.savez(f, **arrays)
    return arrays
