"""Linear algebra on stacks of small matrices (K, m, m): a path's Jacobians at once."""

from __future__ import annotations

import functools
from typing import NamedTuple

import numpy as np

from .._compile_cache import njit
from .closed_chain import lu_factor, lu_solve_factored

#: A matrix whose condition number (1-norm) reaches this is treated as singular.
CONDITION_LIMIT = 1e12
#: :func:`solve_factored_blocks` solves with the blocks' factors from this size of the matrices; below it with NumPy's
#: solve of the whole matrices (LAPACK's ``gesv``), whose numbers the planar machines of three legs — the paper's
#: among them — keep bit for bit: the paper's continuous-time run, integrated to ``rtol = 1e-12``, moves by 2e-12
#: with another factorization's round-off. Measured interleaved on the presets' paths (a thousand and more samples):
#: the Delta's 9×9 in three blocks of three, its run's set-up 7.3 → 6.3 ms; the Stewart platform's 18×18 in six,
#: 19.9 → 14.0 ms.
BLOCK_SOLVE_FROM = 7


class BlockFactors(NamedTuple):
    """The LU factors of each diagonal block of a stack of block-diagonal matrices (:func:`factor_blocks`)."""

    #: The rows and the columns in block order, and each block's end in them (:func:`diagonal_blocks`).
    rows: np.ndarray
    cols: np.ndarray
    ends: np.ndarray
    #: (K, m, m): each matrix's blocks factored by :func:`~pkmlab.numerics.closed_chain.lu_factor`, block ``b`` at
    #: ``[ends[b-1]:ends[b], ends[b-1]:ends[b]]`` in block order (zeros elsewhere); (K, m): their pivots, in the block.
    #: None below :data:`BLOCK_SOLVE_FROM` coordinates, where :func:`solve_factored_blocks` solves with NumPy.
    lu: np.ndarray | None
    piv: np.ndarray | None
    #: The index of the first singular matrix (:func:`first_singular`), -1 if none is; the factors are those of the
    #: matrices before it.
    singular: int


def first_singular(a: np.ndarray, limit: float = CONDITION_LIMIT) -> int:
    """The index of the first singular matrix of a stack of square matrices ``a`` (K, m, m), or -1 if none is.

    A matrix is singular when its condition number in the 1-norm, ``‖A‖₁ ‖A⁻¹‖₁``, is not below ``limit`` (an
    exactly singular one's is infinite). The two condition numbers of an ``m × m`` matrix, 1- and 2-norm, differ by
    a factor of at most ``m``: a matrix within that factor of the limit may be judged either way by the two.

    A closed chain's Jacobians are often block diagonal (each leg's loop closures in its own coordinates, its rows
    and columns wherever the coordinates put them): the condition number is then that of the blocks
    (:func:`diagonal_blocks` of the entries nonzero in any matrix of the stack — an entry zero in every matrix is
    zero in each), found block by block, compiled: NumPy's own (``np.linalg.cond``) inverts each whole matrix and
    spends about a microsecond a matrix on its bookkeeping.
    :func:`factor_blocks` judges the same way and keeps the factors, for solves.
    """
    return _factored(a, limit, None, keep=False).singular


def factor_blocks(a: np.ndarray, limit: float = CONDITION_LIMIT, blocks=None, columns=None) -> BlockFactors:
    """:func:`first_singular` of the stack ``a`` (K, m, m), and the LU factors of each matrix's diagonal blocks up to
    that one, for :func:`solve_factored_blocks`: one factorization of a path's Jacobians for its singularity check
    and every right-hand side after it (kept from :data:`BLOCK_SOLVE_FROM` coordinates, where the solve uses them).
    ``blocks``: :func:`diagonal_blocks` of the matrices' pattern, where the caller has them. ``columns`` (m,): the
    matrices are these columns of ``a`` (K, m, M), read in place (a path's Jacobians of all its coordinates, of
    which the solves need some: no copy of them).

    Partial pivoting never picks a row outside a column's block (its entries there are zero), and the elimination
    adds only exact zeros to a block from outside it: the blocks' solutions are the whole matrix's, to round-off, for
    a fraction of the work (a leg's closures, two to three equations, instead of the whole machine's).
    """
    m = np.shape(a)[-2]
    return _factored(a, limit, blocks, keep=m >= BLOCK_SOLVE_FROM, columns=columns)


def _factored(a: np.ndarray, limit: float, blocks, keep: bool, columns=None) -> BlockFactors:
    """:func:`factor_stack_blocks` of the stack ``a`` (or of its ``columns``), its factors kept or not (a scratch
    matrix then)."""
    a = np.ascontiguousarray(a, dtype=float)
    m = a.shape[1]
    index = np.arange(m) if columns is None else np.arange(a.shape[2])[columns]
    if blocks is None:
        rows, cols, ends = diagonal_blocks(np.any(a != 0.0, axis=0)[:, index])
    else:
        rows, cols, ends = blocks
    shape = (a.shape[0] if keep else 1, m, m)
    lu, piv = np.zeros(shape), np.zeros(shape[:2], np.int64)
    singular = factor_stack_blocks(a, rows, index[cols], ends, limit, lu, piv, keep)
    return BlockFactors(rows, cols, ends, lu if keep else None, piv if keep else None, singular)


def solve_factored_blocks(factors: BlockFactors, a: np.ndarray | None, b: np.ndarray) -> np.ndarray:
    """``x`` (K, m) with ``a x = b`` for each matrix of the stack ``a`` (K, m, m) factored by :func:`factor_blocks`
    (none singular) and ``b`` (K, m): with the blocks' factors from :data:`BLOCK_SOLVE_FROM` coordinates (``a`` is
    not read: None will do), by NumPy's solve of the whole matrices below it."""
    if factors.singular >= 0:
        raise ValueError(f"matrix {factors.singular} of the stack is singular: no solution")
    if factors.lu is None:
        return np.linalg.solve(a, b[..., None])[..., 0]
    x = np.empty(b.shape)
    solve_stack_blocks(factors.lu, factors.piv, factors.rows, factors.cols, factors.ends,
                       np.ascontiguousarray(b, dtype=float), x)
    return x


def diagonal_blocks(nonzero: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """An order of the rows and one of the columns that make a square sparsity pattern block diagonal.

    ``nonzero`` (m, m) marks the entries that may be nonzero. Returns ``(rows, cols, ends)``: the rows and the
    columns in block order, and each block's end in them. The blocks are the connected parts of the graph whose
    edges are the nonzero entries (rows and columns keep their order within a block). Where a part has more columns
    than rows the matrices are singular: then one block, the whole matrix, whose factorization finds them so.
    A pattern seen before is not searched again (a continuous-time run asks for one configuration's, thousands
    of times); each call gets arrays of its own.
    """
    nonzero = np.asarray(nonzero, dtype=bool)
    return tuple(part.copy() for part in _pattern_blocks(nonzero.shape[0], nonzero.tobytes()))


@functools.lru_cache(maxsize=64)
def _pattern_blocks(m: int, packed: bytes) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """:func:`diagonal_blocks` of the (m, m) pattern whose bytes are ``packed``."""
    nonzero = np.frombuffer(packed, dtype=bool).reshape(m, m)
    parent = list(range(2 * m))  # rows 0 .. m-1, columns m .. 2m-1

    def root(i: int) -> int:
        while parent[i] != i:
            parent[i] = parent[parent[i]]
            i = parent[i]
        return i

    for i, j in zip(*np.nonzero(nonzero), strict=True):
        parent[root(int(i))] = root(m + int(j))
    roots = [root(i) for i in range(2 * m)]
    parts = list(dict.fromkeys(roots))
    rows = [[i for i in range(m) if roots[i] == part] for part in parts]
    cols = [[j for j in range(m) if roots[m + j] == part] for part in parts]
    if any(len(r) != len(c) for r, c in zip(rows, cols, strict=True)):
        return np.arange(m), np.arange(m), np.array([m])
    return (np.array([i for part in rows for i in part], dtype=np.int64),
            np.array([j for part in cols for j in part], dtype=np.int64),
            np.cumsum([len(part) for part in rows]).astype(np.int64))


@njit(cache=True)
def factor_stack_blocks(a, rows, cols, ends, limit, lu, piv, keep):
    """:func:`factor_blocks` (``keep``: each matrix's factors into ``lu`` (K, m, m), ``piv`` (K, m)) or
    :func:`first_singular` (not ``keep``: ``lu`` (1, m, m), ``piv`` (1, m) scratch) of the stack ``a`` (K, m, M)
    — its matrices the columns ``cols`` of it —, block diagonal in the order ``rows``, ``cols`` (blocks ending at
    ``ends``). A block diagonal matrix's 1-norm is
    the largest of its blocks', and so is its inverse's; each block's by
    :func:`~pkmlab.numerics.closed_chain.lu_factor` (a pivot below ``1e-14`` of the block's largest entry: singular)
    and its inverse's columns. A matrix with a NaN or an infinite entry is singular (its condition number is NaN, as
    NumPy's). Returns the first singular matrix's index, -1 if none is."""
    m = rows.shape[0]
    block, e = np.empty((m, m)), np.empty(m)
    for k in range(a.shape[0]):
        slot = k if keep else 0
        norm, inverse_norm, start = 0.0, 0.0, 0
        for b in range(ends.shape[0]):
            end = ends[b]
            s = end - start
            for r in range(s):
                for c in range(s):
                    v = a[k, rows[start + r], cols[start + c]]
                    if not np.isfinite(v):  # (max() would drop a NaN from the norms, depending on its place)
                        return k
                    block[r, c] = v
            for c in range(s):
                column = 0.0
                for r in range(s):
                    column += abs(block[r, c])
                norm = max(norm, column)
            lu_k, piv_k = lu[slot, start:end, start:end], piv[slot, start:end]
            ok, _det = lu_factor(block, lu_k, piv_k, s)
            if not ok:
                return k
            for c in range(s):  # A⁻¹ e_c
                for r in range(s):
                    e[r] = 1.0 if r == c else 0.0
                lu_solve_factored(lu_k, piv_k, e, s)
                column = 0.0
                for r in range(s):
                    column += abs(e[r])
                inverse_norm = max(inverse_norm, column)
            start = end
        if not norm * inverse_norm < limit:  # (NaN included)
            return k
    return -1


@njit(cache=True)
def solve_stack_blocks(lu, piv, rows, cols, ends, b, x):
    """:func:`solve_factored_blocks`: each block's right-hand side (``b``'s rows in block order) solved with its
    factors, into ``x``'s columns of the block."""
    m = rows.shape[0]
    work = np.empty(m)
    for k in range(b.shape[0]):
        start = 0
        for blk in range(ends.shape[0]):
            end = ends[blk]
            s = end - start
            for r in range(s):
                work[r] = b[k, rows[start + r]]
            lu_solve_factored(lu[k, start:end, start:end], piv[k, start:end], work, s)
            for c in range(s):
                x[k, cols[start + c]] = work[c]
            start = end
